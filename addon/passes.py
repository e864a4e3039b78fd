"""The one table of render passes. update_render_passes (what Blender shows on the Render Layers
node and writes to multilayer EXR) and the result writer both read it."""
from collections import namedtuple

# name: Blender's pass name (Blender's own where one exists); channels/chan_id/kind: as
# RenderEngine.register_pass takes them; native: the native core's buffer; toggle: the
# ViewLayer.unbound property that enables it (None: always on).
RenderPass = namedtuple("RenderPass", "name channels chan_id kind native toggle description")

PASSES = (
    RenderPass("Combined", 4, "RGBA", 'COLOR', "combined", None, "Shaded image with alpha"),
    RenderPass("Depth", 1, "Z", 'VALUE', "depth", "use_pass_depth",
               "Distance along the camera's view axis, 1e10 for background as in Cycles"),
    RenderPass("Normal", 3, "XYZ", 'VECTOR', "normal", "use_pass_normal", "World-space surface normal"),
    RenderPass("Position", 3, "XYZ", 'VECTOR', "position", "use_pass_position", "World-space position of the hit"),
    RenderPass("Iterations", 1, "X", 'VALUE', "iterations", "use_pass_iterations",
               "Escape count of the iteration at the hit"),
    RenderPass("Steps", 1, "X", 'VALUE', "steps", "use_pass_steps",
               "Ray-marching steps of the pixel's ray, background included"),
    RenderPass("Distance", 1, "X", 'VALUE', "distance", "use_pass_distance",
               "Distance estimate at the hit, in world units"),
    RenderPass("AO", 1, "X", 'VALUE', "ao", "use_pass_ao", "Ambient occlusion: 1 in the open"),
    RenderPass("Shadow", 1, "X", 'VALUE', "shadow", "use_pass_shadow",
               "Fraction of the scene lights' direct light that is not shadowed"),
    RenderPass("Diffuse", 3, "RGB", 'COLOR', "diffuse", "use_pass_diffuse",
               "Direct light (scene lights, axle light and the World's light) times the surface colour"),
    RenderPass("Ambient", 3, "RGB", 'COLOR', "ambient", "use_pass_ambient",
               "Ambient light times the surface colour and ambient occlusion"),
    RenderPass("Reflection", 3, "RGB", 'COLOR', "reflection", "use_pass_reflection", "Reflected light"),
    RenderPass("Orbit Trap", 1, "X", 'VALUE', "orbit_trap", "use_pass_orbit_trap",
               "Closest approach of the orbit to the origin, min |z_k|"),
    RenderPass("Glow", 3, "RGB", 'COLOR', "glow", "use_pass_glow", "Glow from the marching steps"),
    RenderPass("Max Steps", 1, "X", 'VALUE', "max_steps", "use_pass_max_steps",
               "1 where the camera ray ran out of Max Steps before it hit or left the fractal (it shows what "
               "lies behind, the background mostly), 0 elsewhere; the fraction of the samples that did"),
    # Cycles' names and meaning, for the compositor's Denoise node (OpenImageDenoise): the first
    # hit's surface colour and its normal in camera space, each averaged over the samples.
    RenderPass("Denoising Albedo", 3, "RGB", 'COLOR', "denoising_albedo", "use_pass_denoising_data",
               "Surface colour of the first hit, for the Denoise node"),
    RenderPass("Denoising Normal", 3, "XYZ", 'VECTOR', "denoising_normal", "use_pass_denoising_data",
               "Normal of the first hit in camera space, for the Denoise node"),
)

# A toggle several passes share: its label and description (Cycles' "Denoising Data").
SHARED_TOGGLES = {"use_pass_denoising_data": ("Denoising Data", "Denoising Albedo and Denoising Normal, "
                                              "Cycles' passes for the compositor's Denoise node")}


def toggles():
    """(toggle, label, description) of each pass toggle once, in the table's order."""
    seen = {}
    for p in PASSES:
        if p.toggle and p.toggle not in seen:
            seen[p.toggle] = SHARED_TOGGLES.get(p.toggle, (p.name, p.description))
    return [(toggle, label, description) for toggle, (label, description) in seen.items()]


# Combined = fog(Diffuse + Ambient + Reflection) + Glow, with fog the first segment's depth cue.

# Passes the core takes from sample 0 alone (the pixel centre); every other pass is the mean of the
# samples, summed sample by sample and divided by the count with the last one (native kernel.h, put).
SAMPLE_ZERO = frozenset({"depth", "normal", "position", "iterations", "distance"})


def enabled(view_layer):
    """Passes enabled on a view layer, Combined first."""
    props = view_layer.unbound
    return [p for p in PASSES if p.toggle is None or getattr(props, p.toggle)]
