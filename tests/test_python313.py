"""The newest Blender: Python 3.13 and bpy 5.2 inside the Debian trixie chroot of tools/py313.sh.
The abi3 wheel built here (Python 3.11) must load and pass the native suite's platform checks there
(tests/native/conftest.py: the float64 references of the geometry run under 3.11 only), and the
extension must pass the engine suite against bpy 5.2 (new compositor API, multi-part EXR)."""
import glob
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="the trixie chroot needs root (CI runs as root)")


@pytest.fixture(scope="module")
def chroot():
    """Runs a shell script in the Python 3.13 / bpy 5.2 chroot, set up once for the module."""
    setup = subprocess.run(["sh", "tools/py313.sh", "setup", "--bpy"], cwd=ROOT, capture_output=True, text=True,
                           timeout=1500)
    assert setup.returncode == 0, setup.stderr[-3000:]
    return run_in_chroot


def run_in_chroot(script, timeout=1200):
    return subprocess.run(["sh", "tools/py313.sh", "run", "sh", "-c", script], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout)


def test_native_suite_under_python313(chroot):
    wheels = sorted(glob.glob(str(ROOT / "dist" / "unbound_core-*-cp311-abi3-*.whl")))
    assert wheels, "build the wheel first (make wheel)"
    wheel = os.path.relpath(wheels[-1], ROOT)
    run = chroot(f"/opt/venv/bin/pip install -q --no-index --force-reinstall --no-deps {wheel} && "
                 "/opt/venv/bin/python tests/python313_probe.py core && "
                 "/opt/venv/bin/pip uninstall -q -y unbound-core && "
                 "/opt/venv/bin/python -m pytest -q -p no:cacheprovider tests/native --platform-checks")
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert "3.13" in run.stdout and "abi3" in run.stdout
    assert " passed" in run.stdout and "failed" not in run.stdout


def test_engine_suite_under_bpy52(chroot):
    run = chroot("/opt/venv/bin/python tests/python313_probe.py bpy && "
                 "/opt/venv/bin/python -m pytest -q -p no:cacheprovider tests/blender/test_engine.py "
                 "tests/blender/test_shading_blender.py")
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert "bpy 5.2" in run.stdout and " passed" in run.stdout and "failed" not in run.stdout
