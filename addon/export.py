"""Blender -> the native core: the whole translation, in one place, for final renders (engine.py)
and the Rendered viewport (viewport.py) alike.

Every Object.unbound / Scene.unbound property that is a core key has the key's name and is passed
through as it is (enum identifiers lower-cased); the table of the core (unbound_core.PARAMETERS)
gives both their limits and defaults, and tests/blender/test_parameter_table.py holds the two
together. What is built here is only what Blender describes in its own terms: the camera, the
slice frame from the slice offset and rotation, a Julia stack's c-path, IFS maps from location,
rotation and scale, a colour ramp from a texture, the lights, the world's colour, a material's Principled BSDF.

Nothing is validated here: the core checks every value once, and names the object in its
messages (each object dict carries its `name`)."""
import math

import numpy as np
from mathutils import Euler, Matrix, Vector

from . import utils


class RenderError(Exception):
    """A problem the user can fix; reported in Blender's UI, never as a traceback."""


# ---------------------------------------------------------------------------- camera and image

def camera_description(engine, depsgraph, width, height):
    """The native camera dict: Blender's own camera matrix and projection matrix, so focal length,
    sensor size and fit, shift, clipping, orthographic scale and pixel aspect all come for free;
    for a panoramic camera its type and settings as Cycles reads them. With stereo 3D the engine's
    active view picks the eye: its matrix (camera_model_matrix) and its horizontal shift
    (camera_shift_x: off-axis convergence shifts each eye's frustum), as Cycles reads them."""
    cam_ob = evaluated_camera(engine.camera_override or depsgraph.scene.camera, depsgraph)
    cam = camera_dict(depsgraph, cam_ob, engine.camera_model_matrix(cam_ob, use_spherical_stereo=False),
                      width, height)
    shift = engine.camera_shift_x(cam_ob, use_spherical_stereo=False) - cam_ob.data.shift_x
    if shift and cam_ob.data.type == 'PANO':
        # Cycles shifts a panorama's viewplane by the eye's shift_x.
        vp = cam["viewplane"]
        cam["viewplane"] = (vp[0] + shift, vp[1] + shift, vp[2], vp[3])
    elif shift:
        shift_projection_x(cam["projection"], shift, cam_ob.data, depsgraph.scene.render, width, height)
    return cam


def shift_projection_x(projection, shift, cam_data, render, width, height):
    """Adds `shift` (in Blender's shift_x units) to a projection matrix from calc_matrix_camera,
    as BKE_camera_params_compute_viewplane applies shift_x: the viewplane moves by shift times the
    sensor-fit dimension (the width with horizontal fit; the height times the pixel aspect with
    vertical fit), which is 2 shift fit / width in normalised device coordinates."""
    aspect_x, aspect_y = render.pixel_aspect_x, render.pixel_aspect_y
    fit = cam_data.sensor_fit
    if fit == 'AUTO':
        fit = 'HORIZONTAL' if aspect_x * width >= aspect_y * height else 'VERTICAL'
    scale = 1.0 if fit == 'HORIZONTAL' else (aspect_y / aspect_x) * height / width
    delta = 2.0 * shift * scale
    if cam_data.type == 'PERSP':
        projection[0][2] += delta
    else:
        projection[0][3] -= delta


# Blender's panoramic camera types Unbound renders, as Cycles does (their core names are the
# identifiers lower-cased).
PANORAMA_TYPES = ('EQUIRECTANGULAR', 'FISHEYE_EQUIDISTANT', 'FISHEYE_EQUISOLID', 'MIRRORBALL')


