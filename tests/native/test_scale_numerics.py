"""Object scale numerics (issue 16, defect 6): sigma_min, the smallest singular value of the
object -> world matrix, scales every marching step, so an overestimate is an overstep (a correctness
bug, not a precision note). Rotated non-uniform scales up to a ratio of 1e8 against numpy's SVD:
the core's sigma_min is never above it (beyond numpy's own error, eps * sigma_max) and within 1e-6
of it; such an object is accepted and renders. Before the fix (eigenvalues of A^T A in closed
form) (1000, 1, 0.001) rotated gave sigma_min several times too large, or "zero scale"."""
import numpy as np
import pytest
import unbound_core as uc

from conftest import make_camera, render


def rotation(rng):
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    return q * np.sign(np.diag(r))


def placement(linear, offset=(0.1, -0.2, 0.3)):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, offset
    return m.tolist()


SCALES = [(1000.0, 1.0, 0.001), (1e4, 1.0, 1e-4), (1.0, 1e8, 1.0), (1e-4, 1e4, 1e-4), (5e3, 3e-5, 0.7),
          (1.0, 1.0, 1e-8), (2.0, 2.0, 2.0)]


@pytest.mark.parametrize("scale", SCALES)
def test_sigma_min_never_above_the_svd_under_rotation(scale):
    rng = np.random.default_rng(sum(int(np.log10(s) * 7) for s in scale) + 100)
    worst = 0.0
    for _ in range(40):
        lin = rotation(rng) @ np.diag(scale) @ rotation(rng).T
        sv = np.linalg.svd(lin, compute_uv=False)
        info = uc.describe(dict(matrix=placement(lin)))
        # numpy's SVD is backward stable: its error is a few eps * sigma_max.
        slack = 8 * np.finfo(float).eps * sv[0]
        assert info["sigma_min"] <= sv[-1] + slack, (scale, info["sigma_min"], sv)
        assert info["sigma_min"] >= sv[-1] * (1 - 1e-6) - slack, (scale, info["sigma_min"], sv)
        assert abs(info["sigma_max"] - sv[0]) <= 1e-12 * sv[0], (scale, info["sigma_max"], sv)
        worst = max(worst, abs(info["sigma_min"] / sv[-1] - 1))
    print(scale, "worst relative error of sigma_min: %.2e" % worst)


def test_rotated_thin_object_renders_without_overstep():
    """A Julia set squashed to (1, 1, 0.001) and rotated: accepted, and every ray that hits stops
    within its thin slab (an overstep would carry rays through it)."""
    rng = np.random.default_rng(7)
    lin = rotation(rng) @ np.diag((1.0, 1.0, 0.001)) @ rotation(rng).T
    obj = dict(mu=(-0.2, 0.8, 0.1, 0.0), max_iterations=14, matrix=placement(lin, (0, 0, 0)))
    passes, stats = render(make_camera(48, 36), [obj], ["alpha", "position"])
    assert not stats["cancelled"] and passes["alpha"].sum() > 20
    hit = passes["alpha"][..., 0] == 1
    local = np.linalg.solve(lin, passes["position"][hit].astype(np.float64).T).T
    # Object space: hits lie on the Julia set (within its bounding ball), not beyond it.
    assert np.linalg.norm(local, axis=1).max() <= uc.describe(obj)["bound_radius"] + 1e-3
