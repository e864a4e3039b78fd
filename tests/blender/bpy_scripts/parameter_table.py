"""Scripts of test_parameter_table.py: the add-on's properties against the core's table
(unbound_core.PARAMETERS), and what export.py hands the core."""
import bpy

# Properties that are not core keys, each with where its value goes instead.
ADDON_ONLY = {
    "object": {
        "is_fractal": "marks the empty as a fractal",
        "slice_offset": "slice_basis / slice_origin (export.slice_frame)",
        "slice_rotation": "slice_basis / slice_origin (export.slice_frame)",
        "path_mode": "path (export.c_path)",
        "c_start": "path (export.c_path)",
        "c_end": "path (export.c_path)",
        "path_curve": "path (export.c_path)",
        "ifs_maps": "maps (export.ifs_map_rows)",
        "ifs_active_map": "the map shown for editing",
        "kifs_planes": "kifs_planes (export.object_parameters: normal + offset)",
        "kifs_active_plane": "the plane shown for editing",
        "hybrid_steps": "hybrid_steps (export.object_parameters: formula index, count)",
        "hybrid_active_step": "the entry shown for editing",
        "color_ramp_texture": "color_ramp (export.ramp_table)",
        "material": "use_material and the material_* keys (export.material_description)",
        "show_proxy": "proxy.py: whether Solid shading draws the surface",
        "proxy_resolution": "proxy.py: extract_mesh's resolution for the Solid-shading surface",
    },
    "scene": {
        "use_scene_lights": "lights (export.light_description of the scene's lights)",
        "fog_use_world": "fog_color (the world's colour)",
        "viewport_start_divisor": "the viewport's stride",
        "viewport_samples": "samples, in the viewport",
        "viewport_time_limit": "the viewport's scheduler",
        "use_world_light": "world (world_light.world_map: None when off)",
        "world_resolution": "world (world_light.bake_world: the baked map's width)",
        "world_bake_samples": "world (world_light.bake_world: Cycles samples per texel)",
    },
}


def rna_default(prop):
    if prop.type == 'ENUM':
        return prop.default.lower()
    if getattr(prop, "is_array", False) and prop.array_length > 0:
        return list(prop.default_array)
    return prop.default


def compare(group, sections, addon_only):
    """[(property, problem)] for every property of PropertyGroup `group` that differs from the core's
    row of the same name (in the first of `sections` that has it), or that is neither a core key nor
    listed as add-on only; and the properties compared."""
    import unbound_core as uc
    problems, compared = [], []
    for prop in group.bl_rna.properties:
        name = prop.identifier
        if name in {"rna_type", "name"} or name in addon_only:  # PropertyGroup's own
            continue
        row = next((uc.PARAMETERS[s][name] for s in sections if name in uc.PARAMETERS[s]), None)
        if row is None:
            problems.append((name, "neither a core key nor listed as add-on only"))
            continue
        compared.append(name)
        if prop.type == 'ENUM':
            items = [item.identifier.lower() for item in prop.enum_items]
            if items != list(row["choices"]):
                problems.append((name, "choices %s != %s" % (items, row["choices"])))
        elif prop.type in {'FLOAT', 'INT'}:
            size = prop.array_length if prop.is_array else 0
            shape = list(row["shape"])
            if (shape and shape[-1] != size) or (not shape and size):
                problems.append((name, "size %d != shape %s" % (size, shape)))
            # Blender keeps float limits in float32: compare to its precision.
            for what, mine, core in (("min", prop.hard_min, row["min"]), ("max", prop.hard_max, row["max"])):
                if abs(mine - core) > 1e-6 * max(1.0, abs(core)):
                    problems.append((name, "hard %s %r != %r" % (what, mine, core)))
        default, core_default = rna_default(prop), row["default"]
        if prop.type == 'FLOAT':
            flat = list(core_default) if isinstance(core_default, (tuple, list)) else core_default
            mine = default if isinstance(default, list) else [default]
            theirs = flat if isinstance(flat, list) else [flat]
            if len(mine) != len(theirs) or any(abs(a - b) > 1e-6 * max(1.0, abs(b)) for a, b in zip(mine, theirs)):
                problems.append((name, "default %r != %r" % (default, core_default)))
        elif default != core_default:
            problems.append((name, "default %r != %r" % (default, core_default)))
    return problems, compared


