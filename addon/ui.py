"""Panels: Object tab (fractal parameters), Render tab (engine settings), View Layer tab
(passes). Shown only when Unbound is the render engine."""
import bpy

from . import passes, utils


class UnboundPanel:
    COMPAT_ENGINES = {utils.ENGINE_ID}
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class FractalPanel(UnboundPanel):
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and utils.is_fractal(context.object)


class UNBOUND_PT_fractal(FractalPanel, bpy.types.Panel):
    bl_label = "Unbound Fractal"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = True
        props = context.object.unbound
        layout.prop(props, "kind")
        # Label the quaternion's components as Blender labels Location X, Y, Z: without a subtype a
        # 4-vector shows one "Mu" label over four unlabelled fields.
        col = layout.column(align=True)
        for i, text in enumerate(("Mu 1", "i", "j", "k")):
            col.prop(props, "mu", index=i, text=text)
        layout.prop(props, "theta")
        layout.prop(props, "color")


class UNBOUND_PT_fractal_slice(FractalPanel, bpy.types.Panel):
    bl_label = "Slice"
    bl_parent_id = "UNBOUND_PT_fractal"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.object.unbound
        layout.prop(props, "slice_offset")
        # "Rotation", not the property's "Slice Rotation": the panel says Slice already, and the longer
        # label is cut to "Slice Ro..." in the Properties editor of a 1366x768 screen.
        layout.column().prop(props, "slice_rotation", text="Rotation")


class UNBOUND_PT_fractal_quality(FractalPanel, bpy.types.Panel):
    bl_label = "Quality"
    bl_parent_id = "UNBOUND_PT_fractal"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.object.unbound
        col = layout.column()
        col.prop(props, "max_iterations")
        col.prop(props, "bailout")
        col.prop(props, "threshold_mode")
        col.prop(props, "detail" if props.threshold_mode == 'PIXEL' else "epsilon")
        col = layout.column()
        col.prop(props, "step_factor")
        col.prop(props, "max_step")
        col.prop(props, "max_steps")
        col.prop(props, "bisection_steps")


class UNBOUND_PT_render(UnboundPanel, bpy.types.Panel):
    bl_label = "Unbound"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.unbound
        layout.prop(settings, "tile_size")
        layout.prop(settings, "simd")
        layout.prop(context.scene.render, "film_transparent")
        layout.operator("scene.unbound_setup_compositing", icon='NODETREE')


class UNBOUND_PT_passes(UnboundPanel, bpy.types.Panel):
    bl_label = "Unbound Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        props = context.view_layer.unbound
        col = layout.column(heading="Include", align=True)
        for p in passes.PASSES:
            if p.toggle:
                col.prop(props, p.toggle)


classes = (UNBOUND_PT_fractal, UNBOUND_PT_fractal_slice, UNBOUND_PT_fractal_quality, UNBOUND_PT_render,
           UNBOUND_PT_passes)

# Blender's own panels that make sense for Unbound (output format, camera, world, object
# transform ...) list the engines they appear for; add ours as Cycles does, except panels
# about features Unbound does not have.
_EXCLUDE = {"RENDER_PT_eevee_performance", "RENDER_PT_color_management", "RENDER_PT_simplify",
            "RENDER_PT_freestyle", "VIEWLAYER_PT_layer_passes", "VIEWLAYER_PT_eevee_layer_passes_data",
            "RENDER_PT_gpencil", "DATA_PT_light", "DATA_PT_EEVEE_light"}
_added = []


def _builtin_panels():
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if engines and 'BLENDER_RENDER' in engines and panel.__name__ not in _EXCLUDE:
            yield panel


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    for panel in _builtin_panels():
        if utils.ENGINE_ID not in panel.COMPAT_ENGINES:
            panel.COMPAT_ENGINES.add(utils.ENGINE_ID)
            _added.append(panel)


def unregister():
    for panel in _added:
        panel.COMPAT_ENGINES.discard(utils.ENGINE_ID)
    _added.clear()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
