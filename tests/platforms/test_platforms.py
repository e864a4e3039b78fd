"""Every platform Blender runs on, from this x86-64 Linux machine (make test-platforms):

- the six release zips and their wheels (make dist): each zip validated by Blender's tool and
  holding exactly its own platform's wheel; the binaries' static checks (tools/check_binaries.py);
- linux-arm64 under qemu-user and windows-x64 under wine (the official Windows CPython 3.11):
  the native test suite's platform checks (`--platform-checks`), whose golden and platform pixels
  (every kind and formula, every effect, deep zoom, the World, GI, the lenses, every pass, the
  mesh) and math vectors are the x86-64 Linux bits, asserted exactly;
- the linux-x64 release zip installed by Blender's installer in bpy 4.2 and in Python 3.13 /
  bpy 5.2, rendering the same pixels as this machine's development build.
macOS and windows-arm64 binaries cannot run here: static checks only."""
import os
import pathlib
import subprocess
import sys
import tomllib
import zipfile

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
RELEASE = ROOT / "dist" / "release"
WORK = ROOT / "build" / "platforms"
PLATFORMS = ["windows-x64", "windows-arm64", "macos-arm64", "macos-x64", "linux-x64", "linux-arm64"]
VERSION = tomllib.loads((ROOT / "blender_manifest.toml").read_text())["version"]
# The native suite's platform checks (tests/native/conftest.py: REFERENCE_FILES), whose float64
# and arbitrary-precision references of the geometry run on x86-64 only: the core's bits there are
# held to x86-64's by the golden and platform pixels.
NATIVE_PLATFORM_CHECKS = ["tests/native", "--platform-checks"]

sys.path.insert(0, str(ROOT / "tools"))
import cross_build  # noqa: E402


def release_zip(platform):
    return RELEASE / ("unbound-%s-%s.zip" % (VERSION, platform.replace("-", "_")))


def run(args, timeout, env=None):
    proc = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, **(env or {})))
    return proc.returncode, proc.stdout + proc.stderr


@pytest.mark.parametrize("platform", PLATFORMS)
def test_release_zip_holds_only_its_platforms_wheel(platform):
    with zipfile.ZipFile(release_zip(platform)) as z:
        names = z.namelist()
        manifest = tomllib.loads(z.read(next(n for n in names if n.endswith("blender_manifest.toml"))).decode())
    wheels = [pathlib.PurePosixPath(n).name for n in names if n.endswith(".whl")]
    tag = cross_build.TARGETS[platform][1]
    assert wheels == ["unbound_core-%s-cp311-abi3-%s.whl" % (VERSION, tag)]
    # Blender's `build --split-platforms` narrows the platforms in a generated table.
    assert manifest["build"]["generated"]["platforms"] == [platform]


def test_static_checks_of_every_binary():
    rc, out = run([sys.executable, "tools/check_binaries.py"], 300)
    assert rc == 0, out
    assert out.count(" ok") == 6, out


def foreign(platform, args, timeout):
    rc, out = run([sys.executable, "tools/foreign.py", "setup", platform], 900)
    assert rc == 0, out[-3000:]
    return run([sys.executable, "tools/foreign.py", "test", platform, "-q", *args], timeout)


def test_native_suite_on_linux_arm64_under_qemu():
    rc, out = foreign("linux-arm64", NATIVE_PLATFORM_CHECKS, 2400)
    assert rc == 0, out[-5000:]
    assert " passed" in out and "failed" not in out, out[-2000:]


def test_native_suite_on_windows_x64_under_wine():
    rc, out = foreign("windows-x64", NATIVE_PLATFORM_CHECKS, 2400)
    assert rc == 0, out[-5000:]
    assert " passed" in out and "failed" not in out, out[-2000:]


def render_demo_frame(zip_path, out_dir, user_dir, py313=False):
    """One frame of examples/animate_mu.py with `zip_path` installed by Blender's installer into a
    fresh user directory, in bpy 4.2 (the venv) or bpy 5.2 (the Python 3.13 chroot, which sees the
    repository at /src); returns the PNG's pixels."""
    sys.path.insert(0, str(ROOT / "tests" / "blender"))
    from exr import read_png
    for d in (out_dir, user_dir):
        subprocess.run(["rm", "-rf", str(d)], check=True)
    (user_dir / "config").mkdir(parents=True)
    rel = lambda p: os.path.relpath(p, ROOT)  # noqa: E731
    user = "/src/" + rel(user_dir) if py313 else str(user_dir)
    python = ["sh", "tools/py313.sh", "run", "env", "BLENDER_USER_RESOURCES=" + user, "/opt/venv/bin/python"] \
        if py313 else ["env", "BLENDER_USER_RESOURCES=" + user, sys.executable]
    rc, out = run(python + ["examples/animate_mu.py", "--extension", rel(zip_path), "--frames", "5", "5",
                            "--resolution", "96", "54", "--out", rel(out_dir)], 1500)
    assert rc == 0, "%s: %s" % (zip_path.name, out[-3000:])
    pngs = sorted(out_dir.rglob("*.png"))
    assert len(pngs) == 1, out[-2000:]
    return read_png(pngs[0])


def installed_core(user_dir):
    found = sorted(user_dir.rglob("unbound_core/_native.abi3.so"))
    assert len(found) == 1, found
    return found[0].read_bytes()


def wheel_core(platform):
    tag = cross_build.TARGETS[platform][1]
    with zipfile.ZipFile(RELEASE / ("unbound_core-%s-cp311-abi3-%s.whl" % (VERSION, tag))) as z:
        return z.read("unbound_core/_native.abi3.so")


@pytest.mark.parametrize("py313", [False, True], ids=["bpy42", "bpy52"])
def test_linux_release_zip_renders_as_the_development_build(py313):
    """The zig-built manylinux_2_17 core (what ships) against the development build (the host's
    gcc): installed by Blender, loaded from the installed wheel, the same frame to the bit."""
    if py313:
        setup = subprocess.run(["sh", "tools/py313.sh", "setup", "--bpy"], cwd=ROOT, capture_output=True,
                               text=True, timeout=1500)
        assert setup.returncode == 0, setup.stderr[-3000:]
    name = "bpy52" if py313 else "bpy42"
    dev = render_demo_frame(ROOT / "dist" / ("unbound-%s.zip" % VERSION), WORK / (name + "-dev"),
                            WORK / (name + "-dev-user"), py313)
    release = render_demo_frame(release_zip("linux-x64"), WORK / (name + "-release"),
                                WORK / (name + "-release-user"), py313)
    assert installed_core(WORK / (name + "-release-user")) == wheel_core("linux-x64"), \
        "Blender did not load the release wheel's core"
    np.testing.assert_array_equal(release, dev)


def test_release_wheels_are_byte_reproducible(tmp_path):
    """Built again from scratch (a new zig cache, new objects, another directory): the same bytes.
    Two targets of different object formats keep this to a couple of minutes."""
    platforms = ["linux-x64", "macos-arm64"]
    rc, out = run([sys.executable, "tools/cross_build.py", "--out", str(tmp_path / "out"), "--work",
                   str(tmp_path / "work"), "--zig-cache", str(tmp_path / "zig-cache"), *platforms], 1200)
    assert rc == 0, out[-3000:]
    for platform in platforms:
        name = "unbound_core-%s-cp311-abi3-%s.whl" % (VERSION, cross_build.TARGETS[platform][1])
        assert (tmp_path / "out" / name).read_bytes() == (RELEASE / name).read_bytes(), name
