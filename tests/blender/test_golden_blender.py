"""Same pixels through Blender's real pipeline: SHA-256 over every channel of the multilayer EXR that
F12 writes (every Unbound pass enabled; the hashes over the passes they were recorded with:
bpy_scripts/golden.py, HASHED_PASSES) for a suite of small scenes built with the add-on, recorded
before the add-on's refactor and asserted ever since. Every fractal kind made by its operator, the
scene's shading settings and lights, the object's settings (fixed threshold, slice, analytic
normals, orbit-trap colour ramp, steps, a non-uniform scale and rotation), a render border with and
without crop, an orthographic camera.

A hash changes only when pixels change: a change meant to alter pixels re-records the file
(UNBOUND_RECORD_GOLDEN=1 pytest tests/blender/test_golden_blender.py) and says why in its commit.
(tests/native/test_golden_pixels.py does the same for the native core alone.)"""
import json
import os
import pathlib

import pytest

GOLDEN = pathlib.Path(__file__).with_name("golden_blender.json")
RECORD = bool(os.environ.get("UNBOUND_RECORD_GOLDEN"))


def test_same_pixels_as_recorded(run_bpy):
    """Every scene shows the fractal (the Depth pass hits on more than 2% of its pixels), every pass
    reaches the EXR, and the SHA-256 of each scene's channels equals the recorded one."""
    r = run_bpy("golden.same_pixels_as_recorded", timeout=600)
    hashes = r["hashes"]
    for name in hashes:
        assert r["hits"][name] > 0.02, (name, r["hits"])
        assert r["channels"][name] >= r["pass_channels"], (name, r["channels"])
    if RECORD:
        GOLDEN.write_text(json.dumps(dict(blender=r["blender"], scenes=hashes), indent=1, sort_keys=True) + "\n")
        pytest.skip("recorded %d hashes" % len(hashes))
    recorded = json.loads(GOLDEN.read_text())
    if recorded["blender"].split(".")[:2] != r["blender"].split(".")[:2]:
        pytest.skip("recorded with Blender %s, running %s" % (recorded["blender"], r["blender"]))
    scenes = recorded["scenes"]
    assert set(hashes) == set(scenes), "the suite changed: re-record it on the commit before the change"
    changed = sorted(name for name in hashes if hashes[name] != scenes[name])
    assert not changed, "pixels changed in %d of %d scenes: %s" % (len(changed), len(hashes), changed)