def evaluated_camera(cam_ob, depsgraph):
    """The evaluated camera object to render through, or a RenderError a user can act on."""
    if cam_ob is None:
        raise RenderError("The scene has no camera: add one or set Scene > Camera")
    cam_ob = cam_ob.evaluated_get(depsgraph)
    if cam_ob.type != 'CAMERA':
        raise RenderError("The scene camera '%s' is not a camera object" % cam_ob.name)
    data = cam_ob.data
    if data.type == 'PANO' and data.panorama_type not in PANORAMA_TYPES:
        names = {'EQUIANGULAR_CUBEMAP_FACE': "Equiangular Cubemap Face",
                 'FISHEYE_LENS_POLYNOMIAL': "Fisheye Lens Polynomial"}
        raise RenderError("the camera '%s' is a panoramic camera of type %s; Unbound renders the "
                          "equirectangular, fisheye equidistant, fisheye equisolid and mirror ball types"
                          % (cam_ob.name, names.get(data.panorama_type, data.panorama_type.lower())))
    if data.type not in {'PERSP', 'ORTHO', 'PANO'}:
        raise RenderError("the camera '%s' is %s; only perspective, orthographic and panoramic cameras are "
                          "supported" % (cam_ob.name, data.type.lower()))
    return cam_ob


def camera_dict(depsgraph, cam_ob, matrix, width, height, viewplane=None):
    """The native camera dict of camera object `cam_ob` (evaluated) placed at `matrix`, for an
    image of width x height pixels. viewplane: a panoramic camera's part of the panorama that
    the image shows (the viewport's); None: the whole panorama, shifted by the camera's shift."""
    r = depsgraph.scene.render
    data = cam_ob.data
    projection = cam_ob.calc_matrix_camera(depsgraph, x=width, y=height, scale_x=r.pixel_aspect_x,
                                           scale_y=r.pixel_aspect_y)
    # A panoramic camera takes only its clip distances from the (perspective) projection.
    out = native_camera(matrix, projection, data.type != 'ORTHO', data.clip_start, data.clip_end, width, height)
    if data.type == 'PANO':
        out.update(panorama_keys(data, r, viewplane))
    out.update(depth_of_field(depsgraph, cam_ob, matrix))
    return out


def depth_of_field(depsgraph, cam_ob, matrix):
    """The core's depth-of-field keys of camera object `cam_ob` (evaluated) placed at `matrix`, as
    Cycles' blender_camera_from_object makes them: the lens' radius is the focal length in metres
    over twice the f-stop (orthographic: 1 / (2 f-stop) world units), whatever the scene's unit
    scale or the sensor; the focus object's distance is along the camera's view axis to its
    origin (or its bone's, with a focus bone). Depth of field off: a pinhole."""
    dof = cam_ob.data.dof
    if not dof.use_dof:
        return dict(aperture_size=0.0, focus_distance=10.0, aperture_blades=0, aperture_rotation=0.0,
                    aperture_ratio=1.0)
    fstop = max(dof.aperture_fstop, 1e-5)
    focal_length = 1.0 if cam_ob.data.type == 'ORTHO' else cam_ob.data.lens * 1e-3
    return dict(aperture_size=focal_length / (2.0 * fstop), focus_distance=focus_distance(depsgraph, dof, matrix),
                aperture_blades=dof.aperture_blades, aperture_rotation=dof.aperture_rotation,
                aperture_ratio=dof.aperture_ratio)


def focus_distance(depsgraph, dof, matrix):
    """Cycles' blender_camera_focal_distance: the focus distance, or the focus object's (bone's)
    distance along the view axis of a camera at `matrix` (its scale ignored)."""
    if dof.focus_object is None:
        return dof.focus_distance
    target = dof.focus_object.evaluated_get(depsgraph)
    target_matrix = target.matrix_world
    bone = target.pose.bones.get(dof.focus_subtarget) if target.pose and dof.focus_subtarget else None
    if bone is not None:
        target_matrix = target_matrix @ bone.matrix
    m = Matrix(matrix)
    view_axis = m.col[2].to_3d().normalized()
    return abs(view_axis.dot(m.col[3].to_3d() - target_matrix.col[3].to_3d()))


