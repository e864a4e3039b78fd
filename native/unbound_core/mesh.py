"""Convert to Mesh: the native extract_mesh() with numpy arrays (Blender bundles numpy).

    m = unbound_core.mesh.extract(obj, resolution=512, min_faces=100)
    m.vertices (n, 3) float32 object space, m.faces (m, 3) int32 counter-clockwise from outside,
    m.trap, m.iterations, m.estimate (n,) float32, m.stats (dict)

The surface is {estimate = epsilon} (epsilon 0: a 64th of a cell), closed and manifold (each
edge in exactly two faces); see native/src/mesh.c for the method. The arrays are views of the
core's own buffers (extract_mesh returns read-only memoryviews; no copy is made)."""
from ._native import extract_mesh  # noqa: F401


class Mesh:
    __slots__ = ("vertices", "faces", "trap", "iterations", "estimate", "stats")

    def __init__(self, result):
        import numpy as np

        self.vertices = np.frombuffer(result["vertices"], np.float32).reshape(-1, 3)
        self.faces = np.frombuffer(result["faces"], np.int32).reshape(-1, 3)
        self.trap = np.frombuffer(result["trap"], np.float32)
        self.iterations = np.frombuffer(result["iterations"], np.float32)
        self.estimate = np.frombuffer(result["estimate"], np.float32)
        self.stats = {k: v for k, v in result.items() if not isinstance(v, memoryview)}


def extract(obj, **keywords):
    """extract_mesh(obj, **keywords) as a Mesh of numpy arrays."""
    return Mesh(extract_mesh(obj, **keywords))
