"""Float64 numpy references of the kaleidoscopic IFS and of hybrids (issue 22), written from the
published formulations, not from the native core's code.

KIFS: Knighty's "Kaleidoscopic (escape time) IFS" (fractalforums.com, 2010), in two forms:

* the generic one the kind's parameters describe, z <- s R F(z) - o (s - 1), F reflections in
  planes n.z = d, the distance of a final shape divided by s^n, an escaped orbit's bound
  (|z_k| - rho) / s^k;
* the three shapes as Knighty wrote them, with his swaps and translation rather than plane
  folds: the Menger sponge (abs, sort x >= y >= z, scale 3, "if z.z < -1 then z.z += 2"), the
  Sierpinski tetrahedron ("if x + y < 0 then (x, y) = (-y, -x)", ...) and the octahedral flake.
  The core gets these as plane lists (addon/operators.py's KIFS_SHAPES); the tests hold the
  two equal, which checks the plane lists as well as the kernel.

Hybrid: Mandelbulb (White-Nylander triplex, theta from +z), Mandelbox (Lowe) and KIFS steps in
turn with one running derivative."""
import numpy as np

SQRT3 = np.sqrt(3.0)


def euler_xyz(e):
    """Blender's XYZ Euler rotation, Rz @ Ry @ Rx."""
    x, y, z = e
    rx = np.array([[1, 0, 0], [0, np.cos(x), -np.sin(x)], [0, np.sin(x), np.cos(x)]])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    rz = np.array([[np.cos(z), -np.sin(z), 0], [np.sin(z), np.cos(z), 0], [0, 0, 1]])
    return rz @ ry @ rx


def shape_distance(z, shape, size):
    """Signed distance (exact, or a 1-Lipschitz lower bound) of the final shape."""
    if shape == "sphere":
        return np.linalg.norm(z, axis=-1) - size
    if shape == "box":
        q = np.abs(z) - size
        return np.linalg.norm(np.maximum(q, 0), axis=-1) + np.minimum(q.max(-1), 0)
    x, y, w = z[..., 0], z[..., 1], z[..., 2]
    if shape == "tetrahedron":
        return (np.max([-x - y - w, -x + y + w, x - y + w, x + y - w], axis=0) - size) / SQRT3
    if shape == "octahedron":
        return (np.abs(z).sum(-1) - size) / SQRT3
    raise ValueError(shape)


def kifs_rho(planes, scale, offset, shape, size):
    """Radius of the ball holding every level's set, from the escape argument (see scene.c's
    comment for the proof; recomputed here from it)."""
    planes = np.asarray(planes, float)
    n = np.linalg.norm(planes[:, :3], axis=1) if len(planes) else np.zeros(0)
    d = planes[:, 3] / n if len(planes) else np.zeros(0)
    delta = 2 * np.sum(-d[d < 0])
    rho = (scale * delta + np.linalg.norm(offset) * (scale - 1)) / (scale - 1)
    return max(rho, (SQRT3 if shape in ("box", "tetrahedron") else 1.0) * size)


def kifs_step(z, planes, scale, offset, rotation=None, normalize=True):
    """normalize=False: the planes' normals are unit vectors already, taken as given (e.g. rounded
    to float32 as a kernel reads them, which a second normalisation would move)."""
    for nx, ny, nz, d in planes:
        n = np.array([nx, ny, nz], float)
        length = np.linalg.norm(n) if normalize else 1.0
        n, d = n / length, d / length
        t = z @ n - d
        z = np.where((t < 0)[..., None], z - 2 * t[..., None] * n, z)
    if rotation is not None and np.any(rotation):
        z = z @ euler_xyz(rotation).T
    return scale * z - np.asarray(offset, float) * (scale - 1)


def kifs(p, planes, scale, offset, rotation, shape, size, iterations, bailout, normalize=True):
    """Returns (estimate, inside-the-level-n-set, steps taken): the escape-time KIFS
    (normalize: kifs_step's)."""
    p = np.asarray(p, np.float64)
    rho = kifs_rho(planes, scale, offset, shape, size)
    bailout = max(bailout, rho)
    z = p.copy()
    dr = np.ones(p.shape[:-1])
    escaped = np.zeros(p.shape[:-1], bool)
    count = np.zeros(p.shape[:-1])
    for _ in range(iterations):
        active = ~escaped
        if not active.any():
            break
        new = kifs_step(z, planes, scale, offset, rotation, normalize)
        z = np.where(active[..., None], new, z)
        dr = np.where(active, dr * scale, dr)
        count += active
        escaped |= active & (np.linalg.norm(z, axis=-1) > bailout)
    d = np.where(escaped, np.linalg.norm(z, axis=-1) - rho, shape_distance(z, shape, size))
    return d / dr, ~escaped & (shape_distance(z, shape, size) <= 0), count


# -- Knighty's three shapes as he wrote them -----------------------------------------------------------

def _knighty(p, step, scale, shape, size, iterations, bailout, rho):
    p = np.asarray(p, np.float64)
    z = p.copy()
    out = np.zeros(p.shape[:-1])
    done = np.zeros(p.shape[:-1], bool)
    for k in range(1, iterations + 1):
        z = step(z)
        r = np.linalg.norm(z, axis=-1)
        esc = ~done & (r > max(bailout, rho))
        out = np.where(esc, (r - rho) / scale ** k, out)
        done |= esc
    return np.where(done, out, shape_distance(z, shape, size) / scale ** iterations)


