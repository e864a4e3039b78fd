"""Final renders: Blender's depsgraph -> the native core -> render passes.

The RenderEngine class (in __init__.py) only forwards its callbacks here."""
import math
import re
import time

import numpy as np
from mathutils import Vector

from . import passes, properties, utils


# Single precision carries 24 bits: a position is resolved to about 6e-8 of its size. Measured
# (tests/native/test_precision.py): hit depths quantise into steps once one pixel covers less
# than 1e-6 of the fractal's bounding radius, and shading shows facets below about 3e-7.
PRECISION_LIMIT = 1e-6

# Counters of the most recent render in this process (rays, steps, iterations, seconds, threads,
# simd, cancelled), for scripts and tests.
LAST_STATS = {}


class RenderError(Exception):
    """A problem the user can fix; reported in Blender's UI, never as a traceback."""


def camera_description(engine, depsgraph, width, height):
    """The native camera dict: Blender's own camera matrix and projection matrix, so focal length,
    sensor size and fit, shift, clipping, orthographic scale and pixel aspect all come for free."""
    cam_ob = evaluated_camera(engine.camera_override or depsgraph.scene.camera, depsgraph)
    return camera_dict(depsgraph, cam_ob, engine.camera_model_matrix(cam_ob, use_spherical_stereo=False),
                       width, height)


def evaluated_camera(cam_ob, depsgraph):
    """The evaluated camera object to render through, or a RenderError a user can act on."""
    if cam_ob is None:
        raise RenderError("The scene has no camera: add one or set Scene > Camera")
    cam_ob = cam_ob.evaluated_get(depsgraph)
    if cam_ob.type != 'CAMERA':
        raise RenderError("The scene camera '%s' is not a camera object" % cam_ob.name)
    if cam_ob.data.type not in {'PERSP', 'ORTHO'}:
        raise RenderError("the camera '%s' is %s; only perspective and orthographic cameras are supported"
                          % (cam_ob.name, {'PANO': "panoramic"}.get(cam_ob.data.type, cam_ob.data.type.lower())))
    return cam_ob


def camera_dict(depsgraph, cam_ob, matrix, width, height):
    """The native camera dict of camera object `cam_ob` (evaluated) placed at `matrix`, for an
    image of width x height pixels."""
    r = depsgraph.scene.render
    projection = cam_ob.calc_matrix_camera(depsgraph, x=width, y=height, scale_x=r.pixel_aspect_x,
                                           scale_y=r.pixel_aspect_y)
    return native_camera(matrix, projection, cam_ob.data.type == 'PERSP', cam_ob.data.clip_start,
                         cam_ob.data.clip_end, width, height)


def native_camera(matrix, projection, perspective, near, far, width, height):
    """The native camera dict of a camera-to-world matrix and Blender's projection matrix."""
    if not far > near:
        raise RenderError("The clip start (%g) must be less than the clip end (%g)" % (near, far))
    projection = [list(row) for row in projection]
    # The depth row again in double precision, from the clip distances it was made of (Blender's
    # perspective_m4 / orthographic_m4): in the float32 matrix a clip start of 1e-6 with a clip end
    # of 100 rounds -(f + n) / (f - n) to -1, which puts the clip end at infinity.
    if perspective:
        projection[2][2:] = [-(far + near) / (far - near), -2.0 * near * far / (far - near)]
    else:
        projection[2][2:] = [-2.0 / (far - near), -(far + near) / (far - near)]
    return dict(matrix=[list(row) for row in matrix], projection=projection, width=width, height=height)


def scene_instances(depsgraph, accept, describe):
    """describe(object, matrix_world) of every visible instance (instances included) of the objects
    `accept` takes, None results dropped, in a stable order (name, instance flag, random id): the
    same on every machine."""
    found = []
    for inst in depsgraph.object_instances:
        ob = inst.object
        if accept(ob):
            desc = describe(ob, inst.matrix_world)
            if desc is not None:
                found.append(((ob.name_full, inst.is_instance, inst.random_id), desc))
    found.sort(key=lambda item: item[0])
    return [desc for _, desc in found]


def fractal_instances(depsgraph, original=False):
    """(native dict, world bounding radius) of every visible fractal object (instances included),
    in a stable order. The parameters (colour ramp included) are derived and checked by the core
    once per object, the matrix per instance. original: read the parameters from the original
    objects, not the evaluated copies, which a script's change does not reach without a depsgraph
    tag (the viewport's depsgraph is the active one, where keyframes and drivers write the
    originals too)."""
    checked = {}

    def describe(ob, matrix):
        key = ob.name_full  # a linked object may share its name with a local one
        if key not in checked:
            try:
                params = properties.native_parameters((ob.original if original else ob).unbound, depsgraph)
                # The core checks every value (NaN from a keyframe, a slice that misses the set):
                # ask it here, per object, so that the message names the object, not its index.
                checked[key] = params, utils.native().describe(params)["bound_radius"]
            except ValueError as exc:
                message = re.sub(r"^object[.:]\s*", "", str(exc))
                if "finite" in message:  # NaN or infinity: animation is where these come from
                    message += " (check its keyframes and drivers)"
                raise RenderError("fractal '%s': %s" % (ob.name, message)) from None
        params, radius = checked[key]
        return dict(params, matrix=[list(row) for row in matrix]), radius * max(map(abs, matrix.to_scale()))

    return scene_instances(depsgraph, utils.is_fractal, describe)


