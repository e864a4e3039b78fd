"""A render farm (docs/farm.md): the linux-x64 release zip installed by tools/farm_install.py as a
*system* extension into a directory the workers share (BLENDER_SYSTEM_EXTENSIONS; Blender 4.2+'s
read-only System repository, module bl_ext.system.unbound), and workers that are fresh Blender
processes with empty user directories enabling it the way `blender -b --addons` does.

- bpy 4.2 (PyPI, this venv): worker A renders frames 1-2 of a saved keyframed animation on 1
  thread, worker B frames 2-3 on 2 threads; the shared frame 2 is bit-identical in every pass, the
  add-on runs from the system directory, its core is the system wheel's library (which Blender
  extracts into each worker's own user directory), and the shared directory is left unchanged.
- The real `blender` 4.3 binary (Python 3.13; the Debian trixie chroot of tools/blender_gui.sh):
  `blender -b scene.blend --addons bl_ext.system.unbound -o ... -f 2` and a worker enabling it by
  --python-expr write frames with the same pixels as bpy's.
  With the add-on registered before the file (`--addons` first, or enabled in a worker's saved
  preferences), with or without the guard of docs/farm.md, the first frame rendered is the same
  frame too (it once had the animated values of the frame the file was saved at).
  A worker without the add-on: the guard exits 2 and writes nothing (Blender alone would render
  the frame with EEVEE and exit 0).
- The six per-platform zips installed as one package for a mixed farm: a Linux x86-64 worker picks
  its own wheel out of six.
"""
import ast
import hashlib
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import zipfile

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(not os.environ.get("UNBOUND_PLATFORM_TESTS"),
                                reason="platform tests: run with UNBOUND_PLATFORM_TESTS=1 (make test-platforms)")

ROOT = pathlib.Path(__file__).resolve().parents[2]
HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT / "tests" / "blender"))
from exr import read_exr  # noqa: E402  (OpenImageIO; tests/blender/exr.py)

# Inside the repository: the chroot of the real-Blender test sees it at /src/build/farm.
WORK = ROOT / "build" / "farm"
MODULE = "bl_ext.system.unbound"
RESULT = "FARM_RESULT "
# Variables that would point Blender elsewhere than a worker's defaults: not passed to workers.
# The worker guard (docs/farm.md), read from farm_bpy.py without importing bpy.
GUARD = next(ast.literal_eval(node.value) for node in ast.parse((HERE / "farm_bpy.py").read_text()).body
             if isinstance(node, ast.Assign) and [t.id for t in node.targets] == ["GUARD"])
BLENDER_VARS = ("BLENDER_USER_RESOURCES", "BLENDER_USER_CONFIG", "BLENDER_USER_SCRIPTS", "BLENDER_USER_DATAFILES",
                "BLENDER_USER_EXTENSIONS", "BLENDER_SYSTEM_SCRIPTS", "BLENDER_SYSTEM_EXTENSIONS",
                "BLENDER_SYSTEM_DATAFILES", "BLENDER_SYSTEM_RESOURCES", "XDG_CONFIG_HOME", "PYTHONPATH")


def release_zip(platform):
    zips = sorted((ROOT / "dist" / "release").glob("unbound-*-%s.zip" % platform))
    assert zips, "no dist/release/unbound-*-%s.zip: build the release first (make dist)" % platform
    return zips[-1]


def farm_install(*args):
    proc = subprocess.run([sys.executable, str(ROOT / "tools" / "farm_install.py"), *map(str, args)],
                          capture_output=True, text=True, timeout=120)
    return proc.returncode, proc.stdout + proc.stderr


def snapshot(directory):
    """{relative path: sha256} of everything under directory (files and directories)."""
    out = {}
    for path in sorted(directory.rglob("*")):
        rel = path.relative_to(directory).as_posix()
        out[rel] = hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else "dir"
    return out


def worker(system_dir, home, *args, timeout=300):
    """A fresh bpy 4.2 process with only BLENDER_SYSTEM_EXTENSIONS set and its own empty HOME (so
    its Blender user directory is the default ~/.config/blender/4.2/, empty): farm_bpy.py ARGS."""
    home.mkdir(parents=True)
    env = {k: v for k, v in os.environ.items() if k not in BLENDER_VARS}
    env.update(HOME=str(home), BLENDER_SYSTEM_EXTENSIONS=str(system_dir))
    proc = subprocess.run([sys.executable, str(HERE / "farm_bpy.py"), *map(str, args)], cwd=home, env=env,
                          capture_output=True, text=True, timeout=timeout)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, "worker failed (rc %d):\n%s" % (proc.returncode, out[-6000:])
    lines = [line for line in proc.stdout.splitlines() if line.startswith(RESULT)]
    assert lines, out[-6000:]
    result = json.loads(lines[-1][len(RESULT):])
    result["_output"] = out
    return result


