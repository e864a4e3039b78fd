"""Pack addon/ + blender_manifest.toml + the native wheel into a Blender extension zip in dist/,
with Blender's own extension tool (shipped inside the bpy wheel), then validate the zip.

    python tools/build_extension.py            # -> dist/unbound-<version>.zip
"""
import glob
import os
import pathlib
import shutil
import subprocess
import sys
import tomllib

ROOT = pathlib.Path(__file__).resolve().parents[1]


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


def main():
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    stage = ROOT / "build" / "extension"
    shutil.rmtree(stage, ignore_errors=True)
    shutil.copytree(ROOT / "addon", stage, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    shutil.copy(ROOT / "blender_manifest.toml", stage)
    (stage / "wheels").mkdir()
    for wheel in manifest["wheels"]:
        name = pathlib.Path(wheel).name
        src = ROOT / "dist" / name
        if not src.exists():
            sys.exit("build_extension: %s is missing; run `make wheel` first" % src)
        shutil.copy(src, stage / "wheels" / name)
    out = ROOT / "dist"
    out.mkdir(exist_ok=True)
    for old in glob.glob(str(out / ("%s-*.zip" % manifest["id"]))):
        os.remove(old)
    cli = blender_ext_cli()
    subprocess.run([sys.executable, str(cli), "validate", str(stage)], check=True)
    subprocess.run([sys.executable, str(cli), "build", "--source-dir", str(stage), "--output-dir", str(out)],
                   check=True)
    zip_path = out / ("%s-%s.zip" % (manifest["id"], manifest["version"]))
    subprocess.run([sys.executable, str(cli), "validate", str(zip_path)], check=True)
    print(zip_path)


if __name__ == "__main__":
    main()