def menger_knighty(p, iterations, bailout=4.0):
    """Knighty's Menger sponge: z = abs(z); sort so that x >= y >= z; z = 3 z - 2 (1, 1, 1);
    if z.z < -1 then z.z += 2; the unit box at the end."""
    def step(z):
        z = np.abs(z)
        z = -np.sort(-z, axis=-1)  # x >= y >= z
        z = 3 * z - 2
        z[..., 2] = np.where(z[..., 2] < -1, z[..., 2] + 2, z[..., 2])
        return z
    return _knighty(p, step, 3.0, "box", 1.0, iterations, bailout, SQRT3)


def sierpinski_knighty(p, iterations, bailout=4.0):
    """Knighty's Sierpinski tetrahedron: if x + y < 0 then (x, y) = (-y, -x), likewise (x, z) and
    (y, z); z = 2 z - (1, 1, 1); the tetrahedron of vertices (1, 1, 1), (1, -1, -1), ... at the end."""
    def step(z):
        z = z.copy()
        for a, b in ((0, 1), (0, 2), (1, 2)):
            m = z[..., a] + z[..., b] < 0
            za, zb = z[..., a].copy(), z[..., b].copy()
            z[..., a] = np.where(m, -zb, za)
            z[..., b] = np.where(m, -za, zb)
        return 2 * z - 1
    return _knighty(p, step, 2.0, "tetrahedron", 1.0, iterations, bailout, SQRT3)


def octahedral_knighty(p, iterations, bailout=4.0):
    """Knighty's octahedral KIFS: if x + y < 0 then (x, y) = (-y, -x); if x + z < 0 then
    (x, z) = (-z, -x); if x - y < 0 then swap x, y; if x - z < 0 then swap x, z;
    z = 2 z - (1, 0, 0); the octahedron |x| + |y| + |z| <= 1 at the end."""
    def step(z):
        z = z.copy()
        for a, b, sign in ((0, 1, -1), (0, 2, -1), (0, 1, 1), (0, 2, 1)):
            m = z[..., a] - sign * z[..., b] < 0
            za, zb = z[..., a].copy(), z[..., b].copy()
            z[..., a] = np.where(m, sign * zb, za)
            z[..., b] = np.where(m, sign * za, zb)
        return 2 * z - np.array([1.0, 0, 0])
    return _knighty(p, step, 2.0, "octahedron", 1.0, iterations, bailout, 1.0)


# -- hybrids ---------------------------------------------------------------------------------------

def hybrid(p, steps, iterations, bailout, julia_c=None, power=8.0, box=(2.0, 1.0, 0.5, 1.0),
           kifs_args=((), 2.0, (1, 1, 1), None)):
    """steps: [(formula, count)], formula 0 Mandelbulb, 1 Mandelbox, 2 KIFS, applied in turn,
    cycling. Returns (estimate, escaped): 0.5 log r r / dr with a Mandelbulb step, else r / dr."""
    p = np.asarray(p, np.float64)
    c = p if julia_c is None else np.broadcast_to(np.asarray(julia_c, float), p.shape)
    add = 0.0 if julia_c is not None else 1.0
    seq = [f for f, n in steps for _ in range(int(n))]
    z = p.copy()
    dr = np.ones(p.shape[:-1])
    escaped = np.zeros(p.shape[:-1], bool)
    s, L, rmin, rfix = box
    for it in range(iterations):
        active = ~escaped
        if not active.any():
            break
        f = seq[it % len(seq)]
        r = np.linalg.norm(z, axis=-1)
        if f == 0:
            with np.errstate(invalid="ignore", divide="ignore"):
                theta = np.arccos(np.where(r > 0, z[..., 2] / np.where(r > 0, r, 1), 1))
            phi = np.arctan2(z[..., 1], z[..., 0])
            new = (r ** power)[..., None] * np.stack([np.sin(power * theta) * np.cos(power * phi),
                                                      np.sin(power * theta) * np.sin(power * phi),
                                                      np.cos(power * theta)], -1) + c
            ndr = power * r ** (power - 1) * dr + add
        elif f == 1:
            w = np.where(z > L, 2 * L - z, np.where(z < -L, -2 * L - z, z))
            r2 = np.sum(w * w, -1)
            k = np.where(r2 < rmin ** 2, rfix ** 2 / rmin ** 2,
                         np.where(r2 < rfix ** 2, rfix ** 2 / np.maximum(r2, 1e-300), 1.0))
            new = s * k[..., None] * w + c
            ndr = abs(s) * k * dr + add
        else:
            planes, ks, ko, kr = kifs_args
            new = kifs_step(z, planes, ks, ko, kr)
            ndr = dr * ks
        z = np.where(active[..., None], new, z)
        dr = np.where(active, ndr, dr)
        escaped |= active & (np.linalg.norm(z, axis=-1) > bailout)
    r = np.linalg.norm(z, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        est = 0.5 * np.log(np.maximum(r, 1.0)) * r / dr if any(f == 0 for f, _ in steps) else r / dr
    return np.where(escaped, est, 0.0), escaped
