"""Pass buffers for render(): numpy float32 arrays whose data start on a cache line.

    combined = unbound_core.pass_array(height, width, 4)           # contents undefined
    depth = unbound_core.pass_array(height, width, 1, zero=True)

render() takes any C-contiguous float32 buffer, but numpy puts a large array's data 16 bytes past
a cache line (the allocator's header), so a tile shares its first and last line of every row
with the neighbouring tiles, and where two threads write either side of a tile edge they pass
those lines back and forth between their cores. Measured on the peer scene (1280x1024, combined,
alpha and depth, AVX-512, an AMD Zen 4; issue 21): on 2 threads 2-2.6 % more CPU into numpy's
arrays than into arrays that start on a line (with one queue of tiles and with a run of tiles a
thread alike); on 1 thread no difference."""

CACHE_LINE = 64


def pass_array(height, width, channels, zero=False):
    """A C-contiguous float32 array of shape (height, width, channels) whose data start on a
    64-byte line (a view into a slightly larger array, which it keeps alive)."""
    import numpy as np  # Blender bundles numpy; the core itself does not need it

    count = int(height) * int(width) * int(channels)
    spare = CACHE_LINE // 4
    raw = (np.zeros if zero else np.empty)(count + spare, np.float32)
    skip = (-raw.ctypes.data % CACHE_LINE) // 4  # numpy's data are at least 4-byte aligned
    return raw[skip:skip + count].reshape(int(height), int(width), int(channels))
