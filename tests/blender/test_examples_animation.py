"""examples/animate_mu.py, run as a user runs it (`python examples/animate_mu.py ...` with the bpy
module, each run in a fresh process and a fresh BLENDER_USER_RESOURCES): it writes a PNG and a
multilayer EXR of every pass per frame, the keyframed mu reaches every frame, and a frame range
split across two processes (a render farm) gives the same frames as one process."""
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest
from examples_run import finish, start_example
from exr import extension_zip, read_exr, read_png

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "animate_mu.py"
SIZE = (64, 48)
FRAMES = (1, 4)
PASS_CHANNELS = ["ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B", "ViewLayer.Combined.A",
                 "ViewLayer.Depth.Z", "ViewLayer.Normal.X", "ViewLayer.Normal.Y", "ViewLayer.Normal.Z",
                 "ViewLayer.Position.X", "ViewLayer.Position.Y", "ViewLayer.Position.Z",
                 "ViewLayer.Iterations.X", "ViewLayer.Steps.X", "ViewLayer.Distance.X"]


def example_cmd(out, frames, python=None, dashdash=False):
    args = ["--out", str(out), "--frames", str(frames[0]), str(frames[1]),
            "--resolution", str(SIZE[0]), str(SIZE[1])]
    return [python or sys.executable, str(EXAMPLE)] + (["--"] if dashdash else []) + args


def frame_files(out, frame):
    return out / "png" / ("frame_%04d.png" % frame), out / "exr" / ("frame_%04d.exr" % frame)


@pytest.fixture(scope="module")
def animation(tmp_path_factory):
    """Frames 1-4 of the example in one process: (output folder, its stdout)."""
    work = tmp_path_factory.mktemp("animate_mu_full")
    out = work / "out"
    text = finish(start_example(example_cmd(out, FRAMES), work))
    return out, text


def test_writes_png_and_multilayer_exr_per_frame(animation):
    out, text = animation
    listed = [line.strip() for line in text.splitlines() if line.strip().endswith((".png", ".exr"))]
    expected = []
    for frame in range(FRAMES[0], FRAMES[1] + 1):
        png, exr = frame_files(out, frame)
        assert png.is_file() and exr.is_file(), text[-3000:]
        expected += [str(png), str(exr)]
        pixels = read_png(png)
        assert pixels.shape == (SIZE[1], SIZE[0], 3)
        channels = read_exr(exr)
        assert set(PASS_CHANNELS) <= set(channels), sorted(channels)
        assert all(channels[c].shape == (SIZE[1], SIZE[0]) for c in PASS_CHANNELS)
        hit = channels["ViewLayer.Depth.Z"] < 1e9  # background: 1e10
        assert 0.05 < hit.mean() < 0.95  # the fractal is in view, with background around it
        assert np.all(channels["ViewLayer.Combined.A"] == 1.0)  # opaque: the world colour behind
        assert np.all(channels["ViewLayer.Depth.Z"][hit] < 10.0)
        assert np.all(channels["ViewLayer.Iterations.X"][hit] >= 1)
        assert pixels.std() > 5  # not a blank image
    assert sorted(listed) == sorted(expected)  # every written file is printed, one per line
    assert "animate_mu: frames 1-4" in text