def panorama_keys(data, render, viewplane=None):
    """The core's panoramic camera keys of camera data `data`, as Cycles' blender_camera_sync
    makes them: the equisolid fisheye's sensor after the sensor fit, which Cycles makes with the
    render's resolution (also in the viewport); the shift moves the panorama's unit square."""
    width = render.resolution_x * render.resolution_percentage // 100
    height = render.resolution_y * render.resolution_percentage // 100
    fit_x, fit_y = width * render.pixel_aspect_x, height * render.pixel_aspect_y
    if data.sensor_fit == 'AUTO':
        horizontal, size = fit_x > fit_y, data.sensor_width
    elif data.sensor_fit == 'HORIZONTAL':
        horizontal, size = True, data.sensor_width
    else:
        horizontal, size = False, data.sensor_height
    sensor = (size, size * fit_y / fit_x) if horizontal else (size * fit_x / fit_y, size)
    if viewplane is None:
        viewplane = (data.shift_x, 1.0 + data.shift_x, data.shift_y, 1.0 + data.shift_y)
    return dict(panorama_type=data.panorama_type.lower(), fisheye_fov=data.fisheye_fov,
                fisheye_lens=data.fisheye_lens, sensor_width=sensor[0], sensor_height=sensor[1],
                latitude_min=data.latitude_min, latitude_max=data.latitude_max,
                longitude_min=data.longitude_min, longitude_max=data.longitude_max, viewplane=tuple(viewplane))


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


# ---------------------------------------------------------------------------- fractal objects

# Object.unbound properties that are core keys of the same name, passed as they are (enums
# lower-cased). The rest of the object dict is built below from Blender's own terms.
OBJECT_KEYS = ("kind", "mu", "theta", "max_iterations", "bailout", "threshold_mode", "epsilon", "detail",
               "step_factor", "max_step", "max_steps", "bisection_steps", "color", "normal_method", "normal_alpha",
               "normal_delta", "reflectivity", "color_mode", "ramp_scale", "ramp_offset")
KIND_KEYS = {'QUATERNION_JULIA': ("zoom", "zoom_anchor"), 'QUATERNION_MANDELBROT': ("zoom", "zoom_anchor"),
             'JULIA_STACK': ("stack_height",), 'CUBIC_LOCUS': ("cubic_component", "extent"),
             'IFS': ("ifs_depth",), 'MANDELBULB': ("power", "julia_mode", "julia_c", "zoom", "zoom_anchor"),
             'MANDELBOX': ("box_scale", "box_fold", "min_radius", "fixed_radius", "julia_mode", "julia_c", "zoom",
                           "zoom_anchor"),
             'KIFS': ("kifs_scale", "kifs_offset", "kifs_rotation", "kifs_shape", "kifs_size", "zoom", "zoom_anchor"),
             'HYBRID': ("power", "box_scale", "box_fold", "min_radius", "fixed_radius", "julia_mode", "julia_c",
                        "kifs_scale", "kifs_offset", "kifs_rotation", "zoom", "zoom_anchor")}
# A hybrid entry's formula as the core numbers it.
HYBRID_FORMULA_INDEX = {'MANDELBULB': 0, 'MANDELBOX': 1, 'KIFS': 2}

# The most points of a c-path and of a colour ramp the core takes (its PARAMETERS).
PATH_POINTS = 256
RAMP_SIZE = 64


def core_value(value):
    """A property's value as the core takes it: enum identifiers lower-cased, arrays as tuples."""
    if isinstance(value, str):
        return value.lower()
    if hasattr(value, "__len__"):
        return tuple(value)
    return value


