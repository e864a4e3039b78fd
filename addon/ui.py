"""Panels: Object tab (fractal parameters), Render tab (engine settings), View Layer tab
(passes). Shown only when Unbound is the render engine."""
import bpy

from . import passes, properties, utils


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
        row = layout.row(align=True)
        row.menu("UNBOUND_MT_fractal_presets", text=bpy.types.UNBOUND_MT_fractal_presets.bl_label)
        row.operator("unbound.fractal_preset_add", text="", icon='ADD')
        row.operator("unbound.fractal_preset_add", text="", icon='REMOVE').remove_active = True
        layout.prop(props, "kind")
        # Section 5: say which estimates are proven not to overstep the set.
        exact = props.kind in properties.EXACT_KINDS
        layout.label(text="Exact distance estimate" if exact else "Empirical estimate: marched with half steps",
                     icon='CHECKMARK' if exact else 'INFO')
        if props.kind == 'QUATERNION_JULIA':
            # Label the quaternion's components as Blender labels Location X, Y, Z: without a subtype
            # a 4-vector shows one "Mu" label over four unlabelled fields.
            col = layout.column(align=True)
            for i, text in enumerate(("Mu 1", "i", "j", "k")):
                col.prop(props, "mu", index=i, text=text)
        elif props.kind == 'JULIA_STACK':
            layout.prop(props, "path_mode")
            if props.path_mode == 'LINE':
                for name in ("c_start", "c_end"):
                    col = layout.column(align=True)
                    label = props.bl_rna.properties[name].name
                    col.prop(props, name, index=0, text=label + " Re")
                    col.prop(props, name, index=1, text="Im")
            else:
                layout.prop(props, "path_curve")
            layout.prop(props, "stack_height")
        elif props.kind == 'CUBIC_LOCUS':
            layout.prop(props, "cubic_component")
            layout.prop(props, "extent")
        elif props.kind == 'IFS':
            row = layout.row()
            row.template_list("UNBOUND_UL_ifs_maps", "", props, "ifs_maps", props, "ifs_active_map", rows=4)
            col = row.column(align=True)
            col.operator("object.unbound_ifs_map_add", icon='ADD', text="")
            col.operator("object.unbound_ifs_map_remove", icon='REMOVE', text="")
            col.separator()
            col.operator_menu_enum("object.unbound_ifs_shape", "shape", icon='DOWNARROW_HLT', text="")
            if 0 <= props.ifs_active_map < len(props.ifs_maps):
                m = props.ifs_maps[props.ifs_active_map]
                layout.column().prop(m, "location")
                layout.column().prop(m, "rotation")
                layout.column().prop(m, "scale")
            layout.prop(props, "ifs_depth")
        if props.kind in properties.SLICED_KINDS:
            layout.prop(props, "theta")
        layout.prop(props, "color")


