"""Issue 17, F12 as Cycles users know it (bpy 4.2): samples appear in the render result as they
finish, the stats line says Sample k/N and the time remaining, the progress bar moves, and Esc
keeps the samples done, equal bit for bit to a render of that many samples."""
import re

import pytest


def test_samples_are_shown_as_they_finish(run_bpy):
    r = run_bpy("f12.samples_shown_as_they_finish", args={"samples": 8})
    # The stats line counts the samples up, with the time remaining.
    counts = [int(m.group(1)) for m in (re.search(r"Sample (\d+)/8", s) for s in r["stats"]) if m]
    assert counts == sorted(counts) and len(set(counts)) >= 4 and counts[-1] == 8, r["stats"]
    assert any("Remaining" in s for s in r["stats"]), r["stats"]
    # The progress bar moves through the render.
    p = r["progress"]
    assert p == sorted(p) and p[-1] == 1.0 and len({round(v, 2) for v in p}) >= 8, p
    # The result changes before the render ends: one intermediate result per sample but the last,
    # each different.
    u = r["updates"]
    assert len(u) == 7, u
    assert len({x["digest"] for x in u}) == len(u), u
    assert all(x["alpha_sum"] > 0 for x in u), u
    assert u[0]["progress"] < 0.5, u
    assert r["last"]["samples_done"] == 8 and not r["last"]["cancelled"], r["last"]


def test_no_uploads_in_the_background(run_bpy):
    """Issue 21: Blender without a window shows no image, so a render of several samples uploads
    none before its end (as Cycles in the background): the same passes, the uploads' CPU saved."""
    r = run_bpy("f12.no_uploads_in_the_background", args={"samples": 8})
    assert r["background"] and r["updates"] == [0, 7], r["updates"]
    assert len(r["identical"]) >= 12 and all(r["identical"].values()), r["identical"]


def test_esc_keeps_the_samples_done(run_bpy):
    r = run_bpy("f12.esc_keeps_the_samples_done", args={"samples": 8, "at": 0.5})
    assert r["stats"]["cancelled"] and r["breaks"] >= 1, r["stats"]
    assert 3 <= r["done"] <= 5, r["done"]
    assert r["coverage"] > 0.1, r
    # Every pass (Combined, AO, Diffuse, Shadow averaged; Depth and Normal from sample 0) bit for bit.
    assert len(r["channels"]) >= 12, r["channels"]
    assert all(r["identical"].values()), r["diffs"]
    assert any("cancelled after %d of 8 samples" % r["done"] in s for s in r["spy_stats"]), r["spy_stats"]


def test_esc_in_the_first_sample_keeps_the_tiles_done(run_bpy):
    r = run_bpy("f12.esc_in_the_first_sample_keeps_the_tiles_done")
    assert r["stats"]["cancelled"], r
    assert 0.0 < r["partial_coverage"] < r["full_coverage"], r
    assert r["rendered_equal"], r


def test_one_sample_renders_in_bands_of_at_least_BAND_MIN_PIXELS(run_bpy):
    """Issue 21: a one-sample F12 goes to Blender band by band, and each band costs Blender's merge
    and the core's setup whatever its size: as many bands of at least 2^17 pixels as the window
    holds, at most 16 (in whole 32-row tiles), so a window of fewer than 2^18 pixels is one band.
    The bands tile the frame, top to bottom, without gaps or overlaps."""
    sizes = {(640, 360): 1, (640, 480): 2, (1280, 1024): 8, (1920, 1080): 12, (96, 64): 1}
    r = run_bpy("f12.one_sample_bands", args={"sizes": list(sizes)})["found"]
    for (width, height), bands in sizes.items():
        found = r["%dx%d" % (width, height)]
        rects = [tuple(x) for x in found["results"]]
        assert len(rects) == bands, (width, height, rects)
        assert all(x == 0 and w == width for x, _, w, _ in rects), rects
        assert [y for _, y, _, _ in rects] == sorted(y for _, y, _, _ in rects)
        assert sum(h for *_, h in rects) == height and rects[0][1] == 0, rects
        assert all(a[1] + a[3] == b[1] for a, b in zip(rects, rects[1:])), rects
        assert all(h % 32 == 0 and h * width >= 1 << 17 for *_, h in rects[:-1]), rects
        # Every band was rendered (the background too) and the fractal spans rows of several bands.
        assert found["rendered"] == 1.0 and 0.05 < found["hit"] < 0.95, found
        assert found["hit_rows"] > height // 3, found


