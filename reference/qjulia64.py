"""Float64 numpy reference of the quaternion Julia set method (Hart, Sandin & Kauffman 1989).

Written for clarity, not speed: the tests compare the native single-precision kernels with it,
and bench/ uses it as the "straightforward implementation" to race against."""
import numpy as np


def quat_mul(a, b):
    """Quaternion product of arrays (..., 4) with ij = k, jk = i, ki = j (eq. 2-4)."""
    a0, a1, a2, a3 = np.moveaxis(a, -1, 0)
    b0, b1, b2, b3 = np.moveaxis(b, -1, 0)
    return np.stack([
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    ], axis=-1)


def bounding_radius(mu):
    """Radius R of a ball containing K_mu: |z| > R with R^2 - R - |mu| = 0 escapes."""
    return 0.5 * (1.0 + np.sqrt(1.0 + 4.0 * np.linalg.norm(mu)))


def slice_points(points, basis=None, origin=None, theta=0.0):
    """Object-space points (..., 3) -> quaternions (..., 4) through the slice map, with the
    eq. 5-6 rotation applied literally later (see iterate's theta), not folded."""
    basis = np.eye(4, 3) if basis is None else np.asarray(basis, np.float64)
    origin = np.zeros(4) if origin is None else np.asarray(origin, np.float64)
    return origin + np.asarray(points, np.float64) @ basis.T


def iterate(q, mu, max_iterations, bailout, theta=0.0):
    """Iterates f_{mu,theta}(z) = g(f_mu(g^-1 z)), g(z) = e^{i theta} z, literally (eq. 5-6).

    Returns (|z| at the end, |z'| running derivative, escape count, escaped mask)."""
    q = np.array(q, np.float64, copy=True)
    mu = np.asarray(mu, np.float64)
    g = np.array([np.cos(theta), np.sin(theta), 0.0, 0.0])
    g_inv = np.array([np.cos(theta), -np.sin(theta), 0.0, 0.0])
    bail = max(bailout, bounding_radius(mu))
    dz = np.ones(q.shape[:-1])
    n = np.zeros(q.shape[:-1], np.int64)
    escaped = np.zeros(q.shape[:-1], bool)
    for _ in range(max_iterations):
        active = ~escaped
        r = np.linalg.norm(q, axis=-1)
        w = quat_mul(np.broadcast_to(g_inv, q.shape), q)
        new = quat_mul(np.broadcast_to(g, q.shape), quat_mul(w, w) + mu)
        dz = np.where(active, 2.0 * r * dz, dz)
        q = np.where(active[..., None], new, q)
        n = n + active
        escaped |= active & (np.linalg.norm(q, axis=-1) > bail)
        if escaped.all():
            break
    return np.linalg.norm(q, axis=-1), dz, n, escaped


def distance_estimate(q, mu, max_iterations, bailout, theta=0.0):
    """d(z) = |f^n(z)| log|f^n(z)| / (2 |f^n'(z)|) for escaping points, 0 for the others."""
    r, dz, n, escaped = iterate(q, mu, max_iterations, bailout, theta)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        d = r * np.log(r) / (2.0 * dz)
    return np.where(escaped, np.nan_to_num(d, nan=0.0, posinf=0.0), 0.0), n


