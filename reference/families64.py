"""Float64 numpy references of section 5's families, written for clarity: set membership by
iteration (or, for an IFS, by the leaf balls of its map hierarchy), the escape-time estimates
where they are defined, and attractor points. The tests compare the native single-precision
kernels with them; nothing here shares code with the native core."""
import numpy as np

from reference import qjulia64 as qj


# -- quaternion Mandelbrot slices ------------------------------------------------------------------

def mandelbrot(c, max_iterations, bailout=4.0):
    """Iterates z <- z^2 + c from z = c (the orbit of 0 after one step) over quaternions c (..., 4).
    Returns (|z|, |dz/dc| by Milnor's running bound, escaped)."""
    c = np.asarray(c, np.float64)
    bail = max(bailout, 2.0)
    z = c.copy()
    dz = np.ones(c.shape[:-1])
    escaped = np.linalg.norm(z, axis=-1) > bail
    for _ in range(max_iterations):
        active = ~escaped
        r = np.linalg.norm(z, axis=-1)
        dz = np.where(active, 2.0 * r * dz + 1.0, dz)
        z = np.where(active[..., None], qj.quat_mul(z, z) + c, z)
        escaped |= active & (np.linalg.norm(z, axis=-1) > bail)
    return np.linalg.norm(z, axis=-1), dz, escaped


def mandelbrot_estimate(c, max_iterations, bailout=4.0):
    r, dz, escaped = mandelbrot(c, max_iterations, bailout)
    return np.where(escaped, r * np.log(np.maximum(r, 1.0)) / (2.0 * dz), 0.0)


# -- Julia set stacks ------------------------------------------------------------------------------

def path_c(path, u):
    """c(u) and |dc/du| on the piecewise linear path through `path` (n, 2), u in [0, 1]."""
    path = np.asarray(path, np.float64)
    n = len(path) - 1
    u = np.clip(u, 0.0, 1.0)
    if n == 0:
        return np.broadcast_to(path[0, 0] + 1j * path[0, 1], u.shape), np.zeros_like(u)
    pos = u * n
    i = np.minimum(pos.astype(int), n - 1)
    f = pos - i
    c0 = path[i, 0] + 1j * path[i, 1]
    c1 = path[i + 1, 0] + 1j * path[i + 1, 1]
    return c0 + f * (c1 - c0), np.abs(c1 - c0) * n


def stack_escape(points, path, height, max_iterations, bailout=4.0):
    """Points (..., 3) = (Re z, Im z, w): (escaped, inside the slab, |z_n|, |dz/dz0|, |dz/dc|)."""
    p = np.asarray(points, np.float64)
    c, _ = path_c(path, p[..., 2] / height + 0.5)
    radius = max(qj.bounding_radius([abs(complex(*q)), 0, 0, 0]) for q in np.asarray(path, np.float64))
    bail = max(bailout, radius)
    z = p[..., 0] + 1j * p[..., 1]
    dz, dc = np.ones(z.shape), np.zeros(z.shape)
    escaped = np.zeros(z.shape, bool)
    for _ in range(max_iterations):
        active = ~escaped
        r = np.abs(z)
        dc = np.where(active, 2.0 * r * dc + 1.0, dc)
        dz = np.where(active, 2.0 * r * dz, dz)
        z = np.where(active, z * z + c, z)
        escaped |= active & (np.abs(z) > bail)
    in_slab = np.abs(p[..., 2]) <= 0.5 * height
    return escaped, in_slab, np.abs(z), dz, dc


# -- the cubic connectedness locus -----------------------------------------------------------------

def cubic_bounded(q, sign, max_iterations, bailout, extent):
    """Whether the orbit of the critical point sign * a under z^3 - 3a^2 z + b stays within the
    escape radius, for 4-D points q = (Re a, Im a, Re b, Im b)."""
    q = np.asarray(q, np.float64)
    a = q[..., 0] + 1j * q[..., 1]
    b = q[..., 2] + 1j * q[..., 3]
    bail = max(bailout, 2.0 + (1.0 + np.sqrt(3.0)) * extent)
    z = sign * a
    escaped = np.zeros(a.shape, bool)
    for _ in range(max_iterations):
        active = ~escaped
        z = np.where(active, z ** 3 - 3.0 * a * a * z + b, z)
        escaped |= active & (np.abs(z) > bail)
    return ~escaped


