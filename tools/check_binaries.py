"""Static checks of every release wheel's binary: what can be verified here of the platforms this
machine cannot run (macOS, Windows arm64), and of the others too.

    python tools/check_binaries.py [WHEEL ...]     # default: dist/release/*.whl

For each wheel: the right architecture and file type; on Linux, libraries only from glibc and no
symbol version above GLIBC_2.17 (and auditwheel agrees: manylinux_2_17); on Windows, imports only
python3.dll, KERNEL32.dll and the UCRT (no python311.dll, no vcruntime, no winpthread) and the one
export PyInit__native; on macOS, `minos` 11.0, only libSystem, and on arm64 a code signature
(Apple silicon refuses unsigned code); everywhere, every Python symbol it uses within the stable
ABI (python3.def, the exports of python3.dll). Exit status 1 and one line per failure otherwise.
Libraries: pyelftools (via auditwheel), pefile and macholib, pinned in requirements-dist.txt.
"""
import io
import pathlib
import re
import subprocess
import sys
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import cross_build  # noqa: E402

GLIBC_MAX = (2, 17)
LINUX_LIBRARIES = {"libc.so.6", "libm.so.6", "libpthread.so.0"}
WINDOWS_MACHINES = {"win_amd64": 0x8664, "win_arm64": 0xAA64}
MACHO_CPU = {"x86_64": 0x01000007, "arm64": 0x0100000C}
ELF_MACHINE = {"x86_64": "EM_X86_64", "aarch64": "EM_AARCH64"}


def stable_abi():
    definition = ROOT / "build" / "cross" / "python3.def"
    if not definition.exists():
        definition.parent.mkdir(parents=True, exist_ok=True)
        definition.write_bytes(cross_build.member(cross_build.download("python3-dll-a-0.2.15.crate"),
                                                  "/src/python3.def"))
    names = set()
    for line in definition.read_text().splitlines()[1:]:
        words = line.split()
        if words and words[0] not in ("LIBRARY", "EXPORTS"):
            names.add(words[0])
    return names


def python_symbols(names):
    return {n for n in names if re.match(r"_?Py", n)}


def check_linux(data, arch, wheel):
    from elftools.elf.elffile import ELFFile
    from elftools.elf.dynamic import DynamicSection
    from elftools.elf.gnuversions import GNUVerNeedSection
    elf = ELFFile(io.BytesIO(data))
    problems = []
    if elf["e_machine"] != ELF_MACHINE[arch]:
        problems.append("machine %s, expected %s" % (elf["e_machine"], ELF_MACHINE[arch]))
    needed, versions, undefined = set(), set(), set()
    for section in elf.iter_sections():
        if isinstance(section, DynamicSection):
            needed |= {t.needed for t in section.iter_tags() if t.entry.d_tag == "DT_NEEDED"}
        if isinstance(section, GNUVerNeedSection):
            for _, aux in section.iter_versions():
                versions |= {a.name for a in aux}
        if section.name == ".dynsym":
            undefined |= {s.name for s in section.iter_symbols() if s["st_shndx"] == "SHN_UNDEF" and s.name}
    if needed - LINUX_LIBRARIES:
        problems.append("links %s" % sorted(needed - LINUX_LIBRARIES))
    too_new = sorted(v for v in versions if v.startswith("GLIBC_")
                     and tuple(int(x) for x in v[6:].split(".")) > GLIBC_MAX)
    if too_new:
        problems.append("needs %s (newer than glibc %d.%d)" % (too_new, *GLIBC_MAX))
    show = subprocess.run([sys.executable, "-m", "auditwheel", "show", str(wheel)], capture_output=True, text=True)
    if '"manylinux_2_17_%s"' % arch not in show.stdout.replace("\n", " "):
        problems.append("auditwheel does not say manylinux_2_17: %s" % " ".join(show.stdout.split()))
    return problems, python_symbols(undefined)


