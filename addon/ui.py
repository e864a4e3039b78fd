"""Panels: Object Data tab of a fractal empty (its parameters, where Blender shows what a light or
a camera is), Render tab (engine settings, performance), World tab (the colour Unbound reads),
Light tab, View Layer tab (passes). Shown only when Unbound is the render engine; under another
engine a fractal's tabs say how to see it."""
import math

import bpy

from . import export, operators, passes, properties, utils


def draw_item_list(layout, props, items, active, ui_list, op_prefix, rows, shape_op=None):
    """A collection's list with add/remove buttons (operators op_prefix + "_add"/"_remove") and
    optionally a menu of shapes to load; returns the active item, or None."""
    row = layout.row()
    row.template_list(ui_list, "", props, items, props, active, rows=rows)
    col = row.column(align=True)
    col.operator(op_prefix + "_add", icon='ADD', text="")
    col.operator(op_prefix + "_remove", icon='REMOVE', text="")
    if shape_op:
        col.separator()
        col.operator_menu_enum(shape_op, "shape", icon='DOWNARROW_HLT', text="")
    collection, index = getattr(props, items), getattr(props, active)
    return collection[index] if 0 <= index < len(collection) else None


class UnboundPanel:
    COMPAT_ENGINES = {utils.ENGINE_ID}
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class FractalPanel(UnboundPanel):
    bl_context = "data"   # the empty's Object Data tab

    @classmethod
    def poll(cls, context):
        return super().poll(context) and utils.is_fractal(context.object)


class UNBOUND_PT_fractal(FractalPanel, bpy.types.Panel):
    bl_label = "Unbound Fractal"

    def draw_header_preset(self, context):
        operators.UNBOUND_PT_fractal_presets.draw_panel_header(self.layout)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = True
        props = context.object.unbound
        layout.prop(props, "kind")
        if context.scene.camera is not None:
            layout.operator("object.unbound_frame_camera", icon='VIEW_CAMERA')
        # Section 5: say which estimates are proven not to overstep the set.
        exact = props.kind in properties.EXACT_KINDS
        layout.label(text="Exact distance estimate" if exact else "Empirical estimate: marched with half steps",
                     icon='CHECKMARK' if exact else 'INFO')
        if props.kind == 'QUATERNION_JULIA':
            # Label the quaternion's components as Blender labels Location X, Y, Z: without a subtype
            # a 4-vector shows one "Mu" label over four unlabelled fields.
            col = layout.column(align=True)
            for i, text in enumerate(operators.MU_LABELS):
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
            m = draw_item_list(layout, props, "ifs_maps", "ifs_active_map", "UNBOUND_UL_ifs_maps",
                               "object.unbound_ifs_map", 4, "object.unbound_ifs_shape")
            if m is not None:
                layout.column().prop(m, "location")
                layout.column().prop(m, "rotation")
                layout.column().prop(m, "scale")
            layout.prop(props, "ifs_depth")
        elif props.kind in {'KIFS', 'HYBRID'}:
            if props.kind == 'HYBRID':
                e = draw_item_list(layout, props, "hybrid_steps", "hybrid_active_step", "UNBOUND_UL_hybrid_steps",
                                   "object.unbound_hybrid_step", 3)
                if e is not None:
                    layout.prop(e, "formula")
                    layout.prop(e, "count")
                box = layout.box()
                box.label(text="Mandelbulb")
                box.prop(props, "power")
                box = layout.box()
                box.label(text="Mandelbox")
                for name in ("box_scale", "box_fold", "min_radius", "fixed_radius"):
                    box.prop(props, name)
                layout.prop(props, "julia_mode")
                if props.julia_mode:
                    layout.column().prop(props, "julia_c")
            box = layout.box() if props.kind == 'HYBRID' else layout
            if props.kind == 'HYBRID':
                box.label(text="KIFS")
            p = draw_item_list(box, props, "kifs_planes", "kifs_active_plane", "UNBOUND_UL_kifs_planes",
                               "object.unbound_kifs_plane", 4, "object.unbound_kifs_shape")
            if p is not None:
                box.column().prop(p, "normal")
                box.prop(p, "offset")
            box.prop(props, "kifs_scale")
            box.column().prop(props, "kifs_offset")
            box.column().prop(props, "kifs_rotation")
            if props.kind == 'KIFS':
                box.prop(props, "kifs_shape")
                box.prop(props, "kifs_size")
        elif props.kind in {'MANDELBULB', 'MANDELBOX'}:
            if props.kind == 'MANDELBULB':
                layout.prop(props, "power")
            else:
                for name in ("box_scale", "box_fold", "min_radius", "fixed_radius"):
                    layout.prop(props, name)
            layout.prop(props, "julia_mode")
            if props.julia_mode:
                layout.column().prop(props, "julia_c")
        if props.kind in properties.SLICED_KINDS:
            layout.prop(props, "theta")
        layout.prop(props, "color")