def fractal_objects(depsgraph, original=False):
    """Native dicts for every visible fractal object (instances included), in a stable order."""
    return [params for params, _ in fractal_instances(depsgraph, original)]


def image_window(scene):
    """Full image size and the rendered window (x, y, width, height) in pixels: the render border
    when one is set, as Blender computes it: border fraction times size in float32 (C's
    `border.xmin * winx`), truncated. Double precision differs: 0.7f * 100 is 69.99999 in double
    but rounds to 70.0 in float32, and a one-pixel error shifts and shrinks the border."""
    r = scene.render
    width = r.resolution_x * r.resolution_percentage // 100
    height = r.resolution_y * r.resolution_percentage // 100
    if width < 1 or height < 1:
        raise RenderError("The output resolution is %d x %d pixels: nothing to render" % (width, height))
    if not r.use_border:
        return width, height, (0, 0, width, height)
    fw, fh = np.float32(width), np.float32(height)
    x0, x1 = int(np.float32(r.border_min_x) * fw), int(np.float32(r.border_max_x) * fw)
    y0, y1 = int(np.float32(r.border_min_y) * fh), int(np.float32(r.border_max_y) * fh)
    if x1 <= x0 or y1 <= y0:
        raise RenderError("The render border is empty")
    return width, height, (x0, y0, x1 - x0, y1 - y0)


def world_color(scene):
    """Scene-linear RGB of the world: the colour and strength of a Background node feeding the
    World Output, or the world's viewport colour; black without a world."""
    world = scene.world
    if world is None:
        return (0.0, 0.0, 0.0)
    color, strength = tuple(world.color), 1.0
    if world.use_nodes and world.node_tree:
        out = next((n for n in world.node_tree.nodes if n.type == 'OUTPUT_WORLD' and n.is_active_output), None)
        link = out and next(iter(out.inputs["Surface"].links), None)
        if link and link.from_node.type == 'BACKGROUND':
            bg = link.from_node
            if not bg.inputs["Color"].is_linked:
                color = tuple(bg.inputs["Color"].default_value)[:3]
            if not bg.inputs["Strength"].is_linked:
                strength = bg.inputs["Strength"].default_value
    return (color[0] * strength, color[1] * strength, color[2] * strength)


def background(scene):
    """Premultiplied RGBA of the background: transparent film, else the world colour."""
    if scene.render.film_transparent:
        return (0.0, 0.0, 0.0, 0.0)
    return world_color(scene) + (1.0,)


def light_description(light, matrix):
    """A Blender light as the native core's light dict, in Cycles' units (measured against Cycles:
    a Lambertian surface returns albedo / pi times the irradiance E):
      sun:   E = strength (W/m^2) along -Z, angle = angular diameter;
      point: intensity P / (4 pi): E = P cos / (4 pi r^2), radius = shadow_soft_size; with soft
             falloff (the default since 4.1) E = P cos / (4 pi (r^2 + radius^2));
      spot:  a point light times smoothstep((cos a - cos(size/2)) / ((1 - cos(size/2)) blend));
      area:  radiance P / (pi A), far field E = P cos_light cos / (pi r^2), one-sided along -Z.
    Blender 4.5's exposure (2^exposure) multiplies the power where the property exists."""
    power = light.energy * 2.0 ** getattr(light, "exposure", 0.0)
    color = [c * power for c in light.color]
    axis = matrix.to_3x3() @ Vector((0.0, 0.0, -1.0))
    if axis.length == 0.0:
        raise RenderError("The light '%s' has a zero scale" % light.name)
    axis.normalize()
    out = dict(position=tuple(matrix.translation), direction=tuple(axis), cast_shadow=bool(light.use_shadow))
    if light.type == 'SUN':
        out.update(type="sun", color=color, radius=math.tan(0.5 * min(light.angle, math.pi * 0.999)))
    elif light.type in {'POINT', 'SPOT'}:
        out.update(type=light.type.lower(), color=[c / (4.0 * math.pi) for c in color],
                   radius=light.shadow_soft_size, soft_falloff=bool(getattr(light, "use_soft_falloff", False)))
        if light.type == 'SPOT':
            out.update(spot_size=light.spot_size, spot_blend=light.spot_blend)
    elif light.type == 'AREA':
        size_y = light.size_y if light.shape in {'RECTANGLE', 'ELLIPSE'} else light.size
        out.update(type="area", color=[c / math.pi for c in color], radius=0.5 * max(light.size, size_y))
    else:
        return None
    return out