def check_windows(data, plat):
    import pefile
    pe = pefile.PE(data=data)
    problems = []
    if pe.FILE_HEADER.Machine != WINDOWS_MACHINES[plat]:
        problems.append("machine 0x%x, expected 0x%x" % (pe.FILE_HEADER.Machine, WINDOWS_MACHINES[plat]))
    if not pe.is_dll():
        problems.append("not a DLL")
    imported = set()
    for entry in getattr(pe, "DIRECTORY_ENTRY_IMPORT", []):
        dll = entry.dll.decode()
        if not (dll in ("python3.dll", "KERNEL32.dll") or dll.lower().startswith("api-ms-win-crt-")):
            problems.append("imports %s" % dll)
        if dll == "python3.dll":
            imported |= {i.name.decode() for i in entry.imports if i.name}
    exports = {s.name.decode() for s in getattr(pe, "DIRECTORY_ENTRY_EXPORT", None).symbols} \
        if hasattr(pe, "DIRECTORY_ENTRY_EXPORT") else set()
    if exports != {"PyInit__native"}:
        problems.append("exports %s, expected only PyInit__native" % sorted(exports))
    return problems, imported


def check_macos(data, arch):
    from macholib import mach_o
    from macholib.MachO import MachO
    from macholib.SymbolTable import SymbolTable
    path = ROOT / "build" / "cross" / "check-macho.tmp"
    path.write_bytes(data)  # macholib reads files
    try:
        macho = MachO(str(path))
        header = macho.headers[0]
        problems = []
        if header.header.cputype != MACHO_CPU[arch]:
            problems.append("cputype 0x%x, expected 0x%x" % (header.header.cputype, MACHO_CPU[arch]))
        if header.header.filetype not in (mach_o.MH_DYLIB, mach_o.MH_BUNDLE):
            problems.append("file type %d is not a loadable library" % header.header.filetype)
        commands = {lc.cmd: (cmd, payload) for lc, cmd, payload in header.commands}
        libraries = [payload.rstrip(b"\0").decode() for lc, cmd, payload in header.commands
                     if lc.cmd == mach_o.LC_LOAD_DYLIB]
        if libraries != ["/usr/lib/libSystem.B.dylib"]:
            problems.append("loads %s" % libraries)
        build = commands.get(mach_o.LC_BUILD_VERSION)
        if build is None or (build[0].minos >> 16, (build[0].minos >> 8) & 0xFF) != (11, 0):
            problems.append("minimum macOS is not 11.0")
        if arch == "arm64" and mach_o.LC_CODE_SIGNATURE not in commands:
            problems.append("no code signature (Apple silicon refuses to load unsigned code)")
        symbols = SymbolTable(macho)
        # Mach-O prefixes every C name with one underscore.
        undefined = {name.decode()[1:] for _, name in symbols.undefsyms}
        exported = {name.decode()[1:] for _, name in symbols.extdefsyms}
        if "PyInit__native" not in exported:
            problems.append("no PyInit__native export")
        return problems, python_symbols(undefined)
    finally:
        path.unlink()


def check(wheel, abi):
    plat = wheel.name[:-4].split("-")[-1].split(".")[0]
    with zipfile.ZipFile(wheel) as z:
        binaries = [n for n in z.namelist() if n.endswith((".so", ".pyd"))]
        if len(binaries) != 1:
            return ["holds %d binaries" % len(binaries)]
        data = z.read(binaries[0])
    if plat.startswith("manylinux"):
        problems, used = check_linux(data, plat.split("_", 3)[3], wheel)
    elif plat.startswith("win"):
        problems, used = check_windows(data, plat)
    elif plat.startswith("macosx"):
        problems, used = check_macos(data, plat.split("_", 3)[3])
    else:
        return ["unknown platform tag %s" % plat]
    outside = sorted(used - abi)
    if outside:
        problems.append("Python symbols outside the stable ABI: %s" % outside)
    if not used:
        problems.append("no Python symbol found (the check is blind)")
    return problems


def main():
    wheels = [pathlib.Path(a) for a in sys.argv[1:]] or sorted((ROOT / "dist" / "release").glob("*.whl"))
    if not wheels:
        sys.exit("check_binaries: no wheels; run `make dist` first")
    abi = stable_abi()
    failed = 0
    for wheel in wheels:
        problems = check(wheel, abi)
        print("%-70s %s" % (wheel.name, "ok" if not problems else "FAILED"))
        for p in problems:
            print("    " + p)
        failed += bool(problems)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
