"""Arbitrary-precision referee of the deep zoom (issue 18), independent of the native core: the
quaternion Julia set's distance estimate and a ray's first point within epsilon of the set, in
Python's decimal (libmpdec) at 110 significant digits, with no reference orbit, no perturbation
and no rounding to double anywhere: the fractal's point anchor + u 10^-zoom is formed exactly.

decimal rather than mpmath: the same arbitrary precision (correctly rounded + - * / sqrt ln at the
context's precision), but libmpdec is C: ~0.5 us per operation here against mpmath's ~10 us in
pure Python (no gmpy2), which makes a few dozen rays at zoom 30 a matter of seconds."""
import decimal
import math

import numpy as np

DIGITS = 110
CONTEXT = decimal.Context(prec=DIGITS)
D = CONTEXT.create_decimal


def exact(x):
    """The exact value of a binary float (numpy or Python) as a Decimal."""
    return decimal.Decimal(float(x))


def iterations_for_zoom(max_iterations, zoom):
    """The core's rule (native/src/zoom.h): max_iterations + ceil(7 zoom), at most 1024."""
    return min(max_iterations + math.ceil(7.0 * zoom), 1024)


class Julia:
    """K_mu of z^2 + mu on the 1-i-j slice (k = 0), mu given as the float32 values the core
    iterates, and its estimate d(z) = |z_n| ln|z_n| / (2 |z_n'|), |z'| <- 2|z||z'|: the same
    formula as native/src/estimators.h, evaluated exactly (to 110 digits)."""

    def __init__(self, mu, max_iterations, bailout=4.0):
        self.mu = [exact(np.float32(m)) for m in mu]
        self.max_iterations = max_iterations
        self.bail2 = D(bailout) * D(bailout)

    def estimate(self, q):
        """Distance estimate (fractal units) at quaternion q (4 Decimals); 0 if no escape."""
        with decimal.localcontext(CONTEXT):
            a, b, c, d = q
            mu0, mu1, mu2, mu3 = self.mu
            r2 = a * a + b * b + c * c + d * d
            dr2 = decimal.Decimal(1)
            for _ in range(self.max_iterations):
                dr2 *= 4 * r2
                a2 = a + a
                a, b, c, d = a * a - (b * b + c * c + d * d) + mu0, a2 * b + mu1, a2 * c + mu2, a2 * d + mu3
                r2 = a * a + b * b + c * c + d * d
                if r2 > self.bail2:
                    return (r2 / dr2).sqrt() * r2.ln() / 4
            return decimal.Decimal(0)


class Mandelbrot(Julia):
    """The quaternion Mandelbrot slice: z0 = c = the point, Milnor's |z'| <- 2|z||z'| + 1, and the
    estimate |z_n| ln|z_n| / (2 |z_n'|), as native/src/estimators.h (mu unused)."""

    def estimate(self, q):
        with decimal.localcontext(CONTEXT):
            c0, c1, c2, c3 = q
            a, b, c, d = q
            r2 = a * a + b * b + c * c + d * d
            dm = decimal.Decimal(1)
            for _ in range(self.max_iterations):
                dm = 2 * r2.sqrt() * dm + 1
                a2 = a + a
                a, b, c, d = a * a - (b * b + c * c + d * d) + c0, a2 * b + c1, a2 * c + c2, a2 * d + c3
                r2 = a * a + b * b + c * c + d * d
                if r2 > self.bail2:
                    return r2.sqrt() * r2.ln() / (4 * dm)
            return decimal.Decimal(0)


def point(anchor, zoom, u):
    """The fractal's point anchor + u 10^-zoom (anchor: 3 Decimals; u: 3 floats), as a
    quaternion on the 1-i-j slice."""
    with decimal.localcontext(CONTEXT):
        scale = decimal.Decimal(10) ** (-decimal.Decimal(repr(float(zoom))))
        return [anchor[k] + exact(u[k]) * scale for k in range(3)] + [decimal.Decimal(0)]


def ray_estimate(julia, anchor, zoom, origin, direction, t):
    """The estimate in local units at origin + t direction (floats; t a float or Decimal)."""
    with decimal.localcontext(CONTEXT):
        scale = decimal.Decimal(10) ** (-decimal.Decimal(repr(float(zoom))))
        t = t if isinstance(t, decimal.Decimal) else exact(t)
        p = [anchor[k] + (exact(origin[k]) + t * exact(direction[k])) * scale for k in range(3)]
        return julia.estimate(p + [decimal.Decimal(0)]) / scale


def first_hit(julia, anchor, zoom, origin, direction, epsilon, t_max=100.0, max_steps=8000, refine=40,
              step_factor=0.5):
    """The first t along the local ray origin + t direction where the estimate (in local units)
    falls below epsilon: unbounding-sphere steps of step_factor times the estimate, then bisection
    of the last step to 2^-refine of it. None if the ray leaves t_max first.

    The estimate is not continuous: it jumps by a few per cent where the escape count changes, so
    just above the surface it can dip below epsilon, rise above it and fall again within a step.
    Half steps (the render takes whole ones) find the first dip where a whole step may pass it."""
    with decimal.localcontext(CONTEXT):
        def local_estimate(t):
            return ray_estimate(julia, anchor, zoom, origin, direction, t)

        t, prev = decimal.Decimal(0), None
        for _ in range(max_steps):
            e = local_estimate(t)
            if e < epsilon:
                break
            prev = t
            t += exact(step_factor) * e
            if t > t_max:
                return None
        else:
            return None
        if prev is None:
            return float(t)
        lo, hi = prev, t
        for _ in range(refine):
            mid = (lo + hi) / 2
            if local_estimate(mid) < epsilon:
                hi = mid
            else:
                lo = mid
        return float(hi)


def surface_anchor(julia, start, direction, fractal_epsilon, max_steps=2000):
    """A point within fractal_epsilon (estimate) of K along the ray start + t direction (start and
    direction: 3 floats), by unbounding-sphere steps in exact arithmetic: the anchor of a zoom
    into the surface."""
    with decimal.localcontext(CONTEXT):
        p = [exact(v) for v in start]
        dvec = [exact(v) for v in direction]
        for _ in range(max_steps):
            e = julia.estimate(p + [decimal.Decimal(0)])
            if e < fractal_epsilon:
                return p
            p = [p[k] + e * dvec[k] for k in range(3)]
        raise RuntimeError("the ray did not reach the surface")


def anchor_text(p, digits):
    """Three Decimals as the core's anchor string, `digits` digits after the point."""
    with decimal.localcontext(CONTEXT):
        q = decimal.Decimal(1).scaleb(-digits)
        return " ".join(str(v.quantize(q, rounding=decimal.ROUND_HALF_EVEN)) for v in p)