class FractalHint:
    """Under another render engine a fractal is a bare empty: one line saying why, and a button."""
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_label = "Unbound Fractal"
    bl_options = {'HIDE_HEADER'}

    @classmethod
    def poll(cls, context):
        return context.engine != utils.ENGINE_ID and utils.is_fractal(context.object)

    def draw(self, context):
        row = self.layout.row()
        row.label(text="An Unbound fractal: only the Unbound engine draws it", icon='INFO')
        row.operator("scene.unbound_use_engine", text="Use Unbound")


class UNBOUND_PT_fractal_hint(FractalHint, bpy.types.Panel):
    bl_context = "data"


class UNBOUND_PT_fractal_hint_object(FractalHint, bpy.types.Panel):
    bl_context = "object"


class UNBOUND_UL_ifs_maps(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        layout.label(text="Map %d" % (index + 1), icon='OBJECT_ORIGIN')
        layout.label(text="%.3g, %.3g, %.3g" % tuple(item.location))


class UNBOUND_UL_kifs_planes(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        layout.label(text="Plane %d" % (index + 1), icon='MOD_MIRROR')
        layout.label(text="%.3g, %.3g, %.3g | %.3g" % (tuple(item.normal) + (item.offset,)))


class UNBOUND_UL_hybrid_steps(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        layout.label(text=item.bl_rna.properties["formula"].enum_items[item.formula].name)
        layout.label(text="x %d" % item.count)


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


class UNBOUND_PT_fractal_zoom(FractalPanel, bpy.types.Panel):
    bl_label = "Deep Zoom"
    bl_parent_id = "UNBOUND_PT_fractal"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.object.unbound.kind in operators.ZOOM_KINDS

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.object.unbound
        layout.prop(props, "zoom")
        layout.prop(props, "zoom_anchor")
        layout.operator("object.unbound_pick_zoom_anchor", icon='EYEDROPPER')
        if props.kind in operators.FORMULA_ZOOM_KINDS:
            self.draw_formula_limit(context.object)
        elif props.zoom > 0.0:
            # The core's rule (native/src/zoom.h): what a frame at this zoom iterates.
            iterations = min(props.max_iterations + math.ceil(7.0 * props.zoom), 1024)
            layout.label(text="Iterations at this zoom: %d" % iterations, icon='INFO')

    def draw_formula_limit(self, ob):
        """The formula kinds zoom in double only, to the core's ZOOM_FORMULA_MAX; past it the render
        stops with the core's message. The iterations at this zoom are the core's (describe())."""
        layout, props = self.layout, ob.unbound
        try:
            core = utils.native()
        except ImportError:
            return
        limit = core.ZOOM_FORMULA_MAX
        try:
            iterations = core.describe(export.object_parameters(ob, with_ramp=False))["max_iterations"]
        except (ValueError, TypeError, export.RenderError):
            iterations = None
        if props.zoom > limit:
            layout.label(text="Past this kind's deepest zoom, %g: the render stops" % limit, icon='ERROR')
            layout.label(text="(double precision; only the quaternion kinds go deeper)")
            return
        layout.label(text="Deepest zoom for this kind: %g (double precision)" % limit, icon='INFO')
        if props.zoom > 0.0 and iterations is not None:
            layout.label(text="Iterations at this zoom: %d" % iterations, icon='INFO')


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
        layout.template_ID(props, "material", new="material.new")
        col = layout.column()
        col.active = props.material is None  # a material's Base Color replaces the colouring
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

    def draw_header_preset(self, context):
        operators.UNBOUND_PT_look_presets.draw_panel_header(self.layout)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.unbound
        layout.prop(settings, "samples")
        layout.prop(context.scene.render, "film_transparent")
        layout.operator("scene.unbound_setup_compositing", icon='NODETREE')
        layout.operator("scene.unbound_composite_with_cycles", icon='SCENE_DATA')


class UNBOUND_PT_motion_blur(UnboundPanel, bpy.types.Panel):
    """Blender's motion blur settings that Unbound reads (motion_blur.py), laid out as Cycles does"""
    bl_label = "Motion Blur"
    bl_context = "render"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.scene.render, "use_motion_blur", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        rd = context.scene.render
        layout.active = rd.use_motion_blur
        col = layout.column()
        col.prop(rd, "motion_blur_position", text="Position")
        col.prop(rd, "motion_blur_shutter")
        if context.scene.unbound.samples < 2:
            col.label(text="Blur needs 2 or more samples", icon='INFO')


class UNBOUND_PT_motion_blur_curve(UnboundPanel, bpy.types.Panel):
    bl_label = "Shutter Curve"
    bl_context = "render"
    bl_parent_id = "UNBOUND_PT_motion_blur"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = self.layout
        rd = context.scene.render
        layout.active = rd.use_motion_blur
        layout.template_curve_mapping(rd, "motion_blur_shutter_curve")
        row = layout.row(align=True)
        for shape, icon in (('SMOOTH', 'SMOOTHCURVE'), ('ROUND', 'SPHERECURVE'), ('ROOT', 'ROOTCURVE'),
                            ('SHARP', 'SHARPCURVE'), ('LINE', 'LINCURVE'), ('MAX', 'NOCURVE')):
            row.operator("render.shutter_curve_preset", icon=icon, text="").shape = shape


class UNBOUND_PT_performance(UnboundPanel, bpy.types.Panel):
    """Blender's Performance settings as Cycles lays them out: threads, then Unbound's tiles and kernel"""
    bl_label = "Performance"
    bl_context = "render"

    def draw(self, context):
        pass


class UNBOUND_PT_performance_threads(UnboundPanel, bpy.types.Panel):
    bl_label = "Threads"
    bl_context = "render"
    bl_parent_id = "UNBOUND_PT_performance"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        rd = context.scene.render
        col = layout.column()
        col.prop(rd, "threads_mode")
        sub = col.column(align=True)
        sub.enabled = rd.threads_mode == 'FIXED'
        sub.prop(rd, "threads")


class UNBOUND_PT_performance_kernel(UnboundPanel, bpy.types.Panel):
    bl_label = "Kernel"
    bl_context = "render"
    bl_parent_id = "UNBOUND_PT_performance"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.unbound
        layout.prop(settings, "tile_size")
        layout.prop(settings, "simd")


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
        row = layout.row()
        row.active = not s.use_gi  # global illumination has no ambient term
        row.prop(s, "ambient")
        col = layout.column()
        col.prop(s, "use_world_light")
        sub = col.column()
        sub.active = s.use_world_light
        sub.prop(s, "world_samples")
        sub.prop(s, "world_resolution")
        sub.prop(s, "world_bake_samples")


class UNBOUND_PT_render_light_paths(RenderSubPanel, bpy.types.Panel):
    """Cycles' Light Paths panel: global illumination and its bounce limits."""
    bl_label = "Light Paths"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.scene.unbound, "use_gi", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.scene.unbound
        col = layout.column(heading="Max Bounces", align=True)
        col.active = s.use_gi
        col.prop(s, "max_bounces")
        col.prop(s, "diffuse_bounces")
        col.prop(s, "glossy_bounces")


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
        row = layout.row()
        row.active = not s.use_gi  # with global illumination Light Paths > Glossy limits mirrors
        row.prop(s, "reflection_depth")
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


class UNBOUND_PT_camera_panorama(UnboundPanel, bpy.types.Panel):
    """A panoramic camera's type and settings (Blender's Lens panel shows them for Cycles only)"""
    bl_label = "Panorama"
    bl_context = "data"
    bl_parent_id = "DATA_PT_lens"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.camera is not None and context.camera.type == 'PANO'

    def draw(self, context):
        from . import export
        layout = self.layout
        layout.use_property_split = True
        cam = context.camera
        col = layout.column()
        col.prop(cam, "panorama_type")
        if cam.panorama_type not in export.PANORAMA_TYPES:
            col.label(text="Unbound does not render this panorama type", icon='ERROR')
        elif cam.panorama_type == 'FISHEYE_EQUIDISTANT':
            col.prop(cam, "fisheye_fov")
        elif cam.panorama_type == 'FISHEYE_EQUISOLID':
            col.prop(cam, "fisheye_lens", text="Lens")
            col.prop(cam, "fisheye_fov")
        elif cam.panorama_type == 'EQUIRECTANGULAR':
            sub = col.column(align=True)
            sub.prop(cam, "latitude_min", text="Latitude Min")
            sub.prop(cam, "latitude_max", text="Max")
            sub = col.column(align=True)
            sub.prop(cam, "longitude_min", text="Longitude Min")
            sub.prop(cam, "longitude_max", text="Max")


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


class UNBOUND_PT_world(UnboundPanel, bpy.types.Panel):
    """The world's colour as Unbound reads it: the Background node's Color times Strength when the
    world uses nodes, else the world's own colour (export.world_color)"""
    bl_label = "Surface"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.world is not None

    def draw(self, context):
        layout = self.layout
        world = context.world
        layout.prop(world, "use_nodes", icon='NODETREE')
        layout.separator()
        layout.use_property_split = True
        bg = export.background_node(world)
        if bg is None:
            layout.prop(world, "color")
            if world.use_nodes:
                layout.label(text="No Background node feeds the World Output: Unbound uses this colour", icon='INFO')
            return
        col = layout.column()
        for name in ("Color", "Strength"):
            socket = bg.inputs[name]
            row = col.row()
            if socket.is_linked:
                row.label(text="%s: linked (Unbound reads only an unlinked value)" % name, icon='INFO')
            else:
                row.prop(socket, "default_value", text=name)


class UNBOUND_PT_passes(UnboundPanel, bpy.types.Panel):
    bl_label = "Unbound Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        props = context.view_layer.unbound
        col = layout.column(heading="Include", align=True)
        for toggle, _label, _description in passes.toggles():
            col.prop(props, toggle)


classes = (UNBOUND_UL_ifs_maps, UNBOUND_UL_kifs_planes, UNBOUND_UL_hybrid_steps, UNBOUND_PT_fractal_hint, UNBOUND_PT_fractal_hint_object, UNBOUND_PT_fractal,
           UNBOUND_PT_fractal_slice, UNBOUND_PT_fractal_zoom, UNBOUND_PT_fractal_quality, UNBOUND_PT_fractal_shading,
           UNBOUND_PT_render, UNBOUND_PT_render_viewport, UNBOUND_PT_render_lighting,
           UNBOUND_PT_render_light_paths, UNBOUND_PT_render_effects,
           UNBOUND_PT_render_sea, UNBOUND_PT_motion_blur, UNBOUND_PT_motion_blur_curve, UNBOUND_PT_performance,
           UNBOUND_PT_performance_threads, UNBOUND_PT_performance_kernel,
           UNBOUND_PT_world, UNBOUND_PT_camera_panorama, UNBOUND_PT_light, UNBOUND_PT_passes)

# Blender's own panels that make sense for Unbound (output format, colour management, camera, world,
# object transform ...) list the engines they appear for; add ours as Cycles does, except panels
# about features Unbound does not have.
_EXCLUDE = {"RENDER_PT_eevee_performance", "RENDER_PT_simplify",
            "RENDER_PT_freestyle", "VIEWLAYER_PT_layer_passes", "VIEWLAYER_PT_eevee_layer_passes_data",
            "RENDER_PT_gpencil",
            # UNBOUND_PT_light draws what Unbound reads of a light; DATA_PT_spot hangs under an
            # EEVEE panel that never shows for Unbound. Light probes are not used.
            "DATA_PT_light", "DATA_PT_spot", "DATA_PT_lightprobe", "DATA_PT_lightprobe_visibility",
            "DATA_PT_lightprobe_parallax", "DATA_PT_lightprobe_display", "DATA_PT_context_lightprobe"}
# Blender's panels Unbound reads although they do not list BLENDER_RENDER (Cycles adds itself too):
# the camera's depth of field.
_INCLUDE = {"DATA_PT_camera_dof", "DATA_PT_camera_dof_aperture"}
_added = []


def _builtin_panels():
    """Blender's panels for BLENDER_RENDER and the included ones, less the excluded ones and any
    panel that shares its engine set with an excluded one: the node editor's copies of properties
    panels (space_node.py's node_panel, e.g. NODE_DATA_PT_light) hold the very same set object, so
    adding Unbound to the copy would show the excluded original too (two "Light" panels)."""
    panels = bpy.types.Panel.__subclasses__()
    excluded_sets = {id(p.COMPAT_ENGINES) for p in panels
                     if p.__name__ in _EXCLUDE and isinstance(getattr(p, "COMPAT_ENGINES", None), set)}
    for panel in panels:
        engines = getattr(panel, "COMPAT_ENGINES", None)
        wanted = 'BLENDER_RENDER' in engines or panel.__name__ in _INCLUDE if engines else False
        if wanted and panel.__name__ not in _EXCLUDE and id(engines) not in excluded_sets:
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
