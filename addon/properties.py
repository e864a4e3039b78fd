"""Unbound's settings: one PropertyGroup per datablock (Object.unbound, Scene.unbound,
ViewLayer.unbound). Every property is animatable and drivable; enum items carry explicit
indices so that .blend files survive renames."""
import math

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty, StringProperty)

from . import export, passes, utils

# Section 5: the paper's other families. "Exact": the distance estimate never oversteps the set
# (proven); "empirical": no such proof exists, so Unbound marches them with half steps, a step cap
# and bisection of every hit.
FRACTAL_KINDS = [
    ('QUATERNION_JULIA', "Quaternion Julia", "3-D slice of the Julia set of z^2 + mu over the quaternions "
     "(exact distance estimate)", 0),
    ('QUATERNION_MANDELBROT', "Quaternion Mandelbrot", "3-D slice of the Mandelbrot set over the quaternions: "
     "z starts at 0 and mu is the point (exact distance estimate)", 1),
    ('JULIA_STACK', "Julia Stack", "Complex Julia sets of z^2 + c stacked along a path of c, the path along "
     "Z (section 5.1; empirical estimate, marched with care)", 2),
    ('CUBIC_LOCUS', "Cubic Connectedness Locus", "Parameters (a, b) of z^3 - 3a^2 z + b whose critical orbits "
     "stay bounded, a 3-D slice of 4-D (section 5.2; empirical estimate, marched with care)", 3),
    ('IFS', "Iterated Function System", "Attractor of 3-D affine maps (section 5.3; exact bound from "
     "bounding spheres through the map hierarchy)", 4),
    ('MANDELBULB', "Mandelbulb", "White and Nylander's triplex power z^n + c, Mandelbrot or Julia mode "
     "(analytic running-derivative estimate; empirical, marched with care)", 5),
    ('MANDELBOX', "Mandelbox", "Lowe's box fold, sphere fold and scale, Mandelbrot or Julia mode "
     "(running-scale estimate; empirical, marched with care)", 6),
    ('KIFS', "Kaleidoscopic IFS", "Knighty's folds by planes, rotation, scale and offset: Menger sponge, "
     "Sierpinski tetrahedron, octahedral flake or your own planes (exact running-scale bound)", 7),
    ('HYBRID', "Hybrid", "Mandelbulb, Mandelbox and KIFS steps in turn, each a number of times (combined "
     "running derivative; empirical, marched with care)", 8),
]
EXACT_KINDS = {'QUATERNION_JULIA', 'QUATERNION_MANDELBROT', 'IFS', 'KIFS'}
SLICED_KINDS = {'QUATERNION_JULIA', 'QUATERNION_MANDELBROT', 'CUBIC_LOCUS'}
PATH_MODES = [
    ('LINE', "Line", "c moves along a straight segment from C Start (bottom) to C End (top)", 0),
    ('CURVE', "Curve", "c follows a curve object from its first point (bottom) to its last (top), "
     "x = Re c and y = Im c in the curve's own coordinates", 1),
]
CUBIC_COMPONENTS = [
    ('PLUS', "C+", "Parameters whose critical orbit from +a stays bounded", 0),
    ('MINUS', "C-", "Parameters whose critical orbit from -a stays bounded", 1),
    ('UNION', "C+ or C-", "Either critical orbit stays bounded: the union of both components", 2),
    ('BOTH', "C+ and C-", "Both critical orbits stay bounded: the connectedness locus itself", 3),
]
THRESHOLD_MODES = [
    ('PIXEL', "Pixel", "Hit threshold follows the pixel footprint at each depth (detail adapts to resolution)", 0),
    ('FIXED', "Fixed", "Hit threshold is a fixed distance in object units, as in the paper", 1),
]
NORMAL_METHODS = [
    ('GRADIENT_DISTANCE', "Gradient of Distance", "Central differences of the distance estimate d() "
     "(eq. 15), step alpha * t^delta", 0),
    ('GRADIENT_POTENTIAL', "Gradient of Potential", "Central differences of the potential G() (eq. 15), "
     "step alpha * t^delta", 1),
    ('ZBUFFER', "Z-Buffer Neighbours", "Plane through the hits of neighbouring pixels (eq. 12-14); "
     "reflections use the distance gradient", 2),
    ('ANALYTIC', "Analytic", "Gradient of |f^n| through the iteration's Jacobian: one evaluation, "
     "sharpest detail", 3),
]
COLOR_MODES = [
    ('BASE', "Base Color", "One colour for the whole surface", 0),
    ('ORBIT_TRAP', "Orbit Trap", "Colour ramp over the orbit's closest approach to the origin, min |z_k|", 1),
    ('ITERATIONS', "Iterations", "Colour ramp over the escape count divided by the iteration limit", 2),
]
SHADOW_MODES = [
    ('NONE', "None", "Lights are never blocked", 0),
    ('HARD', "Hard", "A ray marched toward each light: lit or not", 1),
    ('SOFT', "Soft", "Penumbra from each light's size (radius, sun angle, area size), estimated from how "
     "nearly the shadow ray missed", 2),
]
# The viewport's first refinement renders every d-th pixel of every d-th row (the item's index
# is d, so renaming an item keeps old files' values).
VIEWPORT_DIVISORS = [('1', "Full", "Start at full resolution", 1)] + [
    (str(d), "1/%d" % d, "Start with every %dth pixel of every %dth row, then halve the spacing" % (d, d), d)
    for d in (2, 4, 8, 16, 32, 64)]
