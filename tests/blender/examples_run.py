"""Runs an example script as a user runs it: `python examples/<name>.py ...` with the bpy module, in a
fresh process with its own Blender user folder (BLENDER_USER_RESOURCES), the built extension zip
installed by the example itself."""
import os
import subprocess

from exr import extension_zip


def start_example(cmd, workdir):
    """Starts the example in workdir with its own Blender user folder; returns the Popen."""
    user = workdir / "user"
    (user / "config").mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user), UNBOUND_EXTENSION=str(extension_zip()))
    return subprocess.Popen(cmd, cwd=workdir, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


def finish(proc, timeout=240):
    """The example's output, once it has ended with rc 0 (else the test fails with its output)."""
    out, _ = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, "example failed (rc %d):\n%s" % (proc.returncode, out[-6000:])
    return out