def cubic_orbit_estimate(q, basis, sign, max_iterations, bailout, extent):
    """The empirical estimate |z_n| log|z_n| / (2 |grad z_n|) along one critical orbit, the
    gradient over the slice axes (columns of basis, 4x3) from dz/da and dz/db."""
    q = np.asarray(q, np.float64)
    basis = np.asarray(basis, np.float64)
    a = q[..., 0] + 1j * q[..., 1]
    b = q[..., 2] + 1j * q[..., 3]
    bail = max(bailout, 2.0 + (1.0 + np.sqrt(3.0)) * extent)
    z, dza, dzb = sign * a, np.full(a.shape, sign + 0j), np.zeros(a.shape, complex)
    escaped = np.zeros(a.shape, bool)
    for _ in range(max_iterations):
        active = ~escaped
        fp = 3.0 * z * z - 3.0 * a * a
        dza = np.where(active, fp * dza - 6.0 * a * z, dza)
        dzb = np.where(active, fp * dzb + 1.0, dzb)
        z = np.where(active, z ** 3 - 3.0 * a * a * z + b, z)
        escaped |= active & (np.abs(z) > bail)
    grad2 = sum(np.abs(dza * (basis[0, k] + 1j * basis[1, k]) + dzb * (basis[2, k] + 1j * basis[3, k])) ** 2
                for k in range(3))
    r = np.abs(z)
    return np.where(escaped, r * np.log(np.maximum(r, 1.0)) / (2.0 * np.sqrt(grad2)), 0.0)


def cubic_estimate(q, basis, component, max_iterations, bailout, extent):
    plus = cubic_orbit_estimate(q, basis, 1.0, max_iterations, bailout, extent)
    minus = cubic_orbit_estimate(q, basis, -1.0, max_iterations, bailout, extent)
    d = {"plus": plus, "minus": minus, "union": np.minimum(plus, minus), "both": np.maximum(plus, minus)}[component]
    return np.maximum(d, np.linalg.norm(np.asarray(q, np.float64), axis=-1) - extent)


def cubic_inside(q, component, max_iterations, bailout, extent):
    plus = cubic_bounded(q, 1.0, max_iterations, bailout, extent)
    minus = cubic_bounded(q, -1.0, max_iterations, bailout, extent)
    inside = {"plus": plus, "minus": minus, "union": plus | minus, "both": plus & minus}[component]
    return inside & (np.linalg.norm(np.asarray(q, np.float64), axis=-1) <= extent)


# -- 3-D iterated function systems -----------------------------------------------------------------

class IFS:
    """An IFS of affine maps (m, 3, 4) with the bounding ball of section 5.3's hierarchy, built
    independently of the native core: operator norms by SVD, the fixed points' centroid as the
    centre, the smallest radius the maps send into itself."""

    def __init__(self, maps):
        self.maps = np.asarray(maps, np.float64)
        self.lin = self.maps[:, :, :3]
        self.off = self.maps[:, :, 3]
        self.norms = np.linalg.svd(self.lin, compute_uv=False)[:, 0]
        fixed = np.array([np.linalg.solve(np.eye(3) - a, t) for a, t in zip(self.lin, self.off)])
        self.center = fixed.mean(axis=0)
        images = np.einsum("mij,j->mi", self.lin, self.center) + self.off
        self.radius = np.max(np.linalg.norm(images - self.center, axis=1) / (1.0 - self.norms))

    def leaves(self, depth):
        """Centres (k, 3) and radii (k,) of the balls w_word(B) over all words of length depth."""
        lin = np.eye(3)[None]
        off = np.zeros((1, 3))
        scale = np.ones(1)
        for _ in range(depth):
            # Children of word w by map m: w o w_m = (L A_m, L t_m + t).
            off = (np.einsum("wij,mj->wmi", lin, self.off) + off[:, None]).reshape(-1, 3)
            lin = np.einsum("wij,mjk->wmik", lin, self.lin).reshape(-1, 3, 3)
            scale = (scale[:, None] * self.norms[None]).reshape(-1)
        centres = np.einsum("wij,j->wi", lin, self.center) + off
        return centres, scale * self.radius

    def chaos_game(self, count, seed=0, burn_in=50):
        """Points of the attractor by the chaos game (random map each step) in float64."""
        rng = np.random.default_rng(seed)
        # Start on the attractor: the fixed point of map 0.
        x = np.linalg.solve(np.eye(3) - self.lin[0], self.off[0])
        out = np.empty((count, 3))
        choice = rng.integers(0, len(self.maps), count + burn_in)
        for k, i in enumerate(choice):
            x = self.lin[i] @ x + self.off[i]
            if k >= burn_in:
                out[k - burn_in] = x
        return out


def leaf_distance(points, centres, radii, chunk=4096):
    """Signed distance from points (n, 3) to the union of balls: min |p - c| - r."""
    points = np.asarray(points, np.float64)
    out = np.empty(len(points))
    for s in range(0, len(points), chunk):
        d = np.linalg.norm(points[s:s + chunk, None, :] - centres[None], axis=-1) - radii[None]
        out[s:s + chunk] = d.min(axis=1)
    return out