def object_parameters(ob, depsgraph=None, with_ramp=True):
    """The core's object dict of fractal object `ob` (without its world matrix). A curve c-path is
    read from the evaluated curve when a depsgraph is given, else from its control points."""
    props = ob.unbound
    out = {key: core_value(getattr(props, key)) for key in OBJECT_KEYS + KIND_KEYS.get(props.kind, ())}
    out["name"] = ob.name
    out["slice_basis"], out["slice_origin"] = slice_frame(props.slice_offset, props.slice_rotation)
    if with_ramp and props.color_mode != 'BASE':
        out["color_ramp"] = ramp_table(props.color_ramp_texture)
    if props.material is not None:
        out.update(material_description(props.material)[0])
    try:
        if props.kind == 'JULIA_STACK':
            out["path"] = c_path(props, depsgraph)
        elif props.kind == 'IFS':
            if not len(props.ifs_maps):
                raise RenderError("an IFS needs at least one map: add one, or pick a preset")
            out["maps"] = [ifs_map_rows(m) for m in props.ifs_maps]
        if props.kind in {'KIFS', 'HYBRID'}:
            out["kifs_planes"] = [tuple(p.normal) + (p.offset,) for p in props.kifs_planes]
        if props.kind == 'HYBRID':
            if not len(props.hybrid_steps):
                raise RenderError("a hybrid needs at least one step: add one, or pick a preset")
            out["hybrid_steps"] = [(HYBRID_FORMULA_INDEX[e.formula], e.count) for e in props.hybrid_steps]
    except RenderError as exc:  # named as the core names an object
        raise RenderError("fractal '%s': %s" % (ob.name, exc)) from None
    return out


def slice_frame(offset, rotation):
    """Slice map of object space into the quaternions: the 1-i-j space at k = offset, turned
    toward the k axis by rotation (angles in the 1-k, i-k and j-k planes, applied in that order).
    Returns (basis 4x3 as rows, origin 4)."""
    frame = [[1.0 if r == c else 0.0 for c in range(4)] for r in range(4)]  # columns: 1, i, j, k
    same_bits = utils.native().same_bits  # the core's sin and cos: the same slice on every platform
    # No rotation (the usual slice): turning the identity by angles 0 (cos 1, sin 0) leaves it the
    # same bits, so the six calls into the core are skipped (issue 21: an animation frame reads
    # this three times).
    for axis, angle in enumerate(rotation if any(rotation) else ()):
        c, s = same_bits.cos(angle), same_bits.sin(angle)
        for r in range(4):
            a, k = frame[r][axis], frame[r][3]
            frame[r][axis], frame[r][3] = c * a - s * k, s * a + c * k
    basis = [row[:3] for row in frame]
    origin = [offset * frame[r][3] for r in range(4)]
    return basis, origin


def ifs_map_rows(m):
    """The core's 3x4 rows [A | t] of an IFS map x -> T R S x."""
    matrix = Matrix.LocRotScale(m.location, Euler(m.rotation, 'XYZ'), m.scale)
    return [list(matrix[r]) for r in range(3)]


def c_path(props, depsgraph=None):
    """Points (Re c, Im c) of a Julia stack's path, bottom to top."""
    if props.path_mode == 'LINE':
        return [tuple(props.c_start), tuple(props.c_end)]
    curve = props.path_curve
    if curve is None:
        raise RenderError("the Julia stack's c-path is a curve, but no curve object is set")
    if curve.type != 'CURVE':
        raise RenderError("the Julia stack's c-path object '%s' is not a curve" % curve.name)
    if depsgraph is not None:
        # The evaluated curve (resolution, modifiers, animation) as Blender tessellates it.
        evaluated = curve.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        try:
            points = [(v.co.x, v.co.y) for v in mesh.vertices]
        finally:
            evaluated.to_mesh_clear()
    else:
        points = [(p.co.x, p.co.y) for spline in curve.data.splines
                  for p in (spline.bezier_points if spline.type == 'BEZIER' else spline.points)]
    if not points:
        raise RenderError("the c-path curve '%s' has no points" % curve.name)
    if len(points) > PATH_POINTS:
        step = (len(points) - 1) / (PATH_POINTS - 1)
        points = [points[round(i * step)] for i in range(PATH_POINTS)]
    return points


def ramp_table(texture):
    """Colours of a texture's colour ramp sampled uniformly (Blender evaluates its own ramp:
    interpolation, colour mode and keyframed stops included); None without a ramp."""
    if texture is None or not texture.use_color_ramp:
        return None
    return [c[:3] for c in sampled_ramp(texture.color_ramp)]


