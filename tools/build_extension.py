"""Pack addon/ + blender_manifest.toml + the native wheel(s) into Blender extension zips, with
Blender's own extension tool (shipped inside the bpy wheel), then validate every zip.

    python tools/build_extension.py            # -> dist/unbound-<version>.zip: this machine's wheel
                                               #    (make wheel), for development and the tests
    python tools/build_extension.py --release  # -> dist/release/unbound-<version>-<platform>.zip:
                                               #    one per platform, each holding only its own
                                               #    wheel from dist/release (tools/cross_build.py)

The manifest's `platforms` and `wheels` are written from the wheels found, so that they cannot
disagree with what is packed.
"""
import argparse
import glob
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
# Wheel platform tag (first of a compressed set) -> Blender's platform name, as Blender maps them.
BLENDER_PLATFORM = {"manylinux_2_17_x86_64": "linux-x64", "linux_x86_64": "linux-x64",
                    "manylinux_2_17_aarch64": "linux-arm64", "linux_aarch64": "linux-arm64",
                    "macosx_11_0_x86_64": "macos-x64", "macosx_11_0_arm64": "macos-arm64",
                    "win_amd64": "windows-x64", "win_arm64": "windows-arm64"}


def blender_ext_cli():
    """blender_ext.py from the installed bpy (identical CLI in 4.2 to 5.x); runs without bpy."""
    import importlib.util
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        sys.exit("build_extension: the bpy module is needed for Blender's extension tool (pip install bpy)")
    base = pathlib.Path(list(spec.submodule_search_locations)[0])
    found = sorted(base.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        sys.exit("build_extension: blender_ext.py not found under %s" % base)
    return found[-1]


def wheel_platform(wheel):
    tag = wheel.name[:-4].split("-")[-1].split(".")[0]
    if tag not in BLENDER_PLATFORM:
        sys.exit("build_extension: no Blender platform for wheel tag %s (%s)" % (tag, wheel.name))
    return BLENDER_PLATFORM[tag]


def staged_manifest(text, wheels):
    """The manifest with `platforms` and `wheels` set to what is packed."""
    platforms = sorted({wheel_platform(w) for w in wheels})
    text, n1 = re.subn(r"(?m)^platforms = .*$", "platforms = [%s]" % ", ".join('"%s"' % p for p in platforms), text)
    text, n2 = re.subn(r"(?ms)^wheels = \[.*?\]$", "wheels = [\n%s\n]" % "\n".join(
        '  "./wheels/%s",' % w.name for w in wheels), text)
    if (n1, n2) != (1, 1):
        sys.exit("build_extension: blender_manifest.toml needs one `platforms = [...]` and one `wheels = [...]`")
    return text


def stage(wheels):
    stage_dir = ROOT / "build" / "extension"
    shutil.rmtree(stage_dir, ignore_errors=True)
    shutil.copytree(ROOT / "addon", stage_dir, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (stage_dir / "blender_manifest.toml").write_text(staged_manifest((ROOT / "blender_manifest.toml").read_text(),
                                                                     wheels))
    (stage_dir / "wheels").mkdir()
    for wheel in wheels:
        shutil.copy(wheel, stage_dir / "wheels" / wheel.name)
    return stage_dir


def check_split_zip(zip_path, platform, wheels):
    """A per-platform zip holds exactly that platform's wheel."""
    with zipfile.ZipFile(zip_path) as z:
        packed = sorted(pathlib.PurePosixPath(n).name for n in z.namelist() if n.endswith(".whl"))
    expected = sorted(w.name for w in wheels if wheel_platform(w) == platform)
    if packed != expected:
        sys.exit("build_extension: %s holds %s, expected %s" % (zip_path.name, packed, expected))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--release", action="store_true", help="one zip per platform from dist/release")
    args = ap.parse_args()
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    source = ROOT / "dist" / ("release" if args.release else "")
    wheels = sorted(source.glob("unbound_core-%s-cp311-abi3-*.whl" % manifest["version"]))
    if not wheels:
        sys.exit("build_extension: no wheel in %s; run `make %s` first" % (source, "dist" if args.release else "wheel"))
    if not args.release and len(wheels) != 1:
        sys.exit("build_extension: expected one wheel in dist/, found %s" % [w.name for w in wheels])
    stage_dir = stage(wheels)
    out = source
    for old in glob.glob(str(out / ("%s-*.zip" % manifest["id"]))):
        os.remove(old)
    cli = [sys.executable, str(blender_ext_cli())]
    subprocess.run(cli + ["validate", str(stage_dir)], check=True)
    build = cli + ["build", "--source-dir", str(stage_dir), "--output-dir", str(out)]
    subprocess.run(build + (["--split-platforms"] if args.release else []), check=True)
    if args.release:
        platforms = sorted({wheel_platform(w) for w in wheels})
        zips = [out / ("%s-%s-%s.zip" % (manifest["id"], manifest["version"], p.replace("-", "_"))) for p in platforms]
    else:
        zips = [out / ("%s-%s.zip" % (manifest["id"], manifest["version"]))]
    for zip_path, platform in zip(zips, platforms if args.release else [None]):
        subprocess.run(cli + ["validate", str(zip_path)], check=True)
        if platform:
            check_split_zip(zip_path, platform, wheels)
        print(zip_path)


if __name__ == "__main__":
    main()
