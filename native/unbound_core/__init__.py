"""Unbound's native core: ray marching of 3-D slices of quaternion Julia sets by unbounding
spheres (Hart, Sandin & Kauffman 1989), on every core, into caller-owned float32 passes.

The functions come from the compiled module; see README "Native core" for the parameters.
"""
from ._native import (  # noqa: F401
    BACKGROUND_DEPTH,
    MAX_IMAGE_SIZE,
    MAX_ITERATIONS,
    PASS_CHANNELS,
    PARAMETERS,
    PASSES,
    PRECISION_LIMIT,
    ZOOM_FORMULA_MAX,
    camera_ray,
    cpu_info,
    describe,
    estimate,
    extract_mesh,
    lens_sample,
    normals,
    render,
    shared_steps_cache,
    zoom_anchor_move,
)
from . import same_bits  # noqa: F401
from . import mesh  # noqa: F401,E402
from .buffers import pass_array  # noqa: F401
from .camera import look_at, orthographic, perspective  # noqa: F401

__version__ = "0.1.0"