def sampled_ramp(ramp):
    """A ColorRamp's RGBA at RAMP_SIZE points uniformly spaced over [0, 1], as Blender evaluates it."""
    return [tuple(ramp.evaluate(i / (RAMP_SIZE - 1))) for i in range(RAMP_SIZE)]


# ---------------------------------------------------------------------------- materials

# Attribute node names a material reads, and the core's attribute each one is (docs: README,
# Materials). Vectors are read as their Fac, the mean of the components, as Blender's Attribute node.
MATERIAL_ATTRIBUTES = {"unbound_orbit_trap": "orbit_trap", "unbound_iterations": "iterations",
                       "unbound_distance": "distance", "unbound_position": "position",
                       "unbound_normal": "normal"}
# Principled BSDF inputs an attribute may drive (through a Color Ramp or a Map Range): the core's
# key and its channels.
DRIVEN_INPUTS = {"Base Color": ("base_color", 3), "Metallic": ("metallic", 1), "Roughness": ("roughness", 1)}
# Principled inputs read as constants: (socket, core key).
CONSTANT_INPUTS = (("IOR", "material_ior"), ("Specular IOR Level", "material_specular_ior_level"),
                   ("Alpha", "material_alpha"))
# Principled layers Unbound does not render: the socket whose non-zero value turns each on.
UNRENDERED_LAYERS = ("Subsurface Weight", "Transmission Weight", "Coat Weight", "Sheen Weight")
# Scene-linear RGB -> luminance (Rec. 709, Blender's default scene-linear space): how a colour
# becomes a number when a Color Ramp's Color drives Metallic or Roughness.
LUMINANCE = (0.2126, 0.7152, 0.0722)


def material_output_node(material):
    """The node feeding the active Material Output's Surface (for Cycles or all engines), or None."""
    outputs = [n for n in material.node_tree.nodes if n.type == 'OUTPUT_MATERIAL' and n.target in {'ALL', 'CYCLES'}]
    out = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    link = out and next(iter(out.inputs["Surface"].links), None)
    return link.from_node if link else None


def material_description(material):
    """The core's material_* keys of a Blender material, and the warnings about what they leave out.

    Read: a Principled BSDF feeding the Material Output: Base Color, Metallic, Roughness, IOR,
    Specular IOR Level, Emission Color x Emission Strength, Alpha, each as its value, or for Base
    Color, Metallic and Roughness an Attribute node named in MATERIAL_ATTRIBUTES through a Color
    Ramp or a Map Range (or directly). Anything else linked to an input is named in a warning and
    the input keeps its own value; a material without nodes, or whose output is not a Principled
    BSDF, renders as a Principled BSDF of its viewport display colour, metallic and roughness."""
    name = material.name
    out = dict(use_material=True)
    node = material_output_node(material) if material.use_nodes and material.node_tree else None
    if node is None or node.type != 'BSDF_PRINCIPLED':
        out.update(material_base_color=tuple(material.diffuse_color)[:3], material_metallic=material.metallic,
                   material_roughness=material.roughness)
        if node is None:
            return out, []
        return out, ["material '%s': the node '%s' (%s) feeding the Material Output is not a Principled BSDF; "
                     "rendered as a Principled BSDF of the material's viewport display colour"
                     % (name, node.name, node.bl_label)]
    warnings = []
    for socket, (key, channels) in DRIVEN_INPUTS.items():
        out.update(driven_input(material, node.inputs[socket], key, channels, warnings))
    for socket, key in CONSTANT_INPUTS:
        out[key] = constant_input(material, node.inputs[socket], warnings)
    color = constant_input(material, node.inputs["Emission Color"], warnings)
    strength = constant_input(material, node.inputs["Emission Strength"], warnings)
    out["material_emission"] = tuple(c * strength for c in color[:3])
    off = [s for s in UNRENDERED_LAYERS if s in node.inputs and (node.inputs[s].is_linked
                                                                  or node.inputs[s].default_value != 0.0)]
    if off:
        warnings.append("material '%s': Unbound does not render the Principled BSDF's %s; left out"
                        % (name, ", ".join(off)))
    return out, warnings