def core_library(wheel_bytes_or_path):
    """(name, bytes) of the compiled core inside a wheel."""
    with zipfile.ZipFile(wheel_bytes_or_path) as zf:
        (name,) = [n for n in zf.namelist() if n.startswith("unbound_core/_native")]
        return name, zf.read(name)


@pytest.fixture(scope="module")
def farm():
    """The shared system directory with the linux-x64 release installed, the scene saved by an
    'artist' process, and the two bpy workers' frames."""
    shutil.rmtree(WORK, ignore_errors=True)
    WORK.mkdir(parents=True)
    system_dir = WORK / "extensions"            # what BLENDER_SYSTEM_EXTENSIONS points to
    rc, out = farm_install("install", system_dir, release_zip("linux_x64"))
    assert rc == 0, out
    author = worker(system_dir, WORK / "home_author", "author", WORK / "scene.blend")
    assert (WORK / "scene.blend").is_file()
    before = snapshot(system_dir)                # the share as the workers find it
    a = worker(system_dir, WORK / "home_a", "render", WORK / "scene.blend", 1, 2, WORK / "a" / "frame_", 1)
    b = worker(system_dir, WORK / "home_b", "render", WORK / "scene.blend", 2, 3, WORK / "b" / "frame_", 2)
    return dict(system_dir=system_dir, author=author, a=a, b=b, before=before)


def test_farm_install_layout(farm):
    """DIR/system/unbound/ as Blender's manual prescribes, a second install is a no-op, and a
    different wheel under the same version is refused (workers would keep the old one)."""
    system_dir = farm["system_dir"]
    pkg = system_dir / "system" / "unbound"
    assert (pkg / "blender_manifest.toml").is_file() and (pkg / "__init__.py").is_file()
    (wheel,) = (pkg / "wheels").glob("*.whl")
    assert "manylinux_2_17_x86_64" in wheel.name
    rc, out = farm_install("install", system_dir, release_zip("linux_x64"))
    assert rc == 0 and "nothing to do" in out, out
    rc, out = farm_install("show", system_dir)
    assert rc == 0 and "unbound 0.1.0" in out and "bl_ext.system.unbound" in out, out
    assert hashlib.sha256(wheel.read_bytes()).hexdigest() in out, out
    # A rebuilt wheel under the same version number: refused without --force.
    other = WORK / "rebuilt.zip"
    with zipfile.ZipFile(release_zip("linux_x64")) as src, zipfile.ZipFile(other, "w") as dst:
        for info in src.infolist():
            data = src.read(info)
            dst.writestr(info, data + b"\0" if info.filename.endswith(".whl") else data)
    before = snapshot(system_dir)
    rc, out = farm_install("install", system_dir, other)
    assert rc == 1 and "new version" in out, out
    assert snapshot(system_dir) == before
    # Not an extension, or a member escaping the directory: refused, nothing written.
    bad = WORK / "escape.zip"
    with zipfile.ZipFile(bad, "w") as zf:
        zf.writestr("blender_manifest.toml", 'id = "unbound"\nversion = "9.0.0"\ntype = "add-on"\n')
        zf.writestr("../evil.py", "")
    rc, out = farm_install("install", system_dir, bad)
    assert rc == 1 and "unsafe member path" in out, out
    assert snapshot(system_dir) == before and not (system_dir / "evil.py").exists()


