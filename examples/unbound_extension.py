"""What the examples share, under the PyPI bpy module and inside Blender alike (`blender -b
--python examples/<name>.py`): their own arguments, the Unbound extension (enabled, or installed
from the built zip), and a new scene with Unbound, a world colour and a camera."""
import atexit
import glob
import os
import sys

# Debian/Ubuntu packages of the X11/GL libraries bpy links even in background mode (libxt6 is
# libxt6t64 on Debian 13 and Ubuntu 24.04); tools/check_system.sh checks and installs them.
BPY_LIBRARIES = ("libx11-6 libxext6 libxrender1 libxi6 libxfixes3 libxkbcommon0 libsm6 libice6 libxxf86vm1 "
                 "libxt6 libgl1 libegl1")


def bpy_import_failed(err, script=None):
    """The message for an `import bpy` that raised err: the real error, and the likely fix."""
    script = script or os.path.basename(sys.argv[0]) or "unbound"
    py = "Python %d.%d (%s)" % (sys.version_info[0], sys.version_info[1], sys.executable)
    if isinstance(err, ModuleNotFoundError) and err.name == "bpy":
        return ("%s: no bpy module in %s.\n"
                "Run me in Blender (blender --background --python %s -- ...), or with the bpy module:\n"
                "`make demo` in the repository builds .venv with it (then .venv/bin/python %s), or\n"
                "pip install bpy==4.2.23 (Python 3.11 only) / bpy==5.2.3 (Python 3.13 only)."
                % (script, py, sys.argv[0], sys.argv[0]))
    text = "%s: %s" % (type(err).__name__, err)
    if "cannot open shared object file" in str(err):
        hint = ("bpy links X11/GL libraries even in background mode and one is missing. In the repository,\n"
                "`sh tools/check_system.sh` names (or, as root, installs) them; on Debian/Ubuntu:\n"
                "sudo apt-get install %s" % BPY_LIBRARIES)
    elif isinstance(err, ModuleNotFoundError):
        hint = "bpy needs the module %r: pip install -r requirements-dev.txt (or make venv)" % err.name
    else:
        hint = "bpy is installed for this Python but fails to load (see the error above)"
    return "%s: bpy is installed but `import bpy` failed in %s:\n    %s\n%s" % (script, py, text, hint)


try:
    import bpy
except ImportError as _err:
    sys.exit(bpy_import_failed(_err))

HERE = os.path.dirname(os.path.abspath(__file__))
ENGINE_ID = "UNBOUND"


def script_args(argv=None):
    """The script's own arguments: those after `--` (Blender passes its own argv), else with the
    bpy module everything after the script name."""
    argv = sys.argv if argv is None else argv
    if "--" in argv:
        return argv[argv.index("--") + 1:]
    if bpy.app.binary_path:  # inside Blender: the rest of argv is Blender's
        return []
    return argv[1:]


def enabled_unbound():
    """Module name of an enabled Unbound extension (bl_ext.<repository>.unbound), or None."""
    return next((m for m in bpy.context.preferences.addons.keys()
                 if m.startswith("bl_ext.") and m.endswith(".unbound")), None)


def default_zip():
    zips = sorted(glob.glob(os.path.join(HERE, os.pardir, "dist", "unbound-*.zip")))
    return zips[-1] if zips else None


def ensure_extension(zip_path=None, prog="unbound"):
    """Use the enabled Unbound extension, else install and enable the zip. Returns its module name."""
    module = enabled_unbound()
    if module is None:
        zip_path = zip_path or default_zip()
        if not zip_path or not os.path.isfile(zip_path):
            sys.exit("%s: Unbound is not enabled and there is no extension zip to install "
                     "(build one with `make extension`, or pass --extension PATH)" % prog)
        result = bpy.ops.extensions.package_install_files(filepath=os.path.abspath(zip_path),
                                                          repo='user_default', enable_on_install=True)
        module = enabled_unbound()
        if result != {'FINISHED'} or module is None:
            sys.exit("%s: could not install and enable %s" % (prog, zip_path))
        print("%s: installed %s as %s" % (prog, zip_path, module))
    if not bpy.app.binary_path:  # the bpy module, not Blender
        atexit.register(_release_addon, module)
    return module


def _release_addon(module):
    """bpy module only: bpy 4.2/4.5 crash or hang at exit while an add-on with a RenderEngine is
    still registered, so unregister it while Python still runs (without saving preferences)."""
    import addon_utils
    if module in bpy.context.preferences.addons:
        addon_utils.disable(module, default_set=False)


def new_scene(width, height, world_color, percentage=100):
    """An empty scene rendered by Unbound at width x height, with the Standard view transform (the
    PNGs hold the rendered colours) and a world of one colour (the background)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    r = scene.render
    r.engine = ENGINE_ID
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, percentage
    scene.view_settings.view_transform = 'Standard'
    world = bpy.data.worlds.new("Backdrop")
    world.color = world_color
    if world.node_tree:  # 5.x worlds always use nodes: the engine reads the Background node
        bg = next((n for n in world.node_tree.nodes if n.type == 'BACKGROUND'), None)
        if bg is not None:
            bg.inputs["Color"].default_value = (*world.color, 1.0)
            bg.inputs["Strength"].default_value = 1.0
    scene.world = world
    return scene


def add_camera(scene, location, target, lens):
    """The scene's camera at `location`, looking at `target`, with a `lens` mm focal length."""
    from mathutils import Vector
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = lens
    scene.collection.objects.link(cam)
    cam.location = location
    cam.rotation_euler = (Vector(target) - Vector(location)).to_track_quat('-Z', 'Y').to_euler()
    scene.camera = cam
    return cam


def set_png_format(scene):
    """8-bit RGB PNG output (4.x and 5.x image settings alike)."""
    ims = scene.render.image_settings
    if bpy.app.version >= (5, 0, 0):
        ims.media_type = 'IMAGE'
    ims.file_format = 'PNG'
    ims.color_mode, ims.color_depth = 'RGB', '8'