def properties_match_the_core_table(S, mod):
    from bl_ext.user_default.unbound import properties
    problems, compared = compare(properties.UnboundObjectSettings, ["object"], ADDON_ONLY["object"])
    scene_problems, scene_compared = compare(properties.UnboundSceneSettings, ["shading", "render"],
                                             ADDON_ONLY["scene"])
    S.report(problems=problems + scene_problems, compared=compared + scene_compared)


def every_core_key_is_reachable(S, mod):
    """The keys export.py produces, for every kind, light type and setting, against the table."""
    import unbound_core as uc
    from bl_ext.user_default.unbound import export
    scene = S.empty_scene(32, 24)
    S.add_camera(scene)
    texture = bpy.data.textures.new("Ramp", 'BLEND')
    texture.use_color_ramp = True
    object_keys = set()
    for kind in [item[0] for item in mod.properties.FRACTAL_KINDS]:
        bpy.ops.object.unbound_fractal_add(kind=kind)
        if kind in ('MANDELBULB', 'MANDELBOX'):
            bpy.context.object.unbound.julia_mode = True  # julia_c goes to the core in Julia mode too
        ob = bpy.context.object
        ob.unbound.color_mode = 'ORBIT_TRAP'
        ob.unbound.color_ramp_texture = texture
    # A material whose three driven inputs read attributes: the material_* keys.
    material = bpy.data.materials.new("Driven")
    material.use_nodes = True
    tree = material.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    for socket, via, name in (("Base Color", "ShaderNodeValToRGB", "unbound_orbit_trap"),
                              ("Metallic", "ShaderNodeMapRange", "unbound_iterations"),
                              ("Roughness", "ShaderNodeValToRGB", "unbound_distance")):
        attribute, node = tree.nodes.new("ShaderNodeAttribute"), tree.nodes.new(via)
        attribute.attribute_name = name
        tree.links.new(attribute.outputs["Fac"], node.inputs[0])
        tree.links.new(node.outputs[0], bsdf.inputs[socket])
    ob.unbound.material = material
    dg = bpy.context.evaluated_depsgraph_get()
    for params in export.fractal_objects(dg, original=True):  # script changes, untagged
        object_keys |= set(params)
    light_keys = set()
    for kind in ('SUN', 'POINT', 'SPOT', 'AREA'):
        light = bpy.data.lights.new(kind, kind)
        ob = bpy.data.objects.new(kind, light)
        scene.collection.objects.link(ob)
    dg = bpy.context.evaluated_depsgraph_get()
    shading = export.shading_description(dg)
    for light in shading["lights"]:
        light_keys |= set(light)
    camera = set(export.camera_dict(dg, scene.camera.evaluated_get(dg), scene.camera.matrix_world, 32, 24))
    scene.camera.data.type = 'PANO'  # a panoramic camera's keys too
    dg = bpy.context.evaluated_depsgraph_get()
    camera |= set(export.camera_dict(dg, scene.camera.evaluated_get(dg), scene.camera.matrix_world, 32, 24))
    render_keys = set(export.render_options(scene))
    S.report(object=sorted(object_keys), shading=sorted(shading), light=sorted(light_keys), camera=sorted(camera),
             render=sorted(render_keys), table={s: sorted(uc.PARAMETERS[s]) for s in uc.PARAMETERS})


def pass_table_matches_the_core(S, mod):
    """The add-on's pass table (passes.PASSES) against the core's pass list, and the view layer's
    toggles the table makes."""
    import unbound_core as uc
    vl = bpy.context.scene.view_layers[0]
    rows = [dict(name=p.name, native=p.native, channels=p.channels, toggle=p.toggle,
                 toggle_name=vl.unbound.bl_rna.properties[p.toggle].name if p.toggle else None)
            for p in mod.passes.PASSES]
    S.report(rows=rows, core=dict(uc.PASS_CHANNELS))
