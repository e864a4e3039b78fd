"""The bpy subprocess that conftest.run_bpy starts (a fresh process and BLENDER_USER_RESOURCES per
call):  python bpy_main.py MODULE.FUNCTION ARGS_JSON [EXTENSION_ZIP]

Imports bpy and bpy_session, installs the extension zip the way Blender does (when one is given),
then imports bpy_scripts.MODULE and calls FUNCTION(S, mod, **ARGS): S is bpy_session, mod the
installed add-on's package (None without a zip). The function hands its results back with
S.report(...)."""
import importlib
import json
import sys

import bpy_session as S  # this folder is sys.path[0]; bpy_session imports bpy


def main(argv):
    ref, args = argv[1], json.loads(argv[2])
    mod = S.install_extension(argv[3]) if len(argv) > 3 and argv[3] else None
    module, name = ref.rsplit(".", 1)
    function = getattr(importlib.import_module("bpy_scripts." + module), name)
    function(S, mod, **args)


if __name__ == "__main__":
    main(sys.argv)
