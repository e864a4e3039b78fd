"""Render a gallery of Unbound's bundled fractal presets: one PNG per preset, each in a scene of its
own (a camera that frames the preset, a sun where it helps), through Blender's pipeline.

The same script runs unchanged in Blender and with the bpy module:

    blender --background --python examples/gallery.py -- [options]
    python examples/gallery.py [options]           # bpy from PyPI, e.g. make venv

Options (after `--` in Blender; `--` is optional with python):
    --out DIR               where the PNG files go (default ./docs/gallery)
    --size W H              image size in pixels (default 480 360)
    --only NAME [NAME ...]  render only these presets (file names without .py, e.g. basilica)
    --extension PATH        the extension zip to install when Unbound is not enabled
                            (default: $UNBOUND_EXTENSION, else dist/unbound-*.zip of this repository)

Each preset is applied as the Fractal Presets menu applies it (script.execute_preset with the
fractal object active), so the gallery shows the presets' own settings: mu, theta, iterations,
normals, colour, samples, shadows, ambient occlusion, reflections, fog and the sea. The script adds
only what a preset does not hold: the camera, the world colour, a sun, the Standard view
transform (so that the PNG colours are the rendered values, not a tone-mapped version of them) and,
for the presets in MATERIALS, a Principled material.
Presets this script has no view for (a preset added later) get a default three-quarter view.

The extension is found or installed as examples/animate_mu.py does: the enabled Unbound if there
is one, else the zip installed into the "user_default" extension repository of the Blender user
folder. Point BLENDER_USER_RESOURCES at another folder to keep your own Blender's folder untouched
(the Makefile's gallery target sets it to a folder under build/):

    BLENDER_USER_RESOURCES=build/blender-user python examples/gallery.py
"""
import argparse
import glob
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)  # Blender's --python does not put the script's folder on the path
# unbound_extension imports bpy first; where that fails it exits with the real error and the fix.
from unbound_extension import add_camera, ensure_extension, new_scene, script_args, set_png_format  # noqa: E402
import bpy  # noqa: E402

PRESET_MENU = "UNBOUND_MT_fractal_presets"
LOOK_MENU = "UNBOUND_MT_look_presets"
# The look preset (the scene's shading: Render tab, Unbound panel's header) each fractal preset is
# shown with; a fractal preset holds the object's parameters only.
LOOKS = {"basilica": "axle_light", "douady_rabbit": "axle_light", "siegel_disk": "axle_light",
         "fig_5_dendrite_in_the_sea": "fig_5_sea", "fig_6_surface_close-up": "fig_6_close-up_fog",
         "fig_7_theta_110": "fine_occlusion", "quaternion_twist": "fine_occlusion",
         "mandelbulb_power_8": "path_traced"}
DEFAULT_LOOK = "ambient_occlusion"
# A Principled BSDF (Object.unbound.material) for the presets shown physically lit: the path_traced
# look (global illumination, the World as a light, no axle light) and a metal that mirrors the sky.
MATERIALS = {"mandelbulb_power_8": dict(base_color=(0.9, 0.62, 0.35), metallic=1.0, roughness=0.35)}

