"""Install an Unbound release into a directory of *system* extensions that render-farm workers share
(Blender 4.2+'s read-only "System" repository, add-on module bl_ext.system.unbound). See docs/farm.md.

    python tools/farm_install.py install DIR ZIP [ZIP ...] [--force]
    python tools/farm_install.py show DIR

DIR is what the workers get as BLENDER_SYSTEM_EXTENSIONS; the package goes to DIR/system/unbound/,
the layout Blender's manual prescribes ("Deploying Blender in Production": packages are extracted
to $BLENDER_SYSTEM_EXTENSIONS/system/<id>/blender_manifest.toml). Blender's own installer cannot
do it: `blender --command extension install-file -r system` answers 'enum "system" not found'
(4.2 and 4.3 offer only user repositories there), so this script does what that installer does
for a user repository: it checks the manifest and every member's path, extracts into a temporary
directory beside system/, and moves the result into place, replacing an older version.

Several ZIPs (the per-platform release zips of one version, dist/release/unbound-0.1.0-*.zip)
install as one package holding every wheel, for a share used by workers of several platforms;
each Blender extracts only its own platform's wheel.

An installed package of the same version whose wheel of the same name has other bytes is refused
without --force: Blender keeps a worker's already extracted wheel of the same name and version (in
the worker's user directory, extensions/.local/), so a rebuilt core under an old version number
would not reach the workers that already ran it. Give a new build a new version instead. (Adding
platforms to an installed version, or other Python files, is fine: Blender reads the add-on's
Python files from DIR/system/ each time.)

`show` prints the installed id, version, platforms, the SHA-256 of each wheel and of the compiled
library inside it, to compare with what a worker reports (docs/farm.md, "Checking the version on workers").

Plain Python >= 3.11 (tomllib), no bpy needed: run it with any Python, or with Blender's own,
`blender -b --factory-startup --python tools/farm_install.py -- install DIR ZIP`.
"""
import argparse
import hashlib
import os
import pathlib
import re
import shutil
import sys
import tempfile
import tomllib
import zipfile

REPOSITORY = "system"   # Blender's default System repository: $BLENDER_SYSTEM_EXTENSIONS/system
MANIFEST = "blender_manifest.toml"
GENERATED_RE = re.compile(r"\n*# BEGIN GENERATED CONTENT\..*?# END GENERATED CONTENT\.\n?", re.S)


class InstallError(Exception):
    pass


def say(*args):
    print("farm_install:", *args, flush=True)


def script_args(argv):
    """Arguments after `--` when run by Blender (`blender -b --python farm_install.py -- ...`)."""
    return argv[argv.index("--") + 1:] if "--" in argv else argv[1:]


def effective(manifest):
    """The manifest as Blender reads an installed package: [build.generated] (written by
    `blender --command extension build --split-platforms`) replaces platforms and wheels."""
    generated = manifest.get("build", {}).get("generated", {})
    return (list(generated.get("platforms", manifest.get("platforms", []))),
            list(generated.get("wheels", manifest.get("wheels", []))))


def read_package(path):
    """(manifest text, manifest dict, {member: bytes}) of an extension zip, checked."""
    try:
        zf = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile) as exc:
        raise InstallError("%s: not an extension zip (%s)" % (path, exc)) from exc
    with zf:
        members = {}
        for info in zf.infolist():
            name = info.filename
            parts = pathlib.PurePosixPath(name).parts
            if name.startswith(("/", "\\")) or "\\" in name or ".." in parts or ":" in name:
                raise InstallError("%s: unsafe member path %r" % (path, name))
            if info.is_dir():
                continue
            if (info.external_attr >> 16) & 0o170000 == 0o120000:
                raise InstallError("%s: symbolic link %r" % (path, name))
            members[name] = zf.read(info)
    if MANIFEST not in members:
        raise InstallError("%s: no %s at the top of the zip (is it a Blender extension?)" % (path, MANIFEST))
    text = members[MANIFEST].decode("utf-8")
    try:
        manifest = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InstallError("%s: %s is not valid TOML (%s)" % (path, MANIFEST, exc)) from exc
    for key in ("id", "version", "type"):
        if not isinstance(manifest.get(key), str):
            raise InstallError("%s: manifest has no %s" % (path, key))
    if manifest["type"] != "add-on":
        raise InstallError("%s: %s is a %s, not an add-on" % (path, manifest["id"], manifest["type"]))
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", manifest["id"]):
        raise InstallError("%s: bad extension id %r" % (path, manifest["id"]))
    for wheel in effective(manifest)[1]:
        if wheel.removeprefix("./") not in members:
            raise InstallError("%s: manifest lists %s, which is not in the zip" % (path, wheel))
    return text, manifest, members