def render(camera, obj, width, height, max_steps=None):
    """Straightforward float64 image of one object: the same method as the native core, vectorised
    over all rays with numpy. The object must have the identity transform and the default slice
    (1, i, j at k = 0, theta = 0); its keys mu, max_iterations, bailout, color, threshold_mode
    ("pixel": the pixel footprint / detail, or "fixed": epsilon), epsilon, detail and max_steps
    (the argument, else the key, else 2000) are read.

    camera is the native camera dict (matrix = camera to world, projection = 4x4, rows).
    Rows of the result run bottom to top, like the native passes. Returns dict(alpha=(H, W) bool,
    depth=(H, W) distance along the view axis (0 for misses), combined=(H, W, 3) Lambert with the
    light at the eye, march_steps=(H, W) marching steps of each ray, exhausted=(H, W) bool: rays
    still marching after max_steps steps (neither a hit nor out of the bounding ball),
    iterations=total formula iterations, steps=marching steps, rays=H*W)."""
    W, H = int(width), int(height)
    mu = np.asarray(obj.get("mu", (-0.2, 0.8, 0.0, 0.0)), np.float64)
    max_it = int(obj.get("max_iterations", 16))
    bailout = float(obj.get("bailout", 4.0))
    color = np.asarray(obj.get("color", (0.8, 0.8, 0.8)), np.float64)
    max_steps = int(obj.get("max_steps", 2000) if max_steps is None else max_steps)
    fixed = obj.get("threshold_mode", "pixel") == "fixed"
    epsilon = float(obj.get("epsilon", 1e-3))
    detail = float(obj.get("detail", 1.0))
    bisection_steps = 10

    # Camera: rotation columns normalised (the camera's scale is ignored), eye at the translation.
    cam = np.asarray(camera["matrix"], np.float64)
    rot = cam[:3, :3] / np.linalg.norm(cam[:3, :3], axis=0)
    eye, forward = cam[:3, 3], -rot[:, 2]
    proj = np.asarray(camera["projection"], np.float64)
    footprint = min(2.0 / (W * abs(proj[0, 0])), 2.0 / (H * abs(proj[1, 1])))  # per unit distance

    def threshold(t):
        """Hit threshold at distance t from the eye (the identity transform: object = world units)."""
        return np.full_like(t, epsilon) if fixed else t * footprint / detail
    inv_proj = np.linalg.inv(proj)

    # One ray per pixel centre; NDC y = -1 is the bottom row (row 0).
    ny, nx = np.meshgrid(2.0 * (np.arange(H) + 0.5) / H - 1.0, 2.0 * (np.arange(W) + 0.5) / W - 1.0,
                         indexing="ij")
    nx, ny = nx.ravel(), ny.ravel()

    def unproject(nz):
        v = np.stack([nx, ny, np.full_like(nx, nz), np.ones_like(nx)], axis=-1) @ inv_proj.T
        return v[:, :3] / v[:, 3:]

    near, far = unproject(-1.0), unproject(1.0)
    t_near, t_far = np.linalg.norm(near, axis=-1), np.linalg.norm(far, axis=-1)
    dirs = (near / t_near[:, None]) @ rot.T  # unit world directions; rays start at the eye

    # Bounding ball |eye + t dir| = R around the origin (section 3.4).
    R = bounding_radius(mu)
    b = dirs @ eye
    disc = b * b - (eye @ eye - R * R)
    sq = np.sqrt(np.maximum(disc, 0.0))
    t_start = np.maximum(-b - sq, t_near)
    t_end = np.minimum(-b + sq, t_far)
    marching = (disc >= 0.0) & (t_end >= t_start)

    total_iterations = total_steps = 0

    def de(idx, t):
        """Distance estimate at distance t along rays idx, and the iterations it took."""
        nonlocal total_iterations
        q = slice_points(eye + t[:, None] * dirs[idx])
        d, n = distance_estimate(q, mu, max_it, bailout)
        total_iterations += int(n.sum())
        return d

    # March by unbounding spheres: step by d until d < eps(t).
    n_rays = W * H
    t = t_start.copy()
    t_miss = t_start.copy()  # last sample outside the threshold
    hit = np.zeros(n_rays, bool)
    march_steps = np.zeros(n_rays, np.int64)
    active = np.flatnonzero(marching)
    for _ in range(max_steps):
        if active.size == 0:
            break
        total_steps += active.size
        march_steps[active] += 1
        d = de(active, t[active])
        is_hit = d < threshold(t[active])
        hit[active[is_hit]] = True
        go = active[~is_hit]
        t_miss[go] = t[go]
        t[go] += d[~is_hit]
        active = go[t[go] <= t_end[go]]
    exhausted = np.zeros(n_rays, bool)
    exhausted[active] = True

    # Refine: bisect between the last miss and the hit.
    idx = np.flatnonzero(hit)
    lo, hi = t_miss[idx], t[idx]
    for _ in range(bisection_steps):
        mid = 0.5 * (lo + hi)
        inside = de(idx, mid) < threshold(mid)
        hi = np.where(inside, mid, hi)
        lo = np.where(inside, lo, mid)
    t[idx] = hi

    # Normals: central differences of d with offset eps(t_hit) (eq. 15); Lambert, light at the eye.
    points = eye + t[idx, None] * dirs[idx]
    h = t[idx] * footprint  # eq. 15's step, the pixel footprint in either threshold mode
    grad = np.zeros((idx.size, 3))
    for axis in range(3):
        off = np.zeros((idx.size, 3))
        off[:, axis] = h
        for sign in (1.0, -1.0):
            d, n = distance_estimate(slice_points(points + sign * off), mu, max_it, bailout)
            total_iterations += int(n.sum())
            grad[:, axis] += sign * d
    length = np.linalg.norm(grad, axis=-1)
    flat = ~(length > 0.0)  # deep inside the set: face the camera
    normal = np.where(flat[:, None], -dirs[idx], grad / np.where(flat, 1.0, length)[:, None])
    lambert = np.maximum(0.0, -np.sum(normal * dirs[idx], axis=-1))

    alpha = np.zeros(n_rays, bool)
    alpha[idx] = True
    depth = np.zeros(n_rays)
    depth[idx] = t[idx] * (dirs[idx] @ forward)
    combined = np.zeros((n_rays, 3))
    combined[idx] = lambert[:, None] * color
    return dict(alpha=alpha.reshape(H, W), depth=depth.reshape(H, W), combined=combined.reshape(H, W, 3),
                march_steps=march_steps.reshape(H, W), exhausted=exhausted.reshape(H, W),
                iterations=total_iterations, steps=total_steps, rays=n_rays)
