"""Blender-side tests run bpy scripts in fresh subprocesses: bpy's state is per process, and each
test installs the built extension zip into its own BLENDER_USER_RESOURCES, as a user would."""
import json
import os
import pathlib
import subprocess
import sys
import textwrap

import pytest
from exr import extension_zip

HERE = pathlib.Path(__file__).resolve().parent


@pytest.fixture
def run_bpy(tmp_path):
    """run_bpy(code, timeout=300) -> dict reported by the script via bpy_session.report(...).
    The code runs after `import bpy_session as S` with the extension installed as `mod`."""

    def run(code, timeout=300, install=True, python=None, env=None, expect_rc=0):
        user = tmp_path / "user"
        (user / "config").mkdir(parents=True, exist_ok=True)
        header = "import os\nimport sys\nsys.path.insert(0, %r)\nimport bpy_session as S\nimport bpy\n" % str(HERE)
        if install:
            header += "mod = S.install_extension(%r)\n" % str(extension_zip())
        script = tmp_path / "script.py"
        script.write_text(header + textwrap.dedent(code))
        full_env = dict(os.environ, BLENDER_USER_RESOURCES=str(user), UNBOUND_TEST_TMP=str(tmp_path))
        full_env.update(env or {})
        proc = subprocess.run([python or sys.executable, str(script)], cwd=tmp_path, env=full_env,
                              capture_output=True, text=True, timeout=timeout)
        out = proc.stdout + proc.stderr
        assert proc.returncode == expect_rc, "bpy script failed (rc %d):\n%s" % (proc.returncode, out[-6000:])
        results = [line for line in proc.stdout.splitlines() if line.startswith("UNBOUND_RESULT ")]
        value = json.loads(results[-1][len("UNBOUND_RESULT "):]) if results else {}
        value["_output"] = out
        return value

    return run
