"""A private Blender user directory for a bench's Blender (bpy) process: set before bpy starts,
so that installing the extension under test touches no one else's Blender, and removed when the
process exits (about 15 MB each once an extension is installed; the benches used to leave them in
the temporary folder)."""
import atexit
import os
import pathlib
import shutil
import tempfile


def private_user_directory():
    """Makes the directory, points BLENDER_USER_RESOURCES at it and returns its path. Call before
    `import bpy`."""
    user = pathlib.Path(tempfile.mkdtemp(prefix="unbound-bench-user-"))
    atexit.register(shutil.rmtree, user, True)
    (user / "config").mkdir()
    os.environ["BLENDER_USER_RESOURCES"] = str(user)
    return user