def test_workers_load_the_system_extension(farm):
    """Each worker runs the add-on from the shared system directory; Blender extracted the system
    wheel into the worker's own user directory (extensions/.local/), so the core library each
    worker loaded is, byte for byte, the one in the shared directory's wheel."""
    system_dir = farm["system_dir"]
    pkg = system_dir / "system" / "unbound"
    (wheel,) = (pkg / "wheels").glob("*.whl")
    _name, library = core_library(wheel)
    rc, shown = farm_install("show", system_dir)     # what an admin compares with the workers
    assert rc == 0, shown
    for key in ("author", "a", "b"):
        r = farm[key]
        home = WORK / ("home_" + key if key != "author" else "home_author")
        assert r["blender"].startswith("4.2"), r["blender"]
        assert r["repos"]["system"] == ["SYSTEM", str(system_dir / "system")], r["repos"]
        assert r["addon_file"] == str(pkg / "__init__.py"), r["addon_file"]
        assert MODULE in r["enabled"] and not [m for m in r["enabled"] if m.endswith(".unbound") and m != MODULE]
        local = home / ".config" / "blender" / "4.2" / "extensions" / ".local"
        assert r["user_extensions"] == str(home / ".config" / "blender" / "4.2" / "extensions"), r
        assert pathlib.Path(r["native_file"]).is_relative_to(local), r["native_file"]
        assert r["native_sha256"] == hashlib.sha256(library).hexdigest(), "the worker's core is not the system wheel's"
        assert r["native_sha256"] in shown, shown
        assert r["core_version"] == "0.1.0" and r["addon_version"] == [0, 1, 0], r
        # The worker's user repository stayed empty: nothing was installed there.
        user_default = home / ".config" / "blender" / "4.2" / "extensions" / "user_default"
        assert not user_default.exists() or not any(user_default.iterdir())
    # Workers only read the share: not a file added, removed or changed (no __pycache__ either:
    # Blender runs add-ons with bytecode writing off).
    assert snapshot(system_dir) == farm["before"]


def test_workers_frames_identical(farm):
    """Frame 2, rendered by worker A (frames 1-2, 1 thread) and worker B (frames 2-3, 2 threads):
    every pass bit-identical; the animation moves (frames 1, 2, 3 differ)."""
    a, b = farm["a"], farm["b"]
    assert a["stats"]["threads"] == 1 and b["stats"]["threads"] == 2, (a["stats"], b["stats"])
    files = {name: WORK / name for name in ("a/frame_0001.exr", "a/frame_0002.exr", "b/frame_0002.exr",
                                             "b/frame_0003.exr")}
    for path in files.values():
        assert path.is_file() and path.stat().st_size > 0, path
    assert not (WORK / "a" / "frame_0003.exr").exists() and not (WORK / "b" / "frame_0001.exr").exists()
    fa, fb = read_exr(files["a/frame_0002.exr"]), read_exr(files["b/frame_0002.exr"])
    assert sorted(fa) == sorted(fb) and len(fa) >= 12, sorted(fa)
    for channel in fa:
        assert fa[channel].tobytes() == fb[channel].tobytes(), channel
    depth = {n: read_exr(p)["ViewLayer.Depth.Z"] for n, p in files.items()}
    assert (depth["a/frame_0002.exr"] < 1e9).mean() > 0.05   # the fractal is in the picture
    assert not np.array_equal(depth["a/frame_0001.exr"], depth["a/frame_0002.exr"])
    assert not np.array_equal(depth["b/frame_0002.exr"], depth["b/frame_0003.exr"])


def first_frame_enabled_before_loading(farm, name, order):
    r = worker(farm["system_dir"], WORK / ("home_" + name), "render", WORK / "scene.blend", 2, 3,
               WORK / name / "frame_", 2, order)
    assert r["addon_file"] == str(farm["system_dir"] / "system" / "unbound" / "__init__.py")
    return read_exr(WORK / name / "frame_0002.exr"), read_exr(WORK / "a" / "frame_0002.exr")


def test_guard_when_enabled_before_loading(farm):
    """The add-on registered before the .blend loads (`blender -b --addons ... scene.blend`, or a
    worker whose preferences enable it), then the guard of docs/farm.md: frame 2 has worker A's bits."""
    got, want = first_frame_enabled_before_loading(farm, "before_guard", "before-guard")
    for channel in want:
        assert got[channel].tobytes() == want[channel].tobytes(), channel


def test_first_frame_when_enabled_before_loading(farm):
    """The same without the guard: the first frame of the range (2; the file was saved at frame 1)
    has worker A's bits in every pass. It once had frame 1's animated values: the add-on's
    frame_change_post handler wrote the original object during the render, and Blender copied the
    original's properties over the render's evaluated ones
    (docs/farm.md, 'Load order does not matter')."""
    got, want = first_frame_enabled_before_loading(farm, "before", "before")
    assert sorted(got) == sorted(want)
    for channel in want:
        assert got[channel].tobytes() == want[channel].tobytes(), channel