@pytest.mark.parametrize("samples", [1, 3])
def test_in_the_background_renders_go_straight_into_blenders_result(run_bpy, samples):
    """Issue 21: without a window nothing shows a band or a sample, so a window of one band (fewer
    than 2^18 pixels), or of several samples, is written into Blender's own result of the frame, not
    into a band Blender allocates, zeroes and merges (a third of a small frame's CPU beyond the
    core; with samples, a full copy of the passes). Every channel of two view layers (the second
    without the sun, with other passes) and two stereo views, bit for bit as through a band;
    begin_result asked only for the one pixel that has Blender allocate its passes."""
    r = run_bpy("f12.direct_frame_result", args={"width": 160, "height": 120, "samples": samples})
    assert r["channels"] == r["channels_bands"], (r["channels"], r["channels_bands"])
    assert any(k.startswith("Second.Position.") for k in r["channels"]), r["channels"]
    assert len(r["channels"]) >= 40 and r["unequal"] == [], r["unequal"]
    assert r["layers_differ"] and r["views_differ"] and 0.05 < r["hit"] < 0.95, r
    assert r["rects_direct"] == [[[0, 0, 1, 1]]] * 2, r["rects_direct"]
    assert r["rects_bands"] == [[[0, 0, 160, 120]]] * 2, r["rects_bands"]


def test_a_failure_straight_into_blenders_result_writes_no_file(run_bpy):
    r = run_bpy("f12.direct_failure_writes_no_file")
    outcome, written = r["outcome"]
    assert outcome == "Error: Unbound: out of memory: lower the resolution or turn off passes", r
    assert written is False and r["rects"] == [[0, 0, 1, 1]], r


def test_a_failure_between_samples_still_writes_no_file(run_bpy):
    r = run_bpy("f12.failure_mid_render_writes_no_file")
    outcome, written = r["outcome"]
    assert outcome == "Error: Unbound: out of memory: lower the resolution or turn off passes", r
    assert written is False, r
    assert r["calls"] == [[0, 1], [1, 1], [2, 1]], r["calls"]


def test_the_next_frame_reuses_the_frame_memory(run_bpy):
    """Issue 21: Blender allocates each render's result afresh and glibc returns such blocks to the
    kernel, so every frame faulted its pages back in (a third of Blender's own time per frame of
    an animation); the add-on keeps them (addon/frame_memory.py). Faults per F12 of a 640x360 frame
    of seven passes (14 channels, 3 150 pages): kept, a small part of a frame's pages (measured
    117); opted out, as before (1 655: the full frame's passes; the bands' are reused). Through a
    band, as Blender with a window renders: in the background this frame goes straight into
    Blender's result, whose one allocation glibc keeps mapped by itself (300 faults opted out)."""
    args = {"width": 640, "height": 360, "renders": 3, "direct": False}
    kept = run_bpy("f12.frame_memory_kept", args=args)
    plain = run_bpy("f12.frame_memory_kept", args=args, env={"UNBOUND_KEEP_FRAME_MEMORY": "0"})
    assert kept["finished"] and plain["finished"]
    assert kept["kept"] and not plain["kept"]
    assert kept["wanted"] == {"default": True, "UNBOUND_KEEP_FRAME_MEMORY": False, "MALLOC_TRIM_THRESHOLD_": False}
    pages = kept["pages_per_frame"]
    assert plain["faults"] > 0.3 * pages, (plain["faults"], pages)
    assert kept["faults"] < 0.1 * pages and kept["faults"] < plain["faults"] / 5, (kept["faults"], plain["faults"])
