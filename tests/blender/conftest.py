"""Blender-side tests run bpy scripts in fresh subprocesses: bpy's state is per process, and each
test installs the built extension zip into its own BLENDER_USER_RESOURCES, as a user would.
The scripts are functions in bpy_scripts/ (see there); bpy_main.py runs one."""
import ast
import json
import os
import pathlib
import subprocess
import sys

import pytest
from exr import extension_zip

HERE = pathlib.Path(__file__).resolve().parent
SCRIPTS = HERE / "bpy_scripts"

# The scripts import bpy: never collected (nor imported) by pytest.
collect_ignore = ["bpy_scripts"]


def check_script(ref, args):
    """Fails at once, in this process, on a reference to no function or on arguments the function
    does not take or that JSON does not carry (bpy_scripts are parsed here, never imported)."""
    module, _, name = ref.rpartition(".")
    path = SCRIPTS / (module.replace(".", "/") + ".py")
    assert module and path.is_file(), "no script module %s (%s)" % (module, path)
    functions = {f.name: f for f in ast.parse(path.read_text()).body if isinstance(f, ast.FunctionDef)}
    assert name in functions, "no function %s in %s" % (name, path)
    params = functions[name].args
    names = [a.arg for a in params.posonlyargs + params.args + params.kwonlyargs]
    assert names[:2] == ["S", "mod"], "%s must take (S, mod, ...): %s" % (ref, names)
    unknown = set(args) - set(names[2:])
    assert params.kwarg or not unknown, "%s takes no argument %s" % (ref, sorted(unknown))
    positional = params.posonlyargs + params.args
    required = [a.arg for a in positional[2:len(positional) - len(params.defaults)]]
    required += [a.arg for a, d in zip(params.kwonlyargs, params.kw_defaults) if d is None]
    missing = set(required) - set(args)
    assert not missing, "%s needs the arguments %s" % (ref, sorted(missing))
    text = json.dumps(args)
    assert json.loads(text) == as_lists(args), "arguments JSON would change: %r" % (args,)
    return text


def erode(mask, n):
    """mask less the pixels within n steps (4-neighbours) of a False pixel; the image's border is
    no such pixel."""
    for _ in range(n):
        m = mask.copy()
        m[1:] &= mask[:-1]
        m[:-1] &= mask[1:]
        m[:, 1:] &= mask[:, :-1]
        m[:, :-1] &= mask[:, 1:]
        mask = m
    return mask


def as_lists(value):
    """value as JSON gives it back: tuples as lists (the scripts receive lists)."""
    if isinstance(value, (list, tuple)):
        return [as_lists(v) for v in value]
    if isinstance(value, dict):
        return {k: as_lists(v) for k, v in value.items()}
    return value


@pytest.fixture
def run_bpy(tmp_path):
    """run_bpy("module.function", args={...}, timeout=300) -> dict reported by the script via
    bpy_session.report(...), plus "_output" (stdout + stderr). Runs
    bpy_scripts.module.function(S, mod, **args) in a fresh bpy process with the extension installed
    as `mod` (install=False: not installed, mod None); args go as JSON (tuples arrive as lists)."""

    def run(ref, args=None, timeout=300, install=True, python=None, env=None, expect_rc=0):
        user = tmp_path / "user"
        (user / "config").mkdir(parents=True, exist_ok=True)
        cmd = [python or sys.executable, str(HERE / "bpy_main.py"), ref, check_script(ref, args or {}),
               str(extension_zip()) if install else ""]
        full_env = dict(os.environ, BLENDER_USER_RESOURCES=str(user), UNBOUND_TEST_TMP=str(tmp_path))
        full_env.update(env or {})
        proc = subprocess.run(cmd, cwd=tmp_path, env=full_env, capture_output=True, text=True, timeout=timeout)
        out = proc.stdout + proc.stderr
        assert proc.returncode == expect_rc, "bpy script failed (rc %d):\n%s" % (proc.returncode, out[-6000:])
        results = [line for line in proc.stdout.splitlines() if line.startswith("UNBOUND_RESULT ")]
        value = json.loads(results[-1][len("UNBOUND_RESULT "):]) if results else {}
        value["_output"] = out
        return value

    return run
