"""Scripts of test_volume_blender.py (run inside bpy by conftest.run_bpy: see bpy_scripts/__init__.py)."""
import os
import pathlib
import time

import bpy
import numpy as np


def _tmp():
    return pathlib.Path(os.environ["UNBOUND_TEST_TMP"])


def _unit_ball(S, width=64, height=48, **props):
    """An empty scene with the unit ball (mu = 0: the filled Julia set of z^2 is |q| <= 1), its
    surface the render's (fixed threshold), moved and scaled so the object transform counts."""
    scene = S.empty_scene(width, height)
    fractal = S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, threshold_mode='FIXED', epsilon=1e-4, **props)
    return scene, fractal


def _radii(volume_object, grid_name, threshold):
    """World-space distances from the volume object's origin of the vertices Blender's Volume to
    Mesh modifier makes from `volume_object`'s grid at `threshold` (the grid's own voxels)."""
    holder = bpy.data.objects.new("Back", bpy.data.meshes.new("Back"))
    bpy.context.scene.collection.objects.link(holder)
    holder.matrix_world = volume_object.matrix_world
    mod = holder.modifiers.new("v2m", 'VOLUME_TO_MESH')
    mod.object, mod.grid_name, mod.threshold, mod.resolution_mode, mod.adaptivity = \
        volume_object, grid_name, threshold, 'GRID', 0.0
    evaluated = holder.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = evaluated.to_mesh()
    v = np.empty(3 * len(me.vertices), np.float64)
    me.vertices.foreach_get("co", v)
    evaluated.to_mesh_clear()
    m = np.array(holder.matrix_world)
    world = v.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    bpy.data.objects.remove(holder)
    return np.linalg.norm(world - m[:3, 3], axis=1)


def convert_ball(S, mod, resolution, grid='SDF', scale=1.0, location=(0.0, 0.0, 0.0), save_blend=False):
    """Convert to Volume on the unit ball: the new object, its file, its grid, and the surface Blender's
    Volume to Mesh finds in the file (radii in the world, over the object's scale)."""
    scene, fractal = _unit_ball(S)
    fractal.location = location
    fractal.scale = (scale,) * 3
    if save_blend:
        bpy.ops.wm.save_as_mainfile(filepath=str(_tmp() / "scene.blend"))
    start = time.perf_counter()
    result = bpy.ops.object.unbound_convert_to_volume(resolution=resolution, grid=grid)
    seconds = time.perf_counter() - start
    new = bpy.context.view_layer.objects.active
    out = dict(result=sorted(result), seconds=seconds, active_type=new.type, active_name=new.name,
               selected=new.select_get(), fractal_selected=fractal.select_get(), fractal_kept=fractal.name in bpy.data.objects,
               matrix_equal=[list(r) for r in new.matrix_world] == [list(r) for r in fractal.matrix_world],
               filepath=new.data.filepath, abspath=bpy.path.abspath(new.data.filepath),
               objects=sorted(o.name for o in bpy.data.objects), meshes=len(bpy.data.meshes),
               node_groups=len(bpy.data.node_groups), volumes=len(bpy.data.volumes),
               materials=[m.name for m in new.data.materials])
    path = pathlib.Path(out["abspath"])
    out["file_exists"] = path.is_file()
    out["file_bytes"] = path.stat().st_size if path.is_file() else 0
    out["level_set_class"] = b"level set" in path.read_bytes() if path.is_file() else False
    grids = new.data.grids
    grids.load()
    out["grids"] = [(g.name, g.data_type) for g in grids]
    out["grid_error"] = grids.error_message
    out["voxel_size"] = [grids[0].matrix_object[i][i] for i in range(3)] if len(grids) else []
    name = "sdf" if grid == 'SDF' else "density"
    radii = _radii(new, name, 0.0 if grid == 'SDF' else 1e-4)
    out["radii"] = [float(radii.min()), float(radii.max()), len(radii)]
    S.report(**out)


def density_radii(S, mod, resolution, thresholds):
    """The density grid of the unit ball read back by Volume to Mesh at several thresholds: the
    radii (min, max) at each, and the voxel size."""
    scene, fractal = _unit_ball(S)
    bpy.ops.wm.save_as_mainfile(filepath=str(_tmp() / "scene.blend"))
    assert bpy.ops.object.unbound_convert_to_volume(resolution=resolution, grid='DENSITY') == {'FINISHED'}
    new = bpy.context.view_layer.objects.active
    new.data.grids.load()
    out = {"voxel_size": new.data.grids[0].matrix_object[0][0], "radii": []}
    for t in thresholds:
        r = _radii(new, "density", t)
        out["radii"].append([float(r.min()), float(r.max())])
    S.report(**out)