# The drag and click step of mu and c (in hundredths, Blender's unit for `step`): Blender's number
# fields move by step / 10000 per pixel dragged, so 10 makes a 100-pixel drag change mu by 0.1 (at
# step 1 it took a 76-pixel drag to move it by 0.01). Shift-drag is ten times finer.
MU_STEP = 10

SIMD_MODES = [
    ('AUTO', "Automatic", "The widest kernel the CPU runs: AVX-512, else AVX2 and FMA, else portable code", 0),
    ('AVX2', "AVX2", "Force the AVX2 and FMA kernel", 1),
    ('PORTABLE', "Portable", "Force the portable kernel (same pixels, slower)", 2),
    ('AVX512', "AVX-512", "Force the AVX-512 kernel (16 rays per packet)", 3),
]


def display_radius(ob, depsgraph=None):
    """Radius around the object's origin of a sphere holding its set: the core's bounding ball
    (describe()); None while the settings are invalid (the render then reports why)."""
    try:
        bound = utils.native().describe(export.object_parameters(ob, depsgraph, with_ramp=False))
    except (ImportError, ValueError, TypeError, export.RenderError):
        return None
    return math.sqrt(sum(c * c for c in bound["bound_center"])) + max(bound["bound_radius"], 0.0)


def _sync_display_size(ob):
    if utils.is_fractal(ob) and not ob.library:
        radius = display_radius(ob)
        if radius is not None and abs(ob.empty_display_size - radius) > 1e-6:
            ob.empty_display_size = radius


# Keep each fractal empty's sphere display on the bounding sphere of its set. Handlers rather than
# property update callbacks: update callbacks make the bpy 4.2 module crash at process exit, and
# they would not follow keyframes anyway. Only differing sizes are written, so they settle at once.
#
# Never while rendering. A final render runs these handlers for its own depsgraph (frame_change_post
# with the render's depsgraph, after it evaluated the frame), and the handler writes the ORIGINAL
# object. Such a write tags the object, and Blender then evaluates the render depsgraph a second
# time for the tag: it copies the original over the evaluated object again without re-running its
# animation, so every keyframed Object.unbound value in the frame went back to the original's
# (un-animated) value; the transform, being runtime data Blender keeps, stayed right. A size only
# differs on the first frame of a render (the original does not change during a render), so the
# first frame got the original's values: those of the frame the file was saved at when the add-on
# was registered before the file loaded (Blender then writes that frame's animated values into the
# original), or whatever a script had set. Only the viewport's depsgraph drives the display size.
def _is_render(depsgraph):
    return depsgraph is not None and depsgraph.mode == 'RENDER'