def shading_description(depsgraph):
    """The native core's scene-wide shading dict: Scene.unbound's settings and the scene's lights."""
    scene = depsgraph.scene
    s = scene.unbound
    lights = []
    if s.use_scene_lights:
        lights = scene_instances(depsgraph, lambda ob: ob.type == 'LIGHT',
                                 lambda ob, matrix: light_description(ob.data, matrix))
    if len(lights) > 64:
        raise RenderError("The scene has %d lights; Unbound renders at most 64" % len(lights))
    fog_color = world_color(scene) if s.fog_use_world else tuple(s.fog_color)
    sea = None
    if s.use_sea:
        sea = dict(height=s.sea_height, wavelength=s.sea_wavelength, amplitude=s.sea_amplitude,
                   color=tuple(s.sea_color), reflectivity=s.sea_reflectivity)
    return dict(samples=s.samples, axle_light=s.axle_light, ambient=tuple(s.ambient), shadows=s.shadows.lower(),
                ao_strength=s.ao_strength, ao_distance=s.ao_distance, ao_samples=s.ao_samples,
                reflection_depth=s.reflection_depth, fog_density=s.fog_density, fog_color=fog_color,
                glow_strength=s.glow_strength, glow_color=tuple(s.glow_color), sea=sea, lights=lights)


def thread_count(scene):
    """Blender's Performance > Threads setting, as Cycles honours it (0: every core)."""
    r = scene.render
    return r.threads if r.threads_mode == 'FIXED' else 0


def precision_warning(core, camera, radii, depth):
    """A message when the nearest hit's pixel footprint is finer than single precision resolves
    (PRECISION_LIMIT of the largest fractal's bounding radius in the world), else None."""
    hits = depth[depth < 0.5 * core.BACKGROUND_DEPTH]
    radii = [r for r in radii if r > 0]  # -1: a slice that misses the set
    if hits.size == 0 or not radii:
        return None
    projection = camera["projection"]
    # Width of one pixel at unit distance (perspective) or on the image plane (orthographic).
    per_pixel = 2.0 / (camera["width"] * abs(projection[0][0]))
    orthographic = projection[3][2] == 0.0
    footprint = per_pixel if orthographic else per_pixel * float(hits.min())
    ratio = footprint / max(radii)
    if ratio >= PRECISION_LIMIT:
        return None
    return ("a pixel covers %.1e of the fractal's size here, finer than single precision resolves "
            "(%.0e): expect steps in depth and shading. Zoom out or move the camera back "
            "(README: Precision)" % (ratio, PRECISION_LIMIT))


def update_render_passes(engine, scene, view_layer):
    for p in passes.enabled(view_layer):
        engine.register_pass(scene, view_layer, p.name, p.channels, p.chan_id, p.kind)


def render(engine, depsgraph):
    """RenderEngine.render: one view layer of one frame."""
    try:
        _render(engine, depsgraph)
    except (RenderError, ImportError, ValueError, TypeError) as exc:
        message = "Unbound: %s" % exc
        engine.report({'ERROR'}, message)
        engine.error_set(message)


def _render(engine, depsgraph):
    scene = depsgraph.scene
    view_layer = depsgraph.view_layer
    core = utils.native()
    width, height, window = image_window(scene)
    camera = camera_description(engine, depsgraph, width, height)
    instances = fractal_instances(depsgraph)
    objects = [params for params, _ in instances]
    shading = shading_description(depsgraph)
    wanted = passes.enabled(view_layer)
    w, h = window[2], window[3]
    buffers = {p.native: np.empty((h, w, p.channels), np.float32) for p in wanted}
    # Depth is always rendered: the precision check below reads it (one float per pixel).
    buffers.setdefault("depth", np.empty((h, w, 1), np.float32))
    frame = scene.frame_current
    label = "Frame %d | %s" % (frame, view_layer.name)
    engine.update_stats("", "Unbound | %s | %d fractal object%s" % (label, len(objects), "" if len(objects) == 1 else "s"))

    def progress(fraction):
        engine.update_progress(fraction)
        return engine.test_break()

    started = time.perf_counter()
    stats = core.render(camera, objects, buffers, window=window, threads=thread_count(scene),
                        tile_size=scene.unbound.tile_size, simd=scene.unbound.simd.lower(),
                        background=background(scene), shading=shading, progress=progress,
                        poll_interval=0.02)
    LAST_STATS.clear()
    LAST_STATS.update(stats)
    # The result covers the window: Blender places it in the full frame (or crops to it).
    result = engine.begin_result(0, 0, w, h, layer=view_layer.name)
    try:
        layer = result.layers[0]
        for p in wanted:
            layer.passes[p.name].rect.foreach_set(buffers[p.native].ravel())
    finally:
        engine.end_result(result, cancel=stats["cancelled"])
    if stats["cancelled"]:
        engine.update_stats("", "Unbound | %s | cancelled" % label)
        return
    warning = precision_warning(core, camera, [radius for _, radius in instances], buffers["depth"])
    if warning:
        engine.report({'WARNING'}, "Unbound: " + warning)
    elapsed = time.perf_counter() - started
    engine.update_progress(1.0)
    engine.update_stats("", "Unbound | %s | %.2f s | %.1f Mrays/s | %s, %d threads" % (
        label, elapsed, stats["rays"] / max(stats["seconds"], 1e-9) / 1e6, stats["simd"], stats["threads"]))
