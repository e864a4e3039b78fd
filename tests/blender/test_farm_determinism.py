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


def test_first_frame_of_a_saved_file_whatever_the_load_order(run_bpy, tmp_path):
    """A .blend saved at frame 1, rendered from frame 2 on: the first frame rendered has frame 2's
    keyframed values whether the add-on was registered before the file loaded (`blender -b
    --addons ... FILE`, or enabled by a worker's preferences) or after it (`blender -b FILE
    --addons ...`), and the same bits as frame 2 of the whole range 1-4. (It once had the values
    the file was saved with: the add-on's frame_change_post handler wrote the display size of the
    original object during the render, which made Blender copy the original's un-animated
    properties over the render depsgraph's evaluated ones: docs/farm.md, 'Load order does not
    matter'.)"""
    path = str(tmp_path / "scene.blend")
    run_bpy("farm.save_keyframed_scene", args=dict(path=path))
    run_bpy("farm.render_saved", args=dict(path=path, order="after", first=1, last=4, prefix="whole_"))
    run_bpy("farm.render_saved", args=dict(path=path, order="after", first=2, last=3, prefix="after_"))
    run_bpy("farm.render_saved", args=dict(path=path, order="before", first=2, last=3, prefix="before_"))
    for frame in (2, 3):
        whole = read_exr(tmp_path / ("whole_%04d.exr" % frame))
        assert (whole["ViewLayer.Depth.Z"] < 1e9).mean() > 0.05
        for prefix in ("after_", "before_"):
            split = read_exr(tmp_path / ("%s%04d.exr" % (prefix, frame)))
            assert sorted(split) == sorted(whole) and len(whole) >= 12, sorted(split)
            for channel in whole:
                assert split[channel].tobytes() == whole[channel].tobytes(), (prefix, frame, channel)
    assert not np.array_equal(read_exr(tmp_path / "whole_0001.exr")["ViewLayer.Depth.Z"],
                              read_exr(tmp_path / "whole_0002.exr")["ViewLayer.Depth.Z"])
