"""Motion blur of final renders (issue 19): Blender's Render > Motion Blur settings as Cycles reads them.

The shutter is open for `motion_blur_shutter` frames; `motion_blur_position` puts the current frame
at its start, centre or end (Cycles' BlenderSync::sync_motion): START [f, f + L], CENTER
[f - L/2, f + L/2], END [f - L, f]. Within it, time is distributed as `motion_blur_shutter_curve`
says (a CurveMapping over the open shutter; Cycles turns it into a table of its inverse CDF and
maps each ray's random number through it). Unbound renders a whole sample at one time, so the
engine evaluates the scene at that sub-frame (RenderEngine.frame_set, as Cycles' motion sync does)
and exports camera, objects, lights and fractal parameters there: camera and object motion and
keyframed parameters (mu and the others) are all sampled within the shutter the same way."""
import math

import numpy as np

from .export import RenderError

# 1 / golden ratio: sample s opens the shutter at fraction frac(1/2 + s / phi) of its CDF. The
# golden-ratio (Kronecker) sequence spreads every prefix over the shutter most evenly of the 1-D
# low-discrepancy sequences (star discrepancy of 64 samples 0.022; Halton base 11: 0.075; 16
# samples 0.069 and 0.25), so the Image Editor's progressive samples sweep the whole shutter
# from the first ones, and sample 0 is the shutter's median: a one-sample render is the first
# sample of a blurred one. It shares no base with the core's pixel jitter (Halton 2, 3) or lens
# samples (Halton 5, 7, shifted per pixel), whose correlation with the time would bias the blur.
INVERSE_GOLDEN = 0.6180339887498949
# Points of the shutter curve read for its CDF: as many as Cycles' table (RAMP_TABLE_SIZE).
CURVE_POINTS = 256


def blur_enabled(scene, view_layer):
    """Motion blur on for this view layer: the scene's setting and the layer's own (Cycles reads both)."""
    return bool(scene.render.use_motion_blur and view_layer.use_motion_blur)


def shutter_interval(render, frame):
    """(opening time, length) of the shutter in frames around `frame` (frame + subframe)."""
    length = float(render.motion_blur_shutter)
    opening = {'START': 0.0, 'CENTER': -0.5, 'END': -1.0}[render.motion_blur_position]
    return frame + opening * length, length


def shutter_cdf(curve_mapping):
    """(fractions of the open shutter, CDF at them) of a shutter curve: its values at CURVE_POINTS
    evenly spaced fractions (their magnitudes, as Cycles takes them), integrated by the trapezoid
    rule: a flat curve is a uniform shutter exactly."""
    curve_mapping.update()  # Blender's evaluation table follows the points (Cycles calls it too)
    curve = curve_mapping.curves[0]
    x = np.linspace(0.0, 1.0, CURVE_POINTS)
    y = np.abs(np.array([curve_mapping.evaluate(curve, float(v)) for v in x]))
    cdf = np.concatenate(([0.0], np.cumsum(0.5 * (y[1:] + y[:-1]))))
    if not cdf[-1] > 0.0:
        raise RenderError("the motion blur's shutter curve is zero everywhere: no light reaches the film "
                          "(Render Properties > Motion Blur > Shutter Curve)")
    return x, cdf / cdf[-1]


def shutter_fraction(u, fractions, cdf):
    """The fraction of the open shutter where the shutter curve's CDF reaches u (its inverse)."""
    return float(np.interp(u, cdf, fractions))


def sample_times(scene, samples):
    """The scene time (frame + subframe) of each of `samples` samples: a pure function of the
    sample index and the settings, the same bits on every machine and thread count."""
    opening, length = shutter_interval(scene.render, scene.frame_current + scene.frame_subframe)
    fractions, cdf = shutter_cdf(scene.render.motion_blur_shutter_curve)
    return [opening + length * shutter_fraction((0.5 + s * INVERSE_GOLDEN) % 1.0, fractions, cdf)
            for s in range(samples)]


def set_time(engine, time):
    """Evaluates the render's depsgraph at scene time `time` (Blender splits it into a whole frame
    and a subframe in [0, 1))."""
    frame = math.floor(time)
    engine.frame_set(int(frame), time - frame)