@bpy.app.handlers.persistent
def sync_updated_objects(scene, depsgraph):
    """After edits: only the objects the depsgraph reports as updated."""
    if _is_render(depsgraph):
        return
    for update in depsgraph.updates:
        if isinstance(update.id, bpy.types.Object):
            _sync_display_size(update.id.original)


@bpy.app.handlers.persistent
def sync_all_objects(scene, depsgraph=None):
    """After frame changes (keyframed mu): every object of the scene."""
    if _is_render(depsgraph):
        return
    for ob in scene.objects:
        _sync_display_size(ob)


HANDLERS = ((bpy.app.handlers.depsgraph_update_post, sync_updated_objects),
            (bpy.app.handlers.frame_change_post, sync_all_objects))


class UnboundIFSMap(bpy.types.PropertyGroup):
    """One affine map x -> T R S x of an IFS: scale, then rotate, then move"""
    location: FloatVectorProperty(name="Location", description="Where the map moves the origin, in object units",
                                  size=3, subtype='TRANSLATION', min=-1e6, max=1e6, soft_min=-10.0, soft_max=10.0)
    rotation: FloatVectorProperty(name="Rotation", description="Rotation after the scale (XYZ Euler)", size=3,
                                  subtype='EULER')
    scale: FloatVectorProperty(name="Scale", description="Contraction along each axis; negative mirrors, and "
                               "every factor stays below 1 so the map contracts", size=3, default=(0.5, 0.5, 0.5),
                               min=-0.99, max=0.99, subtype='XYZ')


class UnboundKIFSPlane(bpy.types.PropertyGroup):
    """One fold plane of a kaleidoscopic IFS: points with normal . z < offset are reflected in it"""
    normal: FloatVectorProperty(name="Normal", description="Normal of the fold plane (any length but zero); "
                                "the fold reflects points behind it to its front", size=3, default=(1.0, 0.0, 0.0),
                                min=-1000.0, max=1000.0, soft_min=-1.0, soft_max=1.0, subtype='XYZ')
    offset: FloatProperty(name="Offset", description="The plane is normal . z = offset (times |normal|)",
                          default=0.0, min=-1000.0, max=1000.0, soft_min=-2.0, soft_max=2.0)


HYBRID_FORMULAS = [
    ('MANDELBULB', "Mandelbulb", "A Mandelbulb step with the Mandelbulb parameters", 0),
    ('MANDELBOX', "Mandelbox", "A Mandelbox step with the Mandelbox parameters", 1),
    ('KIFS', "KIFS", "A kaleidoscopic IFS step with the KIFS parameters", 2),
]


class UnboundHybridStep(bpy.types.PropertyGroup):
    """One entry of a hybrid: a formula applied Count times before the next entry's"""
    formula: EnumProperty(name="Formula", description="Which formula's step", items=HYBRID_FORMULAS,
                          default='MANDELBULB')
    count: IntProperty(name="Count", description="Steps of this formula before the next entry's", default=1,
                       min=1, max=100)


KIFS_SHAPES = [
    ('SPHERE', "Sphere", "A ball of radius Size", 0),
    ('BOX', "Box", "A cube of half-width Size", 1),
    ('TETRAHEDRON', "Tetrahedron", "The tetrahedron of vertices Size (1, 1, 1), Size (1, -1, -1), ...", 2),
    ('OCTAHEDRON', "Octahedron", "|x| + |y| + |z| <= Size", 3),
]


