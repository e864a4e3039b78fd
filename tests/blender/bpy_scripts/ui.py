"""Scripts of test_ui_blender.py: panels registered for Unbound, presets, the Add operator."""
import os

import bpy


def _properties_panels(context_name):
    """Panels of the Properties editor's `context_name` tab that Unbound gets: its own, and
    Blender's whose engine set holds UNBOUND."""
    out = []
    for cls in bpy.types.Panel.__subclasses__():
        if getattr(cls, "bl_space_type", None) != 'PROPERTIES' or getattr(cls, "bl_context", None) != context_name:
            continue
        if "UNBOUND" in getattr(cls, "COMPAT_ENGINES", ()):
            out.append((cls.__name__, cls.bl_label, getattr(cls, "bl_parent_id", "")))
    return sorted(out)


def panels_for_unbound(S, mod):
    scene = S.empty_scene()
    ob = S.add_fractal()
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    scene.world = world
    bg = mod.export.background_node(world)
    bg.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    bg.inputs["Strength"].default_value = 0.5
    S.report(render=_properties_panels("render"), data=_properties_panels("data"),
             world=_properties_panels("world"), object=_properties_panels("object"),
             world_color=list(mod.export.world_color(scene)),
             threads=[mod.export.thread_count(scene)],
             fractal_context=mod.ui.UNBOUND_PT_fractal.bl_context,
             mu_step=ob.unbound.bl_rna.properties["mu"].step,
             add_mu_step=bpy.ops.object.unbound_fractal_add.get_rna_type().properties["mu"].step)


def _read(path):
    with open(path, encoding="utf-8") as f:
        return f.read()


def presets_split_save_apply_remove(S, mod):
    ops = mod.operators
    scene = S.empty_scene(32, 24)
    a = S.add_fractal(mu=(0.1, -0.6, 0.2, 0.05), theta=0.7, kind='QUATERNION_JULIA', max_iterations=33,
                      color=(0.3, 0.2, 0.1))
    scene.unbound.glow_strength = 0.3
    scene.unbound.use_sea = True
    out = {}
    out["save_fractal"] = sorted(bpy.ops.unbound.fractal_preset_add(name="My Fractal"))
    out["save_look"] = sorted(bpy.ops.unbound.look_preset_add(name="My Look"))
    fractal_path = os.path.join(bpy.utils.preset_paths(ops.PRESET_SUBDIR)[-1], "My_Fractal.py")
    look_path = os.path.join(bpy.utils.preset_paths(ops.LOOK_PRESET_SUBDIR)[-1], "My_Look.py")
    out["fractal_text"] = _read(fractal_path)
    out["look_text"] = _read(look_path)
    # A second object and a reset scene: the fractal preset restores the object, not the scene.
    b = S.add_fractal(mu=(-1.0, 0.0, 0.0, 0.0), theta=0.0)
    scene.unbound.glow_strength = 0.0
    scene.unbound.use_sea = False
    out["apply_fractal"] = sorted(bpy.ops.script.execute_preset(filepath=fractal_path,
                                                                menu_idname="UNBOUND_MT_fractal_presets"))
    out["b"] = dict(mu=list(b.unbound.mu), theta=b.unbound.theta, max_iterations=b.unbound.max_iterations,
                    color=list(b.unbound.color))
    out["scene_after_fractal"] = dict(glow=scene.unbound.glow_strength, sea=scene.unbound.use_sea)
    b.unbound.mu = (0.5, 0.5, 0.5, 0.5)
    out["apply_look"] = sorted(bpy.ops.script.execute_preset(filepath=look_path, menu_idname="UNBOUND_MT_look_presets"))
    out["scene_after_look"] = dict(glow=scene.unbound.glow_strength, sea=scene.unbound.use_sea)
    out["b_mu_after_look"] = list(b.unbound.mu)
    # Every bundled fractal preset leaves the scene's shading as it was.
    before = ops.look_preset_text(scene)
    changed = []
    for name, path in ops.preset_files(ops.BUNDLED_PRESETS):
        bpy.ops.script.execute_preset(filepath=path, menu_idname="UNBOUND_MT_fractal_presets")
        if ops.look_preset_text(scene) != before:
            changed.append(name)
    out["bundled_fractal_changed_scene"] = changed
    out["bundled_looks"] = [name for name, _ in ops.preset_files(ops.BUNDLED_LOOK_PRESETS)]
    # Every bundled look changes the scene only.
    ob_text = ops.fractal_preset_text(b)
    touched = []
    for name, path in ops.preset_files(ops.BUNDLED_LOOK_PRESETS):
        bpy.ops.script.execute_preset(filepath=path, menu_idname="UNBOUND_MT_look_presets")
        if ops.fractal_preset_text(b) != ob_text:
            touched.append(name)
    out["bundled_look_changed_object"] = touched
    # Removing: a bundled preset is refused with a warning; the user's own goes.
    bundled_path = ops.preset_files(ops.BUNDLED_PRESETS)[0][1]
    out["remove_bundled"] = sorted(bpy.ops.unbound.fractal_preset_add(name=ops.preset_files(ops.BUNDLED_PRESETS)[0][0],
                                                                      remove_name=True))
    out["bundled_still_there"] = os.path.exists(bundled_path)
    out["remove_own"] = sorted(bpy.ops.unbound.fractal_preset_add(name="My Fractal", remove_name=True))
    out["own_gone"] = not os.path.exists(fractal_path)
    S.report(**out)


def preset_apply_tags_the_depsgraph(S, mod):
    scene = S.empty_scene(32, 24)
    ob = S.add_fractal()
    bpy.context.view_layer.update()
    seen = []

    def record(scene, depsgraph):
        seen.extend(u.id.original.name for u in depsgraph.updates if isinstance(u.id, bpy.types.Object))
    bpy.app.handlers.depsgraph_update_post.append(record)
    size_before = ob.empty_display_size
    path = os.path.join(mod.operators.BUNDLED_PRESETS, "quaternion_mandelbrot.py")
    status = bpy.ops.script.execute_preset(filepath=path, menu_idname="UNBOUND_MT_fractal_presets")
    bpy.context.view_layer.update()
    bpy.app.handlers.depsgraph_update_post.remove(record)
    S.report(status=sorted(status), seen=seen, name=ob.name, size_before=size_before,
             size_after=ob.empty_display_size, expected=mod.properties.display_radius(ob))


def add_operator_keeps_engine_and_rotates(S, mod):
    from mathutils import Euler
    scene = S.empty_scene(32, 24, engine="CYCLES")
    # A script (EXEC): the scene keeps its engine.
    bpy.ops.object.unbound_fractal_add(use_cursor=False, location=(1.0, 2.0, 3.0), rotation=(0.1, 0.2, 0.3))
    ob = bpy.context.object
    # (The Add menu's invoke, which switches the engine, needs a window: gui_ui.py drives it.)
    S.report(exec_engine=scene.render.engine, location=list(ob.location), rotation=list(ob.rotation_euler),
             wanted_rotation=list(Euler((0.1, 0.2, 0.3))))