def merge(packages):
    """One package from the per-platform zips of one release: the files of the first (they must
    agree on every file but the manifest and the wheels), every wheel, and a manifest whose
    [build.generated] lists all their platforms and wheels."""
    (_path, (text, manifest, members)), rest = packages[0], packages[1:]
    if not rest:
        return members, manifest
    platforms, wheels = effective(manifest)
    files = dict(members)
    for path, (_text, other, other_members) in rest:
        if (other["id"], other["version"]) != (manifest["id"], manifest["version"]):
            raise InstallError("%s is %s %s, not %s %s: install one version at a time"
                               % (path, other["id"], other["version"], manifest["id"], manifest["version"]))
        other_platforms, other_wheels = effective(other)
        for name, data in other_members.items():
            if name == MANIFEST or name.removeprefix("./") in {w.removeprefix("./") for w in other_wheels}:
                continue
            if files.get(name) != data:
                raise InstallError("%s: %s differs from the first zip's (zips of different builds?)" % (path, name))
        for wheel in other_wheels:
            files[wheel.removeprefix("./")] = other_members[wheel.removeprefix("./")]
        platforms += [p for p in other_platforms if p not in platforms]
        wheels += [w for w in other_wheels if w not in wheels]
    block = ("\n\n# BEGIN GENERATED CONTENT.\n# This must not be included in source manifests.\n"
             "[build.generated]\nplatforms = [%s]\nwheels = [%s]\n# END GENERATED CONTENT.\n"
             % (", ".join('"%s"' % p for p in platforms), ", ".join('"%s"' % w for w in wheels)))
    base = GENERATED_RE.sub("\n", text).rstrip("\n")
    if "[build.generated]" in base:
        raise InstallError("cannot merge: the manifest's [build.generated] table is not in its marked block")
    merged = base + block
    files[MANIFEST] = merged.encode("utf-8")
    return files, tomllib.loads(merged)


def tree_files(root):
    """{relative posix path: bytes} of the files under root, ignoring Python's bytecode caches."""
    out = {}
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root).as_posix()
        if path.is_file() and "__pycache__" not in path.parts and not rel.endswith(".pyc"):
            out[rel] = path.read_bytes()
    return out