class UnboundObjectSettings(bpy.types.PropertyGroup):
    is_fractal: BoolProperty(name="Fractal", description="This empty is an Unbound fractal object",
                             default=False, options=set())
    kind: EnumProperty(name="Kind", description="Family of fractal", items=FRACTAL_KINDS,
                       default='QUATERNION_JULIA')
    mu: FloatVectorProperty(name="Mu", description="Constant mu of f(z) = z^2 + mu (components 1, i, j, k)",
                            size=4, default=(-0.2, 0.8, 0.0, 0.0), soft_min=-2.0, soft_max=2.0, min=-1000.0,
                            max=1000.0, step=MU_STEP, precision=4)
    theta: FloatProperty(name="Theta", description="Rotation of the complex Julia set before it is lifted "
                         "into the quaternions (the paper's eq. 5-6)", subtype='ANGLE', default=0.0,
                         soft_min=-2 * math.pi, soft_max=2 * math.pi, min=-1e6, max=1e6)
    zoom: FloatProperty(name="Zoom", description="Deep zoom: log10 of the magnification. The object's point u is "
                        "the fractal's Anchor + u 10^-Zoom, so keyframing 0 to 30 flies in at a constant speed in "
                        "scale; the iterations grow with it (the quaternion kinds 7 per unit, to zoom 60; the "
                        "Mandelbulb, Mandelbox, KIFS and hybrid by their formula's scale, in double precision to "
                        "zoom 10)",
                        default=0.0, min=0.0, max=60.0,
                        soft_max=45.0, step=10, precision=3)
    zoom_anchor: StringProperty(name="Anchor", description="Deep zoom: the point of the fractal's object space at "
                                "the object's origin, three decimal numbers 'x y z' with as many digits as the "
                                "zoom needs (Pick Anchor writes it)", default="0 0 0", maxlen=511)
    slice_offset: FloatProperty(name="K Offset", description="Position of the 3-D slice along the fourth (k) axis",
                                default=0.0, soft_min=-2.0, soft_max=2.0, min=-1000.0, max=1000.0, step=1,
                                precision=4)
    slice_rotation: FloatVectorProperty(name="Slice Rotation", description="Rotation of the slice's x, y and z "
                                        "axes toward the fourth (k) axis", size=3, subtype='EULER',
                                        default=(0.0, 0.0, 0.0))
    path_mode: EnumProperty(name="C Path", description="How c varies along a Julia stack", items=PATH_MODES,
                            default='LINE')
    c_start: FloatVectorProperty(name="C Start", description="c at the bottom of the stack (real, imaginary)",
                                 size=2, default=(-1.5, 0.0), soft_min=-2.0, soft_max=2.0, min=-1000.0, max=1000.0,
                                 step=MU_STEP, precision=4)
    c_end: FloatVectorProperty(name="C End", description="c at the top of the stack (real, imaginary)", size=2,
                               default=(0.25, 0.0), soft_min=-2.0, soft_max=2.0, min=-1000.0, max=1000.0,
                               step=MU_STEP, precision=4)
    path_curve: PointerProperty(name="Curve", description="Curve object whose shape is the path of c",
                                type=bpy.types.Object)
    stack_height: FloatProperty(name="Height", description="Height of the stack along Z in object units",
                                default=2.0, min=1e-6, max=1e6, soft_max=10.0, subtype='DISTANCE')
    cubic_component: EnumProperty(name="Component", description="Which critical orbits must stay bounded",
                                  items=CUBIC_COMPONENTS, default='BOTH')
    extent: FloatProperty(name="Extent", description="Radius of the 4-D ball the locus is cut to (C+ and C- "
                          "alone are unbounded)", default=2.0, min=1e-6, max=1000.0, soft_max=4.0)
    ifs_maps: CollectionProperty(name="Maps", description="The affine maps of the IFS", type=UnboundIFSMap)
    ifs_active_map: IntProperty(name="Active Map", description="Map shown for editing", default=0, min=0,
                                options=set())
    ifs_depth: IntProperty(name="Depth", description="Levels of the map hierarchy; the attractor is drawn as "
                           "the balls of the deepest level", default=6, min=0, max=16, soft_max=10)
    kifs_planes: CollectionProperty(name="Fold Planes", description="KIFS: the fold planes, applied in order",
                                    type=UnboundKIFSPlane)
    kifs_active_plane: IntProperty(name="Active Plane", description="Plane shown for editing", default=0, min=0,
                                   options=set())
    kifs_scale: FloatProperty(name="Scale", description="KIFS: scale s of z <- s R fold(z) - offset (s - 1), "
                              "above 1", default=2.0, min=1.0, max=10.0, soft_min=1.01, soft_max=4.0)
    kifs_offset: FloatVectorProperty(name="Offset", description="KIFS: the fixed point of the scaling", size=3,
                                     default=(1.0, 1.0, 1.0), min=-1000.0, max=1000.0, soft_min=-2.0, soft_max=2.0,
                                     subtype='XYZ')
    kifs_rotation: FloatVectorProperty(name="Rotation", description="KIFS: rotation after the folds (XYZ Euler)",
                                       size=3, min=-1e6, max=1e6, subtype='EULER')
    kifs_shape: EnumProperty(name="Shape", description="KIFS: the shape the last level is drawn as",
                             items=KIFS_SHAPES, default='TETRAHEDRON')
    kifs_size: FloatProperty(name="Size", description="KIFS: radius or half-width of the shape", default=1.0,
                             min=1e-3, max=1000.0, soft_max=2.0)
    hybrid_steps: CollectionProperty(name="Steps", description="Hybrid: the formulas applied in turn",
                                     type=UnboundHybridStep)
    hybrid_active_step: IntProperty(name="Active Step", description="Entry shown for editing", default=0, min=0,
                                    options=set())
    julia_mode: BoolProperty(name="Julia Mode", description="Mandelbulb, Mandelbox: c is the constant Julia C "
                             "(else c is the point itself: the Mandelbrot form)", default=False)
    julia_c: FloatVectorProperty(name="Julia C", description="Mandelbulb, Mandelbox: the constant c of Julia mode",
                                 size=3, subtype='XYZ', default=(0.0, 0.0, 0.0), min=-1000.0, max=1000.0,
                                 soft_min=-2.0, soft_max=2.0, step=MU_STEP, precision=4)
    power: FloatProperty(name="Power", description="Mandelbulb: triplex power n of z^n + c", default=8.0, min=2.0,
                         max=32.0, soft_max=16.0)
    box_scale: FloatProperty(name="Scale", description="Mandelbox: scale s of z <- s fold(z) + c (|s| > 1)",
                             default=2.0, min=-10.0, max=10.0, soft_min=-3.0, soft_max=3.0)
    box_fold: FloatProperty(name="Fold Limit", description="Mandelbox: coordinates beyond +-limit are reflected "
                            "back (box fold)", default=1.0, min=1e-3, max=100.0, soft_max=2.0)
    min_radius: FloatProperty(name="Min Radius", description="Mandelbox: sphere fold minimum radius (a linear "
                              "scale inside it)", default=0.5, min=1e-3, max=100.0, soft_max=2.0)
    fixed_radius: FloatProperty(name="Fixed Radius", description="Mandelbox: sphere fold fixed radius (inversion "
                                "between the radii); not below Min Radius", default=1.0, min=1e-3, max=100.0,
                                soft_max=2.0)
    max_iterations: IntProperty(name="Iterations", description="Maximum iterations of z^2 + mu per point",
                                default=16, min=1, max=10000, soft_max=200)
    bailout: FloatProperty(name="Bailout", description="Escape radius; never below the set's bounding radius",
                           default=4.0, min=1.0, max=1e6, soft_max=100.0)
    threshold_mode: EnumProperty(name="Threshold", description="How the hit threshold epsilon is chosen",
                                 items=THRESHOLD_MODES, default='PIXEL')
    detail: FloatProperty(name="Detail", description="Pixel mode: the hit threshold is the pixel footprint "
                          "divided by this", default=1.0, min=0.001, max=1000.0, soft_max=10.0)
    epsilon: FloatProperty(name="Epsilon", description="Fixed mode: hit threshold in object units",
                           default=1e-3, min=1e-7, max=1.0, precision=6, step=0.01)
    step_factor: FloatProperty(name="Step Factor", description="Fraction of the distance estimate taken per "
                               "step; below 1 is more careful", default=1.0, min=0.01, max=1.0)
    max_step: FloatProperty(name="Max Step", description="Longest step along a ray in world units, a guard "
                            "against bad estimates", default=10.0, min=1e-6, max=1e6, soft_max=100.0)
    max_steps: IntProperty(name="Max Steps", description="Most marching steps per ray", default=2000, min=1,
                           max=1000000, soft_max=20000)
    bisection_steps: IntProperty(name="Refinement", description="Bisection steps that refine each hit",
                                 default=10, min=0, max=64)
    color: FloatVectorProperty(name="Color", description="Surface colour", subtype='COLOR', size=3,
                               default=(0.8, 0.8, 0.8), min=0.0, max=1e6, soft_max=1.0)
    # The proxy of Solid, Material Preview and Wireframe shading (proxy.py)
    show_proxy: BoolProperty(name="Viewport Proxy", description="In Solid, Material Preview and Wireframe "
                             "shading draw a low-resolution surface of the fractal (the mesh Convert to Mesh "
                             "makes), built in the background", default=True)
    proxy_resolution: IntProperty(name="Resolution", description="Proxy: lattice cells across the bounding "
                                  "ball's diameter; time and triangles grow with its square", default=64, min=8,
                                  max=512, soft_max=128)
    # Shading (section 4 of the paper)
    normal_method: EnumProperty(name="Normals", description="How surface normals are approximated "
                                "(section 4.1)", items=NORMAL_METHODS, default='GRADIENT_DISTANCE')
    normal_alpha: FloatProperty(name="Alpha", description="Gradient step scale: step = alpha * t^delta, t the "
                                "distance from the eye. Too small is noisy, too large washes out detail",
                                default=1e-3, min=1e-9, max=1000.0, soft_min=1e-5, soft_max=0.1, precision=5,
                                step=0.01)
    normal_delta: FloatProperty(name="Delta", description="Depth exponent of the gradient step (Table 1): "
                                "0 constant (inverse clarity), 1 linear (even clarity), 2 quadratic "
                                "(exaggerated depth)", default=1.0, min=0.0, max=4.0, soft_max=2.0)
    reflectivity: FloatProperty(name="Reflectivity", description="Fraction of light mirrored by the surface "
                                "(needs Reflections above 0)", default=0.0, min=0.0, max=1.0, subtype='FACTOR')
    color_mode: EnumProperty(name="Coloring", description="How the surface colour is chosen",
                             items=COLOR_MODES, default='BASE')
    color_ramp_texture: PointerProperty(name="Color Ramp", description="Texture whose colour ramp colours the "
                                        "surface by orbit trap or iterations", type=bpy.types.Texture)
    ramp_scale: FloatProperty(name="Ramp Scale", description="Ramp position = value * scale + offset",
                              default=1.0, min=-1e6, max=1e6, soft_min=-10.0, soft_max=10.0)
    ramp_offset: FloatProperty(name="Ramp Offset", description="Ramp position = value * scale + offset",
                               default=0.0, min=-1e6, max=1e6, soft_min=-1.0, soft_max=1.0)
    material: PointerProperty(name="Material", description="Material of the fractal: a Principled BSDF (Base "
                              "Color, Metallic, Roughness, IOR, Emission, Alpha; Attribute nodes named "
                              "unbound_orbit_trap, unbound_iterations, ... through a Color Ramp or Map Range). "
                              "Replaces Color and Coloring", type=bpy.types.Material)


