"""Camera helpers for scripts and tests outside Blender: the same matrices Blender produces
(camera looks down its local -Z with +Y up; projections as Object.calc_matrix_camera)."""
import math


def _sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _normalize(a):
    n = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    return [a[0] / n, a[1] / n, a[2] / n]


def look_at(eye, target, up=(0.0, 0.0, 1.0)):
    """Camera-to-world 4x4 (rows) for a camera at eye looking at target."""
    forward = _normalize(_sub(target, eye))
    right = _normalize(_cross(forward, up))
    true_up = _cross(right, forward)
    back = [-forward[0], -forward[1], -forward[2]]
    return [[right[i], true_up[i], back[i], eye[i]] for i in range(3)] + [[0.0, 0.0, 0.0, 1.0]]


def perspective(fov_y, aspect, clip_start=0.1, clip_end=100.0, shift_x=0.0, shift_y=0.0):
    """OpenGL-style perspective projection (4x4 rows); fov_y in radians, aspect = width/height."""
    f = 1.0 / math.tan(fov_y / 2.0)
    n, e = clip_start, clip_end
    return [
        [f / aspect, 0.0, 2.0 * shift_x, 0.0],
        [0.0, f, 2.0 * shift_y * aspect, 0.0],
        [0.0, 0.0, -(e + n) / (e - n), -2.0 * e * n / (e - n)],
        [0.0, 0.0, -1.0, 0.0],
    ]


def orthographic(height, aspect, clip_start=0.1, clip_end=100.0):
    """Orthographic projection showing `height` world units vertically."""
    n, e = clip_start, clip_end
    return [
        [2.0 / (height * aspect), 0.0, 0.0, 0.0],
        [0.0, 2.0 / height, 0.0, 0.0],
        [0.0, 0.0, -2.0 / (e - n), -(e + n) / (e - n)],
        [0.0, 0.0, 0.0, 1.0],
    ]
