"""The abi3 wheel built here (Python 3.11) loads and passes the native suite under Python 3.13
(Blender 5.2's Python), inside the Debian trixie chroot of tools/py313.sh."""
import glob
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.skipif(os.geteuid() != 0, reason="the trixie chroot needs root (CI runs as root)")
def test_native_suite_under_python313():
    wheels = sorted(glob.glob(str(ROOT / "dist" / "unbound_core-*-cp311-abi3-*.whl")))
    assert wheels, "build the wheel first (make wheel)"
    wheel = os.path.relpath(wheels[-1], ROOT)
    setup = subprocess.run(["sh", "tools/py313.sh", "setup"], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert setup.returncode == 0, setup.stderr[-3000:]
    script = (f"/opt/venv/bin/pip install -q --no-index --force-reinstall --no-deps {wheel} && "
              "/opt/venv/bin/python -c 'import sys, unbound_core; assert sys.version_info[:2] == (3, 13); "
              "print(sys.version.split()[0], unbound_core._native.__file__)' && "
              "/opt/venv/bin/python -m pytest -q -p no:cacheprovider tests/native")
    run = subprocess.run(["sh", "tools/py313.sh", "run", "sh", "-c", script], cwd=ROOT, capture_output=True,
                         text=True, timeout=1200)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert "3.13" in run.stdout and "abi3" in run.stdout
    assert " passed" in run.stdout and "failed" not in run.stdout