def render_ball(S, mod, resolution, grid, width, height, engine='CYCLES', samples=16):
    """The unit ball converted (saved .blend, so the file sits beside it), the fractal hidden, and
    the volume rendered by `engine` from a camera on the -Y axis, transparent film: alpha saved."""
    scene, fractal = _unit_ball(S, width, height)
    scene.render.film_transparent = True
    S.add_camera(scene, location=(0.0, -4.0, 0.0), lens=50.0, sensor_fit='HORIZONTAL', sensor_width=36.0)
    bpy.ops.wm.save_as_mainfile(filepath=str(_tmp() / "scene.blend"))
    assert bpy.ops.object.unbound_convert_to_volume(resolution=resolution, grid=grid) == {'FINISHED'}
    fractal.hide_render = True
    if engine == 'EEVEE':  # EEVEE Next is BLENDER_EEVEE_NEXT in 4.2-4.5, BLENDER_EEVEE again from 5.0
        engine = 'BLENDER_EEVEE_NEXT' if bpy.app.version < (5, 0, 0) else 'BLENDER_EEVEE'
    scene.render.engine = engine
    if engine == 'CYCLES':
        c = scene.cycles
        c.device = 'CPU'
        c.samples = samples
        c.use_adaptive_sampling = False
        c.use_denoising = False
        c.filter_width = 0.01
        c.max_bounces = 0
    else:
        scene.eevee.taa_render_samples = samples
    start = time.perf_counter()
    image = S.render_to_exr(scene, "volume.exr")
    seconds = time.perf_counter() - start
    np.save(_tmp() / "alpha.npy", image["ViewLayer.Combined.A"])
    S.report(seconds=seconds)


def _leftovers():
    """Datablocks a conversion must not leave behind, by kind."""
    return dict(objects=sorted(o.name for o in bpy.data.objects), meshes=len(bpy.data.meshes),
                node_groups=len(bpy.data.node_groups), volumes=len(bpy.data.volumes))


def refusals(S, mod, memory_limit_case):
    """Each bad case: the operator's result, the error Blender raised from its report, what is left."""
    tmp = _tmp()
    out = {}
    scene, fractal = _unit_ball(S)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp / "scene.blend"))
    before = _leftovers()

    def attempt(name, **options):
        try:
            result = sorted(bpy.ops.object.unbound_convert_to_volume(**options))
            message = ""
        except RuntimeError as exc:  # an ERROR report becomes the exception in background mode
            result, message = ["RuntimeError"], str(exc).strip().splitlines()[0]
        out[name] = dict(result=result, message=message, left=_leftovers() == before,
                         vdb=sorted(p.name for p in tmp.rglob("*.vdb")))

    if memory_limit_case:  # UNBOUND_MEMORY_LIMIT is set by the caller
        attempt("memory", resolution=512)
    else:
        (tmp / "a_file").write_text("not a folder")
        attempt("directory_is_a_file", resolution=32, directory=str(tmp / "a_file"))
        fractal.unbound.mu = (2.0, 0.0, 0.0, 0.0)  # the Julia set of z^2 + 2: dust, no surface to find
        attempt("no_surface", resolution=32)
        fractal.unbound.mu = (0.0, 0.0, 0.0, 0.0)
        bpy.context.view_layer.objects.active = None
        attempt("no_active_object", resolution=32)
        camera = S.add_camera(scene)
        bpy.context.view_layer.objects.active = camera
        before = _leftovers()
        attempt("not_a_fractal", resolution=32)
    S.report(**out)


def unsaved(S, mod):
    """An unsaved .blend: where the file goes and what the operator says. (Undo is checked in the
    real GUI, real_blender/gui_volume.py: background bpy has no undo stack to undo with.)"""
    scene, fractal = _unit_ball(S)
    result = bpy.ops.object.unbound_convert_to_volume(resolution=32)
    new = bpy.context.view_layer.objects.active
    S.report(result=sorted(result), filepath=new.data.filepath, tempdir=bpy.app.tempdir,
             exists=os.path.isfile(new.data.filepath))


def frame_range(S, mod, resolution):
    """Frame Range on a fractal keyframed from the unit ball (frame 1) to mu = -0.5 (frame 3): one
    file per frame, one Volume object playing them as a sequence."""
    scene, fractal = _unit_ball(S)
    scene.frame_start, scene.frame_end = 1, 3
    bpy.ops.wm.save_as_mainfile(filepath=str(_tmp() / "scene.blend"))
    for frame, mu in ((1, 0.0), (3, -0.5)):
        fractal.unbound.mu = (mu, 0.0, 0.0, 0.0)
        fractal.keyframe_insert('unbound.mu', frame=frame)
    scene.frame_set(2)
    result = bpy.ops.object.unbound_convert_to_volume(resolution=resolution, use_frame_range=True)
    new = bpy.context.view_layer.objects.active
    volume = new.data
    out = dict(result=sorted(result), frame_after=scene.frame_current, filepath=volume.filepath,
               is_sequence=volume.is_sequence, objects=_leftovers()["objects"],
               files=sorted(p.name for p in _tmp().glob("*.vdb")), frames={})
    for frame in (1, 2, 3, 4):
        scene.frame_set(frame)
        grids = new.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.grids
        out["frames"][frame] = dict(file=os.path.basename(grids.frame_filepath) if grids.frame_filepath else "",
                                    grids=len(grids))
    scene.frame_set(1)
    r = _radii(new, "sdf", 0.0)
    out["radii_frame1"] = [float(r.min()), float(r.max())]
    S.report(**out)