def test_mixed_platform_share(farm):
    """The six release zips installed as one package (one share for a mixed farm): a Linux x86-64
    worker enables it and extracts only its own wheel."""
    zips = [release_zip(p) for p in ("linux_x64", "linux_arm64", "macos_arm64", "macos_x64",
                                      "windows_x64", "windows_arm64")]
    system_dir = WORK / "extensions_mixed"
    rc, out = farm_install("install", system_dir, *zips)
    assert rc == 0, out
    wheels = sorted(p.name for p in (system_dir / "system" / "unbound" / "wheels").glob("*.whl"))
    assert len(wheels) == 6, wheels
    r = worker(system_dir, WORK / "home_mixed", "probe")
    assert r["addon_file"] == str(system_dir / "system" / "unbound" / "__init__.py")
    x64 = next(p for p in (system_dir / "system" / "unbound" / "wheels").glob("*manylinux_2_17_x86_64*.whl"))
    assert r["native_sha256"] == hashlib.sha256(core_library(x64)[1]).hexdigest()


# ------------------------------------------------------------------------------------------------
# The real `blender` binary (Debian trixie's 4.3, Python 3.13) in the chroot of tools/blender_gui.sh.

def chroot_path(path):
    return "/src/" + pathlib.Path(path).relative_to(ROOT).as_posix()


