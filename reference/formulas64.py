"""Float64 numpy references of the community formulas (issue 22), written from their published
definitions, not from the native core's code: the Mandelbulb (White and Nylander's triplex power,
2009: spherical coordinates, angles times n, radius to the n-th power) and the Mandelbox (Lowe,
2010: box fold, sphere fold, scale, translate). Each returns the orbit's end and the running
derivative the estimate is made of; membership is "the orbit stays within the escape radius for
max_iterations steps".

Nothing here is shared with native/src; numpy's own arctan2, arccos, sin, cos and power are used
where the core has its own float32 polynomials."""
import numpy as np


# -- bounds (the same theorems as scene.c, computed here in closed form) ----------------------------

def mandelbulb_radius(power, julia_c=None):
    """Radius of a ball holding the set and an escape radius. Mandelbrot mode: |c| > 2^(1/(m-1))
    escapes (m = floor(power)); Julia mode: the root R >= 1 of R^m - R - |c| = 0."""
    m = int(np.floor(power))
    if julia_c is None:
        return 2.0 ** (1.0 / (m - 1))
    c = float(np.linalg.norm(julia_c))
    lo, hi = 1.0, 2.0 + c
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid ** m - mid - c < 0 else (lo, mid)
    return hi


def mandelbox_halfwidth(scale, fold, julia_c=None):
    """Half-width H of a cube |z|_inf <= H holding the set; the escape radius is sqrt(3) H.
    Julia mode: (2 L |s| + |c|_inf) / (|s| - 1), proven; Mandelbrot mode: 2 L |s| / (|s| - 2) for
    |s| > 2 (proven), else Lowe's 2 L (s + 1) / (s - 1) for s > 1 and 2 L for s < -1... see
    scene.c for which are proofs."""
    s = abs(scale)
    if julia_c is not None:
        return (2 * fold * s + float(np.max(np.abs(julia_c)))) / (s - 1)
    if s > 2:
        return 2 * fold * s / (s - 2)
    raise ValueError("no closed form here")


# -- the Mandelbulb ---------------------------------------------------------------------------------

def mandelbulb(p, power, max_iterations, bailout, julia_c=None):
    """Points p (..., 3). Mandelbrot mode (julia_c None): z0 = p, c = p; Julia mode: z0 = p,
    c = julia_c. Returns (|z_n|, dr_n, escaped, escape count) with dr <- n r^(n-1) dr (+ 1 in
    Mandelbrot mode), dr0 = 1."""
    p = np.asarray(p, np.float64)
    c = p if julia_c is None else np.broadcast_to(np.asarray(julia_c, np.float64), p.shape)
    z = p.copy()
    dr = np.ones(p.shape[:-1])
    r = np.linalg.norm(z, axis=-1)
    escaped = np.zeros(p.shape[:-1], bool)
    count = np.zeros(p.shape[:-1])
    for _ in range(max_iterations):
        active = ~escaped
        if not active.any():
            break
        with np.errstate(invalid="ignore", divide="ignore"):
            theta = np.arccos(np.where(r > 0, z[..., 2] / np.where(r > 0, r, 1.0), 1.0))
        phi = np.arctan2(z[..., 1], z[..., 0])
        rn = r ** power
        new = rn[..., None] * np.stack([np.sin(power * theta) * np.cos(power * phi),
                                        np.sin(power * theta) * np.sin(power * phi),
                                        np.cos(power * theta)], -1) + c
        dr = np.where(active, power * r ** (power - 1) * dr + (0.0 if julia_c is not None else 1.0), dr)
        z = np.where(active[..., None], new, z)
        r = np.linalg.norm(z, axis=-1)
        count += active
        escaped |= active & (r > bailout)
    return r, dr, escaped, count


def mandelbulb_estimate(p, power, max_iterations, bailout, julia_c=None):
    """The analytic running-derivative estimate 0.5 log(r) r / dr where the orbit escapes, else 0."""
    r, dr, escaped, _ = mandelbulb(p, power, max_iterations, bailout, julia_c)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return np.where(escaped, 0.5 * np.log(np.maximum(r, 1.0)) * r / dr, 0.0)


# -- the Mandelbox ----------------------------------------------------------------------------------

def mandelbox(p, scale, fold, min_radius, fixed_radius, max_iterations, bailout, julia_c=None):
    """Points p (..., 3): z0 = p; per step the box fold (each coordinate reflected in the planes
    +-fold when beyond them), the sphere fold (inversion in the sphere of fixed_radius for
    min_radius < |z| < fixed_radius, a linear scale by (fixed/min)^2 inside min_radius), then
    z <- scale z + c, c = p (or julia_c). Returns (|z_n|, dr_n, escaped, count); dr is the running
    scale, dr <- |scale| k dr (+ 1 in Mandelbrot mode)."""
    p = np.asarray(p, np.float64)
    c = p if julia_c is None else np.broadcast_to(np.asarray(julia_c, np.float64), p.shape)
    z = p.copy()
    dr = np.ones(p.shape[:-1])
    escaped = np.zeros(p.shape[:-1], bool)
    count = np.zeros(p.shape[:-1])
    for _ in range(max_iterations):
        active = ~escaped
        if not active.any():
            break
        w = np.where(z > fold, 2 * fold - z, np.where(z < -fold, -2 * fold - z, z))
        r2 = np.sum(w * w, -1)
        k = np.where(r2 < min_radius ** 2, fixed_radius ** 2 / min_radius ** 2,
                     np.where(r2 < fixed_radius ** 2, fixed_radius ** 2 / np.maximum(r2, 1e-300), 1.0))
        new = scale * k[..., None] * w + c
        dr = np.where(active, abs(scale) * k * dr + (0.0 if julia_c is not None else 1.0), dr)
        z = np.where(active[..., None], new, z)
        count += active
        escaped |= active & (np.linalg.norm(z, axis=-1) > bailout)
    return np.linalg.norm(z, axis=-1), dr, escaped, count


def mandelbox_estimate(p, scale, fold, min_radius, fixed_radius, max_iterations, bailout, julia_c=None):
    """The running-scale estimate |z_n| / dr_n where the orbit escapes, else 0."""
    r, dr, escaped, _ = mandelbox(p, scale, fold, min_radius, fixed_radius, max_iterations, bailout, julia_c)
    return np.where(escaped, r / dr, 0.0)
