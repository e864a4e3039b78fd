"""The bpy scripts of the Blender tests (bpy_scripts/, run by conftest.run_bpy): every reference a
test makes resolves to a function taking (S, mod, ...), every function is used, bad references
and arguments fail in the pytest process before any bpy starts, and pytest never imports them."""
import ast
import sys

import pytest
from conftest import HERE, SCRIPTS, check_script


def references():
    """(test file, "module.function", argument names) of every run_bpy call with a literal reference."""
    found = []
    for path in sorted(HERE.glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "run_bpy":
                ref = node.args[0]
                assert isinstance(ref, ast.Constant) and isinstance(ref.value, str), \
                    "%s:%d: run_bpy takes a literal \"module.function\"" % (path.name, node.lineno)
                found.append((path.name, ref.value))
    return found


def script_functions():
    return {"%s.%s" % (path.stem, f.name)
            for path in SCRIPTS.glob("*.py") if path.name != "__init__.py"
            for f in ast.parse(path.read_text()).body
            if isinstance(f, ast.FunctionDef) and [a.arg for a in f.args.args[:2]] == ["S", "mod"]}


def test_every_reference_resolves_and_every_script_is_used():
    refs = references()
    assert len(refs) > 20, refs  # the scan finds them
    functions = script_functions()
    assert {ref for _, ref in refs} <= functions, sorted({ref for _, ref in refs} - functions)
    assert functions <= {ref for _, ref in refs}, "unused scripts: %s" % sorted(functions - {r for _, r in refs})


@pytest.mark.parametrize("ref, args, message", [
    ("engine.no_such_script", {}, "no function no_such_script"),
    ("no_such_module.passes_reach_compositor_and_exr", {}, "no script module no_such_module"),
    ("engine.threads_setting_honoured", {"case": 1}, "takes no argument ['case']"),
    ("camera_exactness.unbound_matches_cycles", {"case": []}, "needs the arguments ['band']"),
    ("camera_exactness.unbound_matches_cycles", {"case": {1: 2}, "band": 0.1}, "arguments JSON would change"),
    ("camera_exactness.unbound_matches_cycles", {"case": object(), "band": 0.1}, "not JSON serializable"),
])
def test_bad_references_and_arguments_fail_before_bpy_starts(ref, args, message):
    with pytest.raises((AssertionError, TypeError)) as info:
        check_script(ref, args)
    assert message in str(info.value), str(info.value)


def test_tuples_arrive_as_lists():
    assert check_script("camera_exactness.unbound_matches_cycles", {"case": ((1, 2), {}), "band": 1e-3}) == \
        '{"case": [[1, 2], {}], "band": 0.001}'


def test_pytest_never_imports_the_scripts():
    assert not [name for name in sys.modules if name == "bpy_scripts" or name.startswith("bpy_scripts.")]
    assert "bpy_main" not in sys.modules and "bpy_session" not in sys.modules
