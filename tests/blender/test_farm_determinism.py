"""A render farm's split of a frame range: one Blender renders frames 1-4 of a keyframed μ
animation; two other Blenders render 1-2 and 3-4 with other thread counts and tile sizes, as two
farm machines would. Every pass of every frame must have the same bits."""
import numpy as np
from exr import read_exr


def render_range(run_bpy, prefix, first, last, threads, tile):
    r = run_bpy("farm.render_range", args=dict(prefix=prefix, first=first, last=last, threads=threads, tile=tile))
    assert r["stats"]["threads"] == threads, r["stats"]
    return r


def test_frame_range_split_over_two_processes_is_bit_identical(run_bpy, tmp_path):
    render_range(run_bpy, "whole_", 1, 4, threads=2, tile=32)
    render_range(run_bpy, "farm_", 1, 2, threads=7, tile=13)
    render_range(run_bpy, "farm_", 3, 4, threads=1, tile=64)
    previous = None
    for frame in (1, 2, 3, 4):
        whole = read_exr(tmp_path / ("whole_%04d.exr" % frame))
        farm = read_exr(tmp_path / ("farm_%04d.exr" % frame))
        assert sorted(whole) == sorted(farm) and len(whole) >= 12, sorted(whole)
        for channel in whole:
            assert whole[channel].tobytes() == farm[channel].tobytes(), (frame, channel)
        # The animation moves: consecutive frames differ (the comparison is not of empty images).
        depth = whole["ViewLayer.Depth.Z"]
        assert (depth < 1e9).mean() > 0.05
        if previous is not None:
            assert not np.array_equal(previous, depth), frame
        previous = depth