def constant_input(material, socket, warnings):
    """A socket's own value; if something is linked to it, a warning naming that node."""
    if socket.is_linked:
        node = socket.links[0].from_node
        warnings.append("material '%s': %s is linked from the node '%s' (%s), which Unbound cannot evaluate; "
                        "using the input's own value" % (material.name, socket.name, node.name, node.bl_label))
    value = socket.default_value
    return tuple(value) if hasattr(value, "__len__") else value


def driven_input(material, socket, key, channels, warnings):
    """The core keys of a Principled input: its value, or its attribute, table, scale and offset when
    an Attribute node drives it (through a Color Ramp or a Map Range, or directly)."""
    prefix = "material_" + key
    value = socket.default_value
    out = {prefix: tuple(value)[:3] if channels == 3 else value}
    if not socket.is_linked:
        return out
    link = socket.links[0]
    node, table, scale, offset = link.from_node, [(0.0,) * 4, (1.0,) * 4], 1.0, 0.0
    source = node
    if node.type == 'VALTORGB':  # Color Ramp
        table = sampled_ramp(node.color_ramp)
        if link.from_socket.name == "Alpha":
            table = [(c[3],) * 4 for c in table]
        source = linked_node(node.inputs["Fac"])
    elif node.type == 'MAP_RANGE' and node.data_type == 'FLOAT' and node.interpolation_type == 'LINEAR':
        low, high, to_low, to_high = (node.inputs[i].default_value for i in range(1, 5))
        if high != low and not any(node.inputs[i].is_linked for i in range(1, 5)):
            scale, offset = 1.0 / (high - low), -low / (high - low)
            table = [(to_low,) * 4, (to_high,) * 4]
            source = linked_node(node.inputs[0])
        else:
            source = None
    attribute = MATERIAL_ATTRIBUTES.get(source.attribute_name) if source is not None and \
        source.type == 'ATTRIBUTE' else None
    if attribute is None:
        bad = source if source is not None and source is not node and source.type != 'ATTRIBUTE' else node
        warnings.append("material '%s': %s is driven by the node '%s' (%s), which Unbound cannot evaluate "
                        "(it reads an Attribute node named %s, through a Color Ramp or a linear, float Map Range); "
                        "using the input's own value"
                        % (material.name, socket.name, bad.name, bad.bl_label, ", ".join(sorted(MATERIAL_ATTRIBUTES))))
        return out
    if channels == 3:
        rows = [tuple(c[:3]) for c in table]
    else:
        from_color = node.type == 'VALTORGB' and link.from_socket.name == "Color"
        rows = [(sum(w * v for w, v in zip(LUMINANCE, c)),) if from_color else (c[0],) for c in table]
    out.update({prefix + "_source": attribute, prefix + "_ramp": rows, prefix + "_scale": scale,
                prefix + "_offset": offset})
    return out


def linked_node(socket):
    """The node linked to an input socket, or None."""
    return socket.links[0].from_node if socket.is_linked else None


def material_warnings(depsgraph):
    """One line naming what the fractals' materials use that Unbound cannot evaluate, or None."""
    seen, lines = set(), []
    for inst in depsgraph.object_instances:
        ob = inst.object
        material = utils.is_fractal(ob) and ob.unbound.material
        if material and material.name_full not in seen:
            seen.add(material.name_full)
            lines += material_description(material)[1]
    return "; ".join(lines) if lines else None


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


def fractal_objects(depsgraph, original=False):
    """The core's dicts of every visible fractal object (instances included), in a stable order:
    each object's parameters read once, its matrix per instance. original: read the parameters
    from the original objects, not the evaluated copies, which a script's change does not reach
    without a depsgraph tag (the viewport's depsgraph is the active one, where keyframes and
    drivers write the originals too)."""
    params = {}

    def describe(ob, matrix):
        key = ob.name_full  # a linked object may share its name with a local one
        if key not in params:
            params[key] = object_parameters(ob.original if original else ob, depsgraph)
        return dict(params[key], matrix=[list(row) for row in matrix])

    return scene_instances(depsgraph, utils.is_fractal, describe)


