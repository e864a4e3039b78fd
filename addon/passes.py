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
)


def enabled(view_layer):
    """Passes enabled on a view layer, Combined first."""
    props = view_layer.unbound
    return [p for p in PASSES if p.toggle is None or getattr(props, p.toggle)]