def test_keyframed_mu_reaches_each_frame(animation, run_bpy):
    """Frame k of the animation equals, bit for bit, a single-frame render of the same scene with
    mu set (not keyframed) to the value the F-curves give at frame k."""
    out, _ = animation
    r = run_bpy("examples_animation.keyframed_mu_reaches_each_frame", install=False,
                args=dict(example=str(EXAMPLE), extension=str(extension_zip()), size=SIZE, frame_range=FRAMES))
    mus = {int(k): np.array(v) for k, v in r["mus"].items()}
    frames = range(FRAMES[0], FRAMES[1] + 1)
    # The F-curves: frame 1 is the first key, the loop closes, and between keys mu stays on the path.
    assert np.allclose(mus[1], r["key0"], atol=1e-6)
    assert np.array_equal(mus[1 + r["loop"]], mus[1])
    mid = mus[1 + r["loop"] // 16]
    assert np.allclose(mid, r["mid"], atol=0.005), (mid, r["mid"])  # Bezier vs. circle and sine
    for a in frames:
        for b in frames:
            if a < b:
                assert np.abs(mus[a] - mus[b]).max() > 1e-3, "mu does not move between frames %d and %d" % (a, b)
    previous = None
    for k in frames:
        animated = read_exr(frame_files(out, k)[1])
        single = read_exr(r["singles"][str(k)])
        for c in PASS_CHANNELS:
            assert animated[c].tobytes() == single[c].tobytes(), "frame %d, %s differs from the single render" % (k, c)
        if previous is not None:  # frames differ as mu moves
            for c in ("ViewLayer.Combined.R", "ViewLayer.Depth.Z", "ViewLayer.Iterations.X"):
                assert not np.array_equal(animated[c], previous[c]), "frames %d and %d: same %s" % (k - 1, k, c)
        previous = animated


def test_farm_split_matches_one_process(animation, tmp_path):
    """Frames 1-2 in one process and 3-4 in another (at the same time, as two farm nodes) write the
    same pixels as frames 1-4 in one process."""
    out, _ = animation
    mid = (FRAMES[0] + FRAMES[1]) // 2
    parts = [(FRAMES[0], mid), (mid + 1, FRAMES[1])]
    procs = []
    for i, frames in enumerate(parts):
        work = tmp_path / ("node%d" % i)
        work.mkdir()
        # One node passes its options after `--`, as Blender's command line needs; both forms work.
        procs.append(start_example(example_cmd(tmp_path / "split", frames, dashdash=(i == 1)), work))
    for p in procs:
        finish(p)
    for k in range(FRAMES[0], FRAMES[1] + 1):
        one_png, one_exr = frame_files(out, k)
        split_png, split_exr = frame_files(tmp_path / "split", k)
        one, split = read_exr(one_exr), read_exr(split_exr)
        assert sorted(one) == sorted(split)
        for c in one:
            assert one[c].tobytes() == split[c].tobytes(), "frame %d, %s differs" % (k, c)
        assert read_png(one_png).tobytes() == read_png(split_png).tobytes(), "frame %d PNG differs" % k


@pytest.mark.skipif(shutil.which("blender") is None and os.geteuid() != 0,
                    reason="needs a blender binary on PATH, or root for the trixie chroot's Blender 4.3")
def test_runs_unchanged_in_blender(tmp_path):
    """`blender --background --python examples/animate_mu.py -- ...`: the same script in Blender
    (on PATH, else Debian's Blender 4.3 in the chroot of tools/blender_gui.sh)."""
    args = ["--frames", "1", "2", "--resolution", str(SIZE[0]), str(SIZE[1])]
    if shutil.which("blender"):
        out = tmp_path / "out"
        cmd = ["blender", "--background", "--python", str(EXAMPLE), "--", "--out", str(out)] + args
        text = finish(start_example(cmd, tmp_path))
    else:
        root = pathlib.Path(__file__).resolve().parents[2]
        work = root / "build" / "example_in_blender"
        shutil.rmtree(work, ignore_errors=True)
        (work / "user" / "config").mkdir(parents=True)
        out = work / "out"
        setup = subprocess.run(["sh", "tools/blender_gui.sh", "setup"], cwd=root, capture_output=True, text=True,
                               timeout=1500)
        assert setup.returncode == 0, setup.stderr[-3000:]
        proc = subprocess.run(["sh", "tools/blender_gui.sh", "run", "env",
                               "BLENDER_USER_RESOURCES=/src/build/example_in_blender/user", "blender", "--background",
                               "--python", "/src/examples/animate_mu.py", "--", "--out",
                               "/src/build/example_in_blender/out"] + args,
                              cwd=root, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, (proc.stdout + proc.stderr)[-6000:]
        text = proc.stdout.replace("/src/", str(root) + "/")
        assert "Blender 4." in proc.stdout
    for k in (1, 2):
        png, exr = frame_files(out, k)
        assert png.is_file() and str(png) in text
        assert set(PASS_CHANNELS) <= set(read_exr(exr))