class UNBOUND_UL_ifs_maps(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        layout.label(text="Map %d" % (index + 1), icon='OBJECT_ORIGIN')
        layout.label(text="%.3g, %.3g, %.3g" % tuple(item.location))


class UNBOUND_PT_fractal_slice(FractalPanel, bpy.types.Panel):
    bl_label = "Slice"
    bl_parent_id = "UNBOUND_PT_fractal"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.object.unbound.kind in properties.SLICED_KINDS

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
        if props.kind != 'IFS':  # the IFS has a depth, not an iteration
            col.prop(props, "max_iterations")
            col.prop(props, "bailout")
        col.prop(props, "threshold_mode")
        col.prop(props, "detail" if props.threshold_mode == 'PIXEL' else "epsilon")
        col = layout.column()
        col.prop(props, "step_factor")
        col.prop(props, "max_step")
        col.prop(props, "max_steps")
        col.prop(props, "bisection_steps")


class UNBOUND_PT_fractal_shading(FractalPanel, bpy.types.Panel):
    bl_label = "Shading"
    bl_parent_id = "UNBOUND_PT_fractal"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.object.unbound
        col = layout.column()
        col.prop(props, "normal_method")
        sub = col.column()
        sub.active = props.normal_method in {'GRADIENT_DISTANCE', 'GRADIENT_POTENTIAL'}
        sub.prop(props, "normal_alpha")
        sub.prop(props, "normal_delta")
        layout.prop(props, "reflectivity")
        col = layout.column()
        col.prop(props, "color_mode")
        if props.color_mode != 'BASE':
            tex = props.color_ramp_texture
            col.prop(props, "color_ramp_texture")
            if tex is None:
                col.operator("object.unbound_color_ramp_add", icon='ADD')
            elif tex.use_color_ramp:
                col.template_color_ramp(tex, "color_ramp", expand=True)
            else:
                col.prop(tex, "use_color_ramp", text="Use the Texture's Ramp")
            col.prop(props, "ramp_scale")
            col.prop(props, "ramp_offset")


class UNBOUND_PT_render(UnboundPanel, bpy.types.Panel):
    bl_label = "Unbound"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.unbound
        layout.prop(settings, "samples")
        layout.prop(settings, "tile_size")
        layout.prop(settings, "simd")
        layout.prop(context.scene.render, "film_transparent")
        layout.operator("scene.unbound_setup_compositing", icon='NODETREE')


class RenderSubPanel(UnboundPanel):
    bl_context = "render"
    bl_parent_id = "UNBOUND_PT_render"


class UNBOUND_PT_render_viewport(RenderSubPanel, bpy.types.Panel):
    bl_label = "Viewport"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.unbound
        layout.prop(s, "viewport_start_divisor")
        layout.prop(s, "viewport_samples", text="Samples")
        layout.prop(s, "viewport_time_limit")


class UNBOUND_PT_render_lighting(RenderSubPanel, bpy.types.Panel):
    bl_label = "Lighting"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.scene.unbound
        layout.prop(s, "axle_light")
        layout.prop(s, "use_scene_lights")
        layout.prop(s, "shadows")
        layout.prop(s, "ambient")


class UNBOUND_PT_render_effects(RenderSubPanel, bpy.types.Panel):
    bl_label = "Effects"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.scene.unbound
        col = layout.column()
        col.prop(s, "ao_strength")
        sub = col.column()
        sub.active = s.ao_strength > 0.0
        sub.prop(s, "ao_distance")
        sub.prop(s, "ao_samples")
        layout.prop(s, "reflection_depth")
        col = layout.column()
        col.prop(s, "fog_density")
        sub = col.column()
        sub.active = s.fog_density > 0.0
        sub.prop(s, "fog_use_world")
        if not s.fog_use_world:
            sub.prop(s, "fog_color")
        col = layout.column()
        col.prop(s, "glow_strength")
        sub = col.column()
        sub.active = s.glow_strength > 0.0
        sub.prop(s, "glow_color")


class UNBOUND_PT_render_sea(RenderSubPanel, bpy.types.Panel):
    bl_label = "Sea"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.scene.unbound, "use_sea", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.scene.unbound
        layout.active = s.use_sea
        layout.prop(s, "sea_height")
        layout.prop(s, "sea_wavelength")
        layout.prop(s, "sea_amplitude")
        layout.prop(s, "sea_color")
        layout.prop(s, "sea_reflectivity")


class UNBOUND_PT_light(UnboundPanel, bpy.types.Panel):
    """The light settings Unbound reads (Cycles' units), in place of Blender's engine-specific panels"""
    bl_label = "Light"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.light is not None

    def draw(self, context):
        layout = self.layout
        light = context.light
        layout.row().prop(light, "type", expand=True)
        layout.use_property_split = True
        col = layout.column()
        col.prop(light, "color")
        col.prop(light, "energy")
        col.prop(light, "use_shadow", text="Cast Shadow")
        col.separator()
        if light.type in {'POINT', 'SPOT'}:
            col.prop(light, "shadow_soft_size", text="Radius")
            if hasattr(light, "use_soft_falloff"):
                col.prop(light, "use_soft_falloff")
            if light.type == 'SPOT':
                col.separator()
                col.prop(light, "spot_size", text="Spot Size")
                col.prop(light, "spot_blend", text="Blend")
        elif light.type == 'SUN':
            col.prop(light, "angle")
        elif light.type == 'AREA':
            col.prop(light, "shape")
            sub = col.column(align=True)
            if light.shape in {'SQUARE', 'DISK'}:
                sub.prop(light, "size")
            else:
                sub.prop(light, "size", text="Size X")
                sub.prop(light, "size_y", text="Y")


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


classes = (UNBOUND_UL_ifs_maps, UNBOUND_PT_fractal, UNBOUND_PT_fractal_slice, UNBOUND_PT_fractal_quality, UNBOUND_PT_fractal_shading,
           UNBOUND_PT_render, UNBOUND_PT_render_viewport, UNBOUND_PT_render_lighting, UNBOUND_PT_render_effects, UNBOUND_PT_render_sea,
           UNBOUND_PT_light, UNBOUND_PT_passes)

# Blender's own panels that make sense for Unbound (output format, camera, world, object
# transform ...) list the engines they appear for; add ours as Cycles does, except panels
# about features Unbound does not have.
_EXCLUDE = {"RENDER_PT_eevee_performance", "RENDER_PT_color_management", "RENDER_PT_simplify",
            "RENDER_PT_freestyle", "VIEWLAYER_PT_layer_passes", "VIEWLAYER_PT_eevee_layer_passes_data",
            "RENDER_PT_gpencil",
            # UNBOUND_PT_light draws what Unbound reads of a light; DATA_PT_spot hangs under an
            # EEVEE panel that never shows for Unbound. Light probes are not used.
            "DATA_PT_light", "DATA_PT_spot", "DATA_PT_lightprobe", "DATA_PT_lightprobe_visibility",
            "DATA_PT_lightprobe_parallax", "DATA_PT_lightprobe_display", "DATA_PT_context_lightprobe"}
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