# Per preset (file name without .py): the camera (location, target, focal length in mm), the sun
# (the direction it shines toward and its strength in W/m^2, as in Cycles; None: no sun) and the
# world colour, which is the background. Object space maps to the quaternions as x -> 1, y -> i,
# z -> j: a complex Julia set lies in the x-y plane (Blender's ground plane) and its quaternion
# slice swells out of it along z. The presets light the surface from the eye (the paper's axle
# light, at full strength), so each sun comes from the side of the view, where it models the
# surface and casts shadows instead of adding to what the axle light already lights.
DARK = (0.02, 0.025, 0.04)
SIDE_SUN = ((0.57, -0.3, -0.77), 2.0)  # from the upper left of a camera at the front left
DEFAULT_VIEW = dict(camera=((-1.75, -3.3, 2.6), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK)
VIEWS = {
    # The paper's Fig. 5: mu = i, a dendrite, standing in the reflecting sea; a wide view across
    # the water under a light sky.
    "fig_5_dendrite_in_the_sea": dict(camera=((-1.2, -4.6, 0.55), (0.0, 0.0, -0.1), 35.0),
                                      sun=((0.6, 0.45, -0.65), 3.0), world=(0.25, 0.33, 0.5)),
    # Fig. 6: a valley in the surface of mu = -0.2 + 0.8i; the nearest surface is 0.45 from the eye.
    "fig_6_surface_close-up": dict(camera=((-0.45, -0.62, 0.55), (0.3, -0.3, -0.2), 35.0),
                                   sun=((0.6, 0.1, -0.8), 2.0), world=DARK),
    # Fig. 7: mu = -0.2 + 0.8i turned by theta = 110 degrees before the lift; a closer view.
    "fig_7_theta_110": dict(camera=((0.7, -3.5, 1.9), (0.0, -0.1, 0.0), 55.0), sun=SIDE_SUN, world=DARK),
    # The well-known complex Julia sets lifted into the quaternions: three-quarter views.
    "basilica": dict(camera=((-1.0, -4.0, 2.4), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    "siegel_disk": dict(camera=((-1.75, -3.3, 2.6), (0.0, 0.0, -0.15), 50.0), sun=SIDE_SUN, world=DARK),
    # Section 5's families. Julia stacks stand 2 units tall on the complex plane (x, y); c runs up Z.
    "julia_stack_fig_4": dict(camera=((-3.2, -5.2, 3.0), (0.0, 0.0, -0.1), 50.0), sun=SIDE_SUN, world=DARK),
    "julia_stack_rabbit_to_dendrite": dict(camera=((-3.0, -4.6, 2.8), (0.0, 0.0, -0.1), 50.0), sun=SIDE_SUN,
                                           world=DARK),
    # The cubic locus: (Re a, Im a, Re b) at Im b = 0, cut to |(a, b)| <= extent.
    "cubic_connectedness_locus": dict(camera=((-2.2, -3.4, 2.0), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    "cubic_locus_c_plus": dict(camera=((-2.6, -4.0, 2.4), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    # Physically lit (MATERIALS): the light sky is the World light, the sun from the side.
    "mandelbulb_power_8": dict(camera=((-1.75, -3.3, 2.6), (0.0, 0.0, 0.0), 50.0), sun=((0.57, -0.3, -0.77), 3.0),
                               world=(0.35, 0.42, 0.55)),
    "quaternion_mandelbrot": dict(camera=((-1.0, -4.8, 2.5), (-0.6, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    # IFS attractors in the cube [-1, 1]^3 (the Koch curve spans X, its spikes rise along Z and Y).
    "sierpinski_tetrahedron": dict(camera=((-2.4, -4.2, 1.9), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    "menger_sponge": dict(camera=((-3.0, -4.4, 2.9), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    "koch_curve": dict(camera=((0.4, -2.9, 1.3), (0.0, 0.0, 0.15), 50.0), sun=SIDE_SUN, world=DARK),
    # The community's formulas (issue 22): the Mandelbox at scale 2 fills a cube of half-width
    # about 1.1, at scale -1.5 about 0.9; the KIFS Menger sponges the cube [-1, 1]^3.
    "mandelbox_scale_2": dict(camera=((-2.6, -4.9, 3.9), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    "mandelbox_scale_minus_1_5": dict(camera=((-1.7, -3.2, 2.5), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    "kifs_menger_sponge": dict(camera=((-2.3, -4.3, 3.4), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
    "kifs_twisted_menger": dict(camera=((-2.4, -4.5, 3.6), (0.0, 0.0, 0.0), 50.0), sun=SIDE_SUN, world=DARK),
}


# -- arguments -------------------------------------------------------------------------------------

def parse_args(args):
    p = argparse.ArgumentParser(prog="gallery.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=os.path.join("docs", "gallery"), help="output folder")
    p.add_argument("--size", nargs=2, type=int, default=(480, 360), metavar=("W", "H"))
    p.add_argument("--only", nargs="+", default=None, metavar="NAME", help="render only these presets")
    p.add_argument("--extension", default=os.environ.get("UNBOUND_EXTENSION"),
                   help="extension zip to install if Unbound is not enabled")
    a = p.parse_args(args)
    if min(a.size) < 1:
        p.error("--size: at least 1 x 1 pixels")
    return a


def bundled_presets(module):
    """{name: path} of the presets shipped with the extension, in file-name order."""
    folder = sys.modules[module].operators.BUNDLED_PRESETS
    return {os.path.splitext(os.path.basename(f))[0]: f
            for f in sorted(glob.glob(os.path.join(folder, "*.py")))}


# -- the scene -------------------------------------------------------------------------------------

def build_scene(preset, view, width, height):
    """A new empty scene for one preset: camera, world, sun, a fractal object with the preset
    applied. Returns (scene, fractal object)."""
    from mathutils import Vector
    scene = new_scene(width, height, view["world"])
    cam = add_camera(scene, *view["camera"])
    cam.data.clip_start = 0.01

    if view["sun"] is not None:
        direction, strength = view["sun"]
        sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
        sun.data.energy = strength          # W/m^2, as in Cycles
        sun.data.angle = math.radians(1.0)  # used by soft shadows only
        sun.rotation_euler = Vector(direction).to_track_quat('-Z', 'Y').to_euler()
        scene.collection.objects.link(sun)

    bpy.ops.object.unbound_fractal_add(use_cursor=False)
    ob = bpy.context.object
    ob.name = os.path.splitext(os.path.basename(preset))[0]
    # As the Fractal Presets menu does: the preset script runs with the fractal object active.
    result = bpy.ops.script.execute_preset(filepath=preset, menu_idname=PRESET_MENU)
    if result != {'FINISHED'}:
        sys.exit("gallery: could not apply the preset %s" % preset)
    # ...and the look preset it is shown with, as the Look Presets popover applies it.
    folder = os.path.join(os.path.dirname(os.path.dirname(preset)), "look")
    look = os.path.join(folder, LOOKS.get(os.path.splitext(os.path.basename(preset))[0], DEFAULT_LOOK) + ".py")
    if bpy.ops.script.execute_preset(filepath=look, menu_idname=LOOK_MENU) != {'FINISHED'}:
        sys.exit("gallery: could not apply the look preset %s" % look)
    if ob.name in MATERIALS:
        ob.unbound.material = principled_material(ob.name, **MATERIALS[ob.name])
    return scene, ob


def principled_material(name, base_color, metallic, roughness):
    """A material whose output is a Principled BSDF with these inputs (the rest Blender's defaults)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = next(n for n in mat.node_tree.nodes if n.type == 'BSDF_PRINCIPLED')
    bsdf.inputs["Base Color"].default_value = (*base_color, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    return mat


def render_png(scene, path):
    """F12 through Blender's pipeline, saved as an 8-bit RGB PNG."""
    set_png_format(scene)
    scene.render.image_settings.compression = 100
    scene.render.filepath = path
    scene.render.use_file_extension = False
    if os.path.isfile(path):  # so that a file from an earlier run cannot pass for this one's
        os.remove(path)
    bpy.ops.render.render(write_still=True)
    if not os.path.isfile(path):
        sys.exit("gallery: the render wrote no %s (see Blender's messages above)" % path)


def describe(ob):
    u = ob.unbound
    if u.kind == 'JULIA_STACK':
        return "Julia stack, c from %s to %s" % (tuple(round(c, 4) for c in u.c_start), tuple(round(c, 4) for c in u.c_end))
    if u.kind == 'CUBIC_LOCUS':
        return "cubic connectedness locus, %s, extent %g" % (u.cubic_component, u.extent)
    if u.kind == 'IFS':
        return "IFS of %d maps, depth %d" % (len(u.ifs_maps), u.ifs_depth)
    if u.kind == 'QUATERNION_MANDELBROT':
        return "quaternion Mandelbrot slice"
    return "mu = (%s), theta = %.0f deg" % (", ".join("%g" % round(c, 4) for c in u.mu), math.degrees(u.theta))


def main(argv=None):
    a = parse_args(script_args(argv))
    started = time.perf_counter()
    module = ensure_extension(a.extension, prog='gallery')
    presets = bundled_presets(module)
    if a.only:
        unknown = sorted(set(a.only) - set(presets))
        if unknown:
            sys.exit("gallery: no bundled preset %s (there are: %s)" % (", ".join(unknown), ", ".join(presets)))
        presets = {name: path for name, path in presets.items() if name in a.only}
    out = os.path.abspath(a.out)
    os.makedirs(out, exist_ok=True)
    written = []
    for name, preset in presets.items():
        t0 = time.perf_counter()
        scene, ob = build_scene(preset, VIEWS.get(name, DEFAULT_VIEW), a.size[0], a.size[1])
        path = os.path.join(out, name + ".png")
        render_png(scene, path)
        print(path)
        print("gallery: %s: %s, %d samples, %.1f s" % (name, describe(ob), scene.unbound.samples,
                                                        time.perf_counter() - t0))
        written.append(path)
    print("gallery: %d presets (%d x %d px) in %s, %.1f s"
          % (len(written), a.size[0], a.size[1], out, time.perf_counter() - started))
    return written


if __name__ == "__main__":
    main()
