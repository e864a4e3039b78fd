"""Reads the log of a sanitized run (tools/sanitize.sh test) and says what it found.

Exit status 1 if the log holds an AddressSanitizer error, an UndefinedBehaviorSanitizer report,
or a leak whose allocation stack runs through the native core's sources (native/src/). Leaks of
the interpreter itself at exit (stacks only through libpython, numpy, pytest) are counted and
shown, not failed: they are not the core's, and CPython does not free everything at exit.

    python tools/lsan_report.py LOG
"""
import re
import sys

LEAK = re.compile(r"^(Direct|Indirect) leak of (\d+) byte\(s\) in (\d+) object\(s\) allocated from:")
FRAME = re.compile(r"^\s+#\d+ 0x[0-9a-f]+ in (\S+) (\S+)")
CORE_SOURCE = "native/src/"


def leaks(lines):
    """(kind, bytes, frames) for each leak block LeakSanitizer printed."""
    out, i = [], 0
    while i < len(lines):
        m = LEAK.match(lines[i])
        i += 1
        if not m:
            continue
        frames = []
        while i < len(lines) and FRAME.match(lines[i]):
            frames.append(lines[i].strip())
            i += 1
        out.append((m.group(1), int(m.group(2)), frames))
    return out


def main(path):
    lines = open(path, errors="replace").read().splitlines()
    errors = [ln for ln in lines if "ERROR: AddressSanitizer" in ln or "runtime error:" in ln]
    found = leaks(lines)
    core = [lk for lk in found if any(CORE_SOURCE in f for f in lk[2])]
    other = sum(b for _, b, _ in found) - sum(b for _, b, _ in core)
    print(f"sanitizer errors: {len(errors)}; leaks through native/src: {len(core)} "
          f"({sum(b for _, b, _ in core)} bytes); other leaks at exit (interpreter): {other} bytes")
    for ln in errors[:20]:
        print("  " + ln)
    for kind, nbytes, frames in core[:10]:
        print(f"  {kind} leak of {nbytes} bytes:")
        for f in frames[:8]:
            print("    " + f)
    return 1 if errors or core else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
