"""Unbound: ray-marched 3-D deterministic fractals (quaternion Julia sets first) as a Blender
render engine, after Hart, Sandin & Kauffman, "Ray tracing deterministic 3-D fractals" (1989)."""
# Import order keeps reloading safe: utils -> passes -> composite -> export -> motion_blur -> properties -> engine -> viewport -> operators -> ui -> convert -> proxy.
if "bpy" in locals():
    import importlib
    for _mod in (utils, passes, composite, export, motion_blur, properties, engine, viewport, operators, ui, convert, proxy):  # noqa: F821
        importlib.reload(_mod)

import bpy

from . import utils, passes, composite, export, motion_blur, properties, engine, viewport, operators, ui, convert, proxy  # noqa: E402


class UnboundRenderEngine(bpy.types.RenderEngine):
    """Thin: every callback is one call into engine.py."""
    bl_idname = utils.ENGINE_ID
    bl_label = "Unbound"
    bl_use_preview = False
    bl_use_shading_nodes_custom = False

    def render(self, depsgraph):
        engine.render(self, depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        engine.update_render_passes(self, scene, renderlayer)

    # The Rendered viewport
    def view_update(self, context, depsgraph):
        viewport.view_update(self, context, depsgraph)

    def view_draw(self, context, depsgraph):
        viewport.view_draw(self, context, depsgraph)

    def __del__(self):
        viewport.free(self)


def register():
    properties.register()
    bpy.utils.register_class(UnboundRenderEngine)
    operators.register()
    ui.register()
    convert.register()
    proxy.register()


def unregister():
    proxy.unregister()
    convert.unregister()
    ui.unregister()
    operators.unregister()
    bpy.utils.unregister_class(UnboundRenderEngine)
    properties.unregister()