class UnboundSceneSettings(bpy.types.PropertyGroup):
    tile_size: IntProperty(name="Tile Size", description="Side of the square tiles handed to render threads",
                           default=32, min=1, max=4096, soft_min=4, soft_max=1024)
    samples: IntProperty(name="Samples", description="Anti-aliasing (and depth-of-field) samples per pixel "
                         "(stratified, the same on every machine)", default=1, min=1, max=4096, soft_max=64)
    # Lighting
    axle_light: FloatProperty(name="Axle Light", description="A light at the eye, as in the paper: every "
                              "visible point receives light. 1 lights a white surface facing the eye to 1",
                              default=1.0, min=0.0, max=1e6, soft_max=2.0)
    use_scene_lights: BoolProperty(name="Scene Lights", description="Light the fractals with the scene's "
                                   "sun, point, spot and area lights", default=True)
    ambient: FloatVectorProperty(name="Ambient", description="Ambient light, scaled by ambient occlusion",
                                 subtype='COLOR', size=3, default=(0.0, 0.0, 0.0), min=0.0, max=1e6, soft_max=1.0)
    shadows: EnumProperty(name="Shadows", description="Shadows of the scene's lights", items=SHADOW_MODES,
                          default='HARD')
    # The World as a light (world_light.py)
    use_world_light: BoolProperty(name="World Light", description="The World is the background and a light: "
                                  "every world node tree, baked by Cycles into an equirectangular map once per "
                                  "change", default=True)
    world_samples: IntProperty(name="World Samples", description="World light samples per hit and sample, each "
                               "one from the World's map and one from the surface (a World of one colour: "
                               "from the surface alone); 0: the World is only seen",
                               default=1, min=0, max=64)
    world_resolution: IntProperty(name="World Map Width", description="Width of the equirectangular map a "
                                  "non-constant World is baked into (height: half of it)", default=512, min=16,
                                  max=4096, step=2)
    world_bake_samples: IntProperty(name="World Bake Samples", description="Cycles samples per texel of the "
                                    "World's map", default=16, min=1, max=4096)
    # Light Paths (global illumination), named and limited as Cycles' Light Paths
    use_gi: BoolProperty(name="Global Illumination", description="Path tracing: light bounces off every "
                         "surface (the fractals, the sea), so surfaces light each other and colours bleed; "
                         "the ambient term is off", default=False)
    max_bounces: IntProperty(name="Total", description="Bounces of a path in all", default=12, min=0, max=1024,
                             soft_max=32)
    diffuse_bounces: IntProperty(name="Diffuse", description="Diffuse bounces of a path", default=4, min=0,
                                 max=1024, soft_max=32)
    glossy_bounces: IntProperty(name="Glossy", description="Glossy bounces of a path: a material's specular "
                                "lobe and mirror reflections (with Global Illumination, instead of "
                                "Reflections)", default=4, min=0, max=1024, soft_max=32)
    # Effects
    ao_strength: FloatProperty(name="AO Strength", description="Strength of the occlusion estimated from "
                               "the distance estimate (0: off)", default=0.0, min=0.0, max=1.0, subtype='FACTOR')
    ao_distance: FloatProperty(name="AO Distance", description="Distance of the farthest occlusion sample",
                               default=0.5, min=1e-6, max=1e6, soft_max=10.0, subtype='DISTANCE')
    ao_samples: IntProperty(name="AO Samples", description="Occlusion samples along the normal", default=5,
                            min=1, max=32)
    reflection_depth: IntProperty(name="Reflections", description="Mirror bounces of reflective "
                                  "surfaces (0: off)", default=0, min=0, max=16)
    fog_density: FloatProperty(name="Fog Density", description="Depth cue: colour fades toward the fog colour "
                               "as 1 - exp(-density * distance) (0: off)", default=0.0, min=0.0, max=1e6,
                               soft_max=1.0, precision=4)
    fog_use_world: BoolProperty(name="World Color Fog", description="Fade toward the world's colour",
                                default=True)
    fog_color: FloatVectorProperty(name="Fog Color", description="Colour distant surfaces fade toward",
                                   subtype='COLOR', size=3, default=(0.5, 0.5, 0.5), min=0.0, max=1e6,
                                   soft_max=1.0)
    glow_strength: FloatProperty(name="Glow", description="Glow from the marching steps: rays that pass close "
                                 "to the set take many steps (0: off)", default=0.0, min=0.0, max=1e6,
                                 soft_max=2.0)
    glow_color: FloatVectorProperty(name="Glow Color", description="Colour of the glow", subtype='COLOR', size=3,
                                    default=(0.4, 0.6, 1.0), min=0.0, max=1e6, soft_max=1.0)
    # The sea of Fig. 5
    use_sea: BoolProperty(name="Sea", description="A reflective ground plane whose waves are a periodic "
                          "function of the distance to the fractals (the paper's Fig. 5)", default=False)
    sea_height: FloatProperty(name="Height", description="Height of the sea plane (world Z)", default=-1.0,
                              min=-1e9, max=1e9, soft_min=-10.0, soft_max=10.0, subtype='DISTANCE')
    sea_wavelength: FloatProperty(name="Wavelength", description="Distance between wave crests",
                                  default=0.25, min=1e-6, max=1e9, soft_max=10.0, subtype='DISTANCE')
    sea_amplitude: FloatProperty(name="Amplitude", description="Height of the waves", default=0.01, min=0.0,
                                 max=1e9, soft_max=1.0, subtype='DISTANCE', precision=4)
    sea_color: FloatVectorProperty(name="Color", description="Colour of the sea", subtype='COLOR', size=3,
                                   default=(0.1, 0.25, 0.4), min=0.0, max=1e6, soft_max=1.0)
    sea_reflectivity: FloatProperty(name="Reflectivity", description="Fraction of light the sea mirrors "
                                    "(needs Reflections above 0)", default=0.5, min=0.0, max=1.0, subtype='FACTOR')
    simd: EnumProperty(name="SIMD", description="Vector instruction set of the marching kernel",
                       items=SIMD_MODES, default='AUTO')
    # The Rendered viewport (progressive refinement, section 7.1 of the paper)
    viewport_start_divisor: EnumProperty(name="Start Resolution", description="Resolution of the viewport's "
                                         "first image after a change; each refinement doubles it up to full",
                                         items=VIEWPORT_DIVISORS, default='8')
    viewport_samples: IntProperty(name="Viewport Samples", description="Anti-aliasing samples per pixel in "
                                  "the viewport, added one at a time after full resolution", default=1, min=1,
                                  max=4096, soft_max=64)
    viewport_time_limit: FloatProperty(name="Time Limit", description="Stop refining the viewport after this "
                                       "many seconds (0: no limit)", default=0.0, min=0.0, max=86400.0,
                                       soft_max=60.0, unit='TIME_ABSOLUTE')


UnboundViewLayerSettings = type("UnboundViewLayerSettings", (bpy.types.PropertyGroup,), {
    "__annotations__": {toggle: BoolProperty(name=label, description=description, default=False)
                        for toggle, label, description in passes.toggles()},
    "__doc__": "Which of Unbound's passes this view layer writes",
})

classes = (UnboundIFSMap, UnboundKIFSPlane, UnboundHybridStep, UnboundObjectSettings, UnboundSceneSettings, UnboundViewLayerSettings)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.unbound = PointerProperty(type=UnboundObjectSettings, name="Unbound",
                                               description="Unbound fractal settings")
    bpy.types.Scene.unbound = PointerProperty(type=UnboundSceneSettings, name="Unbound",
                                              description="Unbound render settings")
    bpy.types.ViewLayer.unbound = PointerProperty(type=UnboundViewLayerSettings, name="Unbound",
                                                  description="Unbound passes")
    for handlers, handler in HANDLERS:
        handlers.append(handler)


def unregister():
    for handlers, handler in HANDLERS:
        if handler in handlers:
            handlers.remove(handler)
    del bpy.types.ViewLayer.unbound
    del bpy.types.Scene.unbound
    del bpy.types.Object.unbound
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