def blender_gui(*args, timeout=300):
    """sh tools/blender_gui.sh ARGS -> (rc, output); on timeout the process group (and with it
    the chroot's pid namespace) is killed."""
    proc = subprocess.Popen(["sh", "tools/blender_gui.sh", *args], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        pytest.fail("timed out after %d s: blender_gui.sh %s\n%s" % (timeout, " ".join(args), out[-4000:]))
    return proc.returncode, out


REPORT = ("import bpy, json, sys; m = sys.modules['bl_ext.system.unbound']; "
          "print('FARM_RESULT ' + json.dumps(dict(blender=bpy.app.version_string, python=sys.version, "
          "addon_file=m.__file__, native_file=sys.modules['unbound_core._native'].__file__, "
          "stats=m.engine.LAST_STATS)))")


@pytest.fixture(scope="module")
def real_blender():
    """The chroot with the real blender (built by `sh tools/blender_gui.sh setup`: minutes and
    about 1 GB the first time, seconds afterwards); skipped where it cannot be built."""
    if os.geteuid() != 0:
        pytest.skip("the trixie chroot of tools/blender_gui.sh needs root (debootstrap, apt, chroot)")
    if not shutil.which("unshare"):
        pytest.skip("tools/blender_gui.sh needs unshare (util-linux)")
    rc, out = blender_gui("setup", timeout=1500)
    if rc != 0:
        pytest.skip("the real-Blender chroot could not be built (sh tools/blender_gui.sh setup):\n" + out[-2000:])
    return out


def real_worker(farm, name, *blender_args, scene=True, expect_rc=0):
    """`blender -b [ARGS...]` with BLENDER_SYSTEM_EXTENSIONS and a fresh HOME of its own; with
    scene=True the .blend comes first. Returns (report of the extension, output)."""
    home = WORK / ("home_" + name)
    home.mkdir(exist_ok=True)   # it exists when a test wrote the worker's preferences first
    args = [chroot_path(WORK / "scene.blend")] if scene else []
    rc, out = blender_gui("run", "env", "HOME=" + chroot_path(home),
                          "BLENDER_SYSTEM_EXTENSIONS=" + chroot_path(farm["system_dir"]),
                          "blender", "-b", *args, *blender_args, "--python-expr", REPORT)
    assert rc == expect_rc, out[-4000:]
    if expect_rc:
        return None, out
    lines = [line for line in out.splitlines() if line.startswith(RESULT)]
    assert lines, out[-4000:]
    r = json.loads(lines[-1][len(RESULT):])
    assert r["blender"].startswith("4.") and not r["blender"].startswith("4.2") and r["python"].startswith("3.13"), r
    assert r["addon_file"] == chroot_path(farm["system_dir"] / "system" / "unbound" / "__init__.py"), r
    version = ".".join(r["blender"].split(".")[:2])
    assert r["native_file"].startswith(chroot_path(home) + "/.config/blender/%s/extensions/.local/" % version), r
    return r, out


def assert_same_pixels(path, reference):
    got, want = read_exr(path), read_exr(reference)
    assert sorted(got) == sorted(want), (sorted(got), sorted(want))
    for channel in want:
        assert got[channel].tobytes() == want[channel].tobytes(), (path.name, channel)


def test_real_blender_workers(farm, real_blender):
    """Blender 4.3 (Python 3.13) workers on the share, each with an empty user directory:
    C `blender -b scene.blend --addons bl_ext.system.unbound -o OUT -f 2` writes frame 2 with bpy
    4.2's pixels; D enables the add-on from --python-expr under --factory-startup, on 1 thread,
    and writes frame 3 with worker B's pixels; E puts --addons before the file and runs the guard:
    frame 2 again; F has no --addons: the guard stops it with exit code 2 and no file (without the
    guard Blender renders the frame with EEVEE and exits 0). G puts --addons before the file with
    no guard, and H's saved preferences enable Unbound (no --addons): both register the add-on
    before the file loads, and frame 2, the first frame they render, is frame 2 again (it once had
    the animated values of frame 1, at which the file was saved)."""
    r, _ = real_worker(farm, "c", "--addons", MODULE, "-o", chroot_path(WORK / "c" / "frame_"), "-f", "2")
    assert r["stats"]["rays"] > 0 and not r["stats"]["cancelled"], r
    assert_same_pixels(WORK / "c" / "frame_0002.exr", WORK / "a" / "frame_0002.exr")

    enable = "import addon_utils; addon_utils.enable('%s', default_set=False)" % MODULE
    r, _ = real_worker(farm, "d", "--factory-startup", "--python-expr", enable,
                       "-o", chroot_path(WORK / "d" / "frame_"), "-t", "1", "-f", "3")
    assert r["stats"]["threads"] == 1, r
    assert_same_pixels(WORK / "d" / "frame_0003.exr", WORK / "b" / "frame_0003.exr")

    r, _ = real_worker(farm, "e", "--addons", MODULE, chroot_path(WORK / "scene.blend"),
                       "--python-exit-code", "2", "--python-expr", GUARD,
                       "-o", chroot_path(WORK / "e" / "frame_"), "-f", "2", scene=False)
    assert_same_pixels(WORK / "e" / "frame_0002.exr", WORK / "a" / "frame_0002.exr")

    _, out = real_worker(farm, "f", "--python-exit-code", "2", "--python-expr", GUARD,
                         "-o", chroot_path(WORK / "f" / "frame_"), "-f", "2", expect_rc=2)
    assert "Unbound is not enabled on this worker" in out, out[-4000:]
    assert not (WORK / "f").exists()

    real_worker(farm, "g", "--addons", MODULE, chroot_path(WORK / "scene.blend"),
                "-o", chroot_path(WORK / "g" / "frame_"), "-f", "2", scene=False)
    assert_same_pixels(WORK / "g" / "frame_0002.exr", WORK / "a" / "frame_0002.exr")

    home = WORK / "home_h"
    home.mkdir()
    save_preferences = ("import bpy, addon_utils; addon_utils.enable('%s', default_set=True); "
                        "bpy.ops.wm.save_userpref()" % MODULE)
    rc, out = blender_gui("run", "env", "HOME=" + chroot_path(home),
                          "BLENDER_SYSTEM_EXTENSIONS=" + chroot_path(farm["system_dir"]),
                          "blender", "-b", "--python-exit-code", "2", "--python-expr", save_preferences)
    assert rc == 0 and list(home.glob(".config/blender/*/config/userpref.blend")), out[-4000:]
    real_worker(farm, "h", "-o", chroot_path(WORK / "h" / "frame_"), "-f", "2")
    assert_same_pixels(WORK / "h" / "frame_0002.exr", WORK / "a" / "frame_0002.exr")
    # Debian's Blender runs Python with bytecode writing on: on a share it can write to (here, as
    # root) it adds __pycache__/*.cpython-313.pyc beside the add-on; nothing else changed. (bpy 4.2
    # from PyPI wrote none; a read-only share, as docs/farm.md advises, gets none.)
    after = snapshot(farm["system_dir"])
    assert {k: v for k, v in after.items() if "__pycache__" not in k} == farm["before"]
    assert all(k.endswith(("__pycache__", ".cpython-313.pyc")) for k in set(after) - set(farm["before"]))


def test_docs_carry_the_guard():
    """docs/farm.md's worker command lines use the guard these tests run."""
    assert GUARD in (ROOT / "docs" / "farm.md").read_text()
