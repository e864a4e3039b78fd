"""Fixtures for the native core's tests: cameras, pass buffers, float64 rays.

The native module under test is the installed wheel (`unbound_core`); the float64 references
come from reference/ at the repository root."""
import pathlib
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
# The wheel `make wheel` built, unpacked (the tests run the real compiled module).
sys.path.insert(0, str(ROOT / "build" / "wheel"))

import unbound_core as uc  # noqa: E402


def make_camera(width=64, height=48, eye=(0.4, -3.0, 0.9), target=(0.0, 0.0, 0.0), fov_y=0.7,
                ortho_height=None, clip=(0.1, 100.0)):
    matrix = uc.look_at(eye, target, (0.0, 0.0, 1.0))
    if ortho_height is None:
        proj = uc.perspective(fov_y, width / height, *clip)
    else:
        proj = uc.orthographic(ortho_height, width / height, *clip)
    return dict(matrix=matrix, projection=proj, width=width, height=height)


def alloc_passes(width, height, names=None):
    names = uc.PASSES if names is None else names
    return {n: np.full((height, width, uc.PASS_CHANNELS[n]), np.nan, np.float32) for n in names}


def render(camera, objects, names=None, window=None, **kw):
    w = camera["width"] if window is None else window[2]
    h = camera["height"] if window is None else window[3]
    passes = alloc_passes(w, h, names)
    stats = uc.render(camera, objects, passes, window=window, **kw)
    return passes, stats


def rays_float64(camera):
    """Independent float64 camera rays (numpy), pixel centres, shape (H, W, 3)."""
    w, h = camera["width"], camera["height"]
    inv = np.linalg.inv(np.array(camera["projection"], np.float64))
    m = np.array(camera["matrix"], np.float64)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    ys, xs = np.mgrid[0:h, 0:w]
    ndc = np.stack([2 * (xs + 0.5) / w - 1, 2 * (ys + 0.5) / h - 1, -np.ones_like(xs, float),
                    np.ones_like(xs, float)], -1)
    near = ndc @ inv.T
    near = near[..., :3] / near[..., 3:]
    far_ndc = ndc.copy()
    far_ndc[..., 2] = 1.0
    far = far_ndc @ inv.T
    far = far[..., :3] / far[..., 3:]
    if camera["projection"][3][2] != 0.0:  # perspective
        d = near / np.linalg.norm(near, axis=-1, keepdims=True)
        o = np.zeros_like(d)
    else:
        d = (far - near) / np.linalg.norm(far - near, axis=-1, keepdims=True)
        o = near - d * (near[..., 2:] / d[..., 2:])
    origin = o @ rot.T + m[:3, 3]
    direction = d @ rot.T
    forward = -rot[:, 2]
    return origin, direction, forward


def sphere_hits(origin, direction, center=(0.0, 0.0, 0.0), radius=1.0):
    """Analytic first intersection t with a sphere (nan where missed) and closest approach."""
    rel = origin - np.asarray(center)
    b = np.sum(rel * direction, -1)
    c = np.sum(rel * rel, -1) - radius * radius
    disc = b * b - c
    t = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.nan)
    closest = np.sqrt(np.maximum(np.sum(rel * rel, -1) - b * b, 0))
    return t, closest


@pytest.fixture
def camera():
    return make_camera()