def install(directory, zips, force=False):
    """Installs the zips (one version) as DIR/system/<id>; returns that path."""
    directory = pathlib.Path(directory).resolve()
    packages = []
    for path in zips:
        text, manifest, members = read_package(path)
        packages.append((path, (text, manifest, members)))
    files, manifest = merge(packages)
    ext_id, version = manifest["id"], manifest["version"]
    repo = directory / REPOSITORY
    target = repo / ext_id
    repo.mkdir(parents=True, exist_ok=True)

    if target.exists():
        old_manifest_path = target / MANIFEST
        old = tomllib.loads(old_manifest_path.read_text("utf-8")) if old_manifest_path.is_file() else {}
        if old.get("version") == version:
            installed = tree_files(target)
            if installed == files:
                say("%s %s is already installed in %s (same files): nothing to do" % (ext_id, version, target))
                return target
            changed = sorted(name for name in files if name.endswith(".whl") and name in installed
                             and installed[name] != files[name])
            if changed and not force:
                raise InstallError(
                    "%s %s is already installed in %s with another %s. Workers keep the wheel they "
                    "extracted for that version, so the new one would not reach them all: give the new "
                    "build a new version, or pass --force and empty every worker's extensions/.local/ "
                    "and extensions/.cache/ (docs/farm.md)" % (ext_id, version, target, ", ".join(changed)))
        say("replacing %s %s in %s" % (ext_id, old.get("version", "?"), target))

    # Extract beside system/ (same file system, not scanned by Blender), then move into place.
    staging = pathlib.Path(tempfile.mkdtemp(prefix=".%s-install-" % ext_id, dir=directory))
    try:
        new = staging / ext_id
        for name, data in sorted(files.items()):
            dest = new / name
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_bytes(data)
        for path in [new, *new.rglob("*")]:
            os.chmod(path, 0o755 if path.is_dir() else 0o644)   # readable by every worker's account
        if target.exists():
            old_dir = staging / "old"
            os.replace(target, old_dir)
        os.replace(new, target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    platforms, wheels = effective(manifest)
    say("installed %s %s (%s) in %s" % (ext_id, version, ", ".join(platforms) or "any platform", target))
    say("workers: BLENDER_SYSTEM_EXTENSIONS=%s blender -b FILE.blend --addons bl_ext.%s.%s ..."
        % (directory, REPOSITORY, ext_id))
    return target


def show(directory):
    """Prints what DIR/system holds; returns {id: (version, platforms, {wheel: sha256})}."""
    repo = pathlib.Path(directory).resolve() / REPOSITORY
    found = {}
    for manifest_path in sorted(repo.glob("*/" + MANIFEST)):
        manifest = tomllib.loads(manifest_path.read_text("utf-8"))
        platforms, wheels = effective(manifest)
        digests, libraries = {}, {}
        for wheel in wheels:
            wheel_path = manifest_path.parent / wheel.removeprefix("./")
            if not wheel_path.is_file():
                digests[wheel_path.name] = "MISSING"
                continue
            digests[wheel_path.name] = hashlib.sha256(wheel_path.read_bytes()).hexdigest()
            # The compiled libraries inside, as a worker loads them (extracted unchanged).
            with zipfile.ZipFile(wheel_path) as zf:
                libraries[wheel_path.name] = {
                    n: hashlib.sha256(zf.read(n)).hexdigest() for n in zf.namelist()
                    if n.endswith((".so", ".pyd", ".dylib"))}
        found[manifest["id"]] = (manifest["version"], platforms, digests)
        print("%s %s in %s" % (manifest["id"], manifest["version"], manifest_path.parent))
        print("  module: bl_ext.%s.%s" % (REPOSITORY, manifest_path.parent.name))
        print("  platforms: %s" % (", ".join(platforms) or "any"))
        for name, digest in digests.items():
            print("  wheel %s sha256 %s" % (name, digest))
            for member, lib_digest in libraries.get(name, {}).items():
                print("    %s sha256 %s" % (member, lib_digest))
    if not found:
        print("no extensions in %s" % repo)
    return found


def main(argv=None):
    ap = argparse.ArgumentParser(prog="farm_install.py", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    p = sub.add_parser("install", help="install release zip(s) into DIR/system/")
    p.add_argument("directory", metavar="DIR", help="the workers' BLENDER_SYSTEM_EXTENSIONS")
    p.add_argument("zips", metavar="ZIP", nargs="+", help="dist/release/unbound-VERSION-PLATFORM.zip")
    p.add_argument("--force", action="store_true",
                   help="replace an installed package of the same version but other content")
    p = sub.add_parser("show", help="print the installed extensions and their wheels' SHA-256")
    p.add_argument("directory", metavar="DIR")
    args = ap.parse_args(script_args(sys.argv) if argv is None else argv)
    try:
        if args.command == "install":
            install(args.directory, args.zips, force=args.force)
        else:
            show(args.directory)
    except (InstallError, OSError) as exc:
        print("farm_install: error: %s" % exc, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