# ---------------------------------------------------------------------------- world and lights

def world_color(scene):
    """Scene-linear RGB of the world: the colour and strength of a Background node feeding the
    World Output, or the world's viewport colour; black without a world."""
    world = scene.world
    if world is None:
        return (0.0, 0.0, 0.0)
    color, strength = tuple(world.color), 1.0
    bg = background_node(world)
    if bg is not None:
        if not bg.inputs["Color"].is_linked:
            color = tuple(bg.inputs["Color"].default_value)[:3]
        if not bg.inputs["Strength"].is_linked:
            strength = bg.inputs["Strength"].default_value
    return (color[0] * strength, color[1] * strength, color[2] * strength)


def world_surface_node(world):
    """The node feeding the active World Output's Surface of a world that uses nodes, or None."""
    if not (world.use_nodes and world.node_tree):
        return None
    out = next((n for n in world.node_tree.nodes if n.type == 'OUTPUT_WORLD' and n.is_active_output), None)
    link = out and next(iter(out.inputs["Surface"].links), None)
    return link.from_node if link else None


def background_node(world):
    """The Background node feeding the active World Output of a world that uses nodes, or None
    (world_color then reads the world's own colour; the World tab shows the one it reads)."""
    node = world_surface_node(world)
    return node if node is not None and node.type == 'BACKGROUND' else None


def background(scene):
    """Premultiplied RGBA of the background: transparent film, else the world colour."""
    if scene.render.film_transparent:
        return (0.0, 0.0, 0.0, 0.0)
    return world_color(scene) + (1.0,)


def light_description(light, matrix):
    """A Blender light as the core's light dict, in Cycles' units (measured against Cycles: a
    Lambertian surface returns albedo / pi times the irradiance E):
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
        out.update(type="sun", color=color, radius=utils.native().same_bits.tan(0.5 * min(light.angle, math.pi * 0.999)))
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


# Scene.unbound properties that are shading keys of the same name.
SHADING_KEYS = ("samples", "axle_light", "ambient", "shadows", "ao_strength", "ao_distance", "ao_samples",
                "reflection_depth", "fog_density", "fog_color", "glow_strength", "glow_color", "use_sea",
                "sea_height", "sea_wavelength", "sea_amplitude", "sea_color", "sea_reflectivity", "world_samples",
                "use_gi", "max_bounces", "diffuse_bounces", "glossy_bounces")
MAX_LIGHTS = 64


def shading_description(depsgraph, samples=None):
    """The core's shading dict: Scene.unbound's settings and the scene's lights; `samples`
    overrides the sample count (the viewport's own)."""
    scene = depsgraph.scene
    s = scene.unbound
    out = {key: core_value(getattr(s, key)) for key in SHADING_KEYS}
    if samples is not None:
        out["samples"] = samples
    if s.fog_use_world:
        out["fog_color"] = world_color(scene)
    lights = []
    if s.use_scene_lights:
        lights = scene_instances(depsgraph, lambda ob: ob.type == 'LIGHT',
                                 lambda ob, matrix: light_description(ob.data, matrix))
    if len(lights) > MAX_LIGHTS:
        raise RenderError("The scene has %d lights; Unbound renders at most %d" % (len(lights), MAX_LIGHTS))
    out["lights"] = lights
    return out


# ---------------------------------------------------------------------------- render keywords

def thread_count(scene):
    """Blender's Performance > Threads setting, as Cycles honours it (0: every core)."""
    r = scene.render
    return r.threads if r.threads_mode == 'FIXED' else 0


def render_options(scene, bake_world=True):
    """render()'s keywords from the scene: threads, tiles, kernel, background, the World's map
    (world_light.py; bake_world=False: a World not baked yet gives none)."""
    from . import world_light
    s = scene.unbound
    return dict(threads=thread_count(scene), tile_size=s.tile_size, simd=core_value(s.simd),
                background=background(scene), world=world_light.world_map(scene, bake=bake_world))
