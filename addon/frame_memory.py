"""A frame's memory kept for the next frame (issue 21), on Linux with glibc.

Blender allocates each render's result afresh (the full frame's passes, and each band's), and
frees it when the next frame starts. glibc hands blocks of that size back to the kernel: blocks
above its mmap threshold (128 KiB until the first such block is freed) are unmapped when freed,
and the free top of its heap above the trim threshold is trimmed. The next frame's first write to
each page then faults it back in, zeroed by the kernel: 3 700 page faults a 640x360 frame of
seven passes, a third of Blender's own CPU time per frame in an animation (bench/README.md).

`keep()` asks glibc to keep them (mallopt): blocks up to 32 MiB (glibc's largest dynamic mmap
threshold: a 1920x1080 RGBA pass is 32 MiB) come from the heap, and up to 256 MiB of free heap
top stays mapped, so the next frame reuses the pages instead of faulting them in (the same
setting a render farm makes with MALLOC_MMAP_THRESHOLD_ and MALLOC_TRIM_THRESHOLD_). The memory
is kept for what the next frame needs: Blender's peak does not grow, only what it keeps between
renders (at most the last frame's result, which Blender shows in the Render Result anyway).

Only for final renders, once per process; nothing elsewhere (macOS and Windows allocators reuse
such blocks themselves). A user's own MALLOC_*_ settings are left as they are, and
UNBOUND_KEEP_FRAME_MEMORY=0 turns this off.
"""
import ctypes
import os
import sys

# mallopt's parameter numbers (glibc's malloc.h).
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3

MMAP_THRESHOLD = 32 << 20
TRIM_THRESHOLD = 256 << 20

_state = {"done": False, "kept": False}


def glibc():
    """Whether this process runs on glibc (its confstr answers; platform.libc_ver would scan the
    executable, which in Blender can be hundreds of megabytes)."""
    try:
        return os.confstr("CS_GNU_LIBC_VERSION").startswith("glibc")
    except (AttributeError, ValueError, OSError):
        return False


def wanted():
    """Whether this process should keep frame memory: Linux, glibc, not opted out, and the user
    has not tuned glibc's allocator through its own environment variables."""
    if not sys.platform.startswith("linux") or not glibc():
        return False
    if os.environ.get("UNBOUND_KEEP_FRAME_MEMORY", "1").strip() in ("0", "false", "no", "off"):
        return False
    return not any(os.environ.get(name) for name in ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"))


def keep():
    """Apply the setting once per process; returns whether it is in effect. Never raises: a
    libc without mallopt only leaves the allocator as it was."""
    if not _state["done"]:
        _state["done"] = True
        if wanted():
            try:
                libc = ctypes.CDLL("libc.so.6")
                _state["kept"] = bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and \
                    bool(libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
            except (OSError, AttributeError):
                _state["kept"] = False
    return _state["kept"]
