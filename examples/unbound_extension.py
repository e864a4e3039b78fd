"""What the examples share: find the enabled Unbound extension or install the built zip, under
the PyPI bpy module and inside Blender alike (`blender -b --python examples/<name>.py`)."""
import atexit
import glob
import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))


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
