"""How busy a packet's lanes are while it marches, from the peer frame's steps pass (issue 21).

A packet of camera rays steps until its slowest lane is done, and a pair of packets
(march_julia_pair_body) until both are: every step costs the whole vector, so the lanes busy per
packet-step bound what any change of the packets' shape or of their scheduling can gain. Counted,
not timed, so the figure is the same on any host and for any kernel (the steps pass has the same
bits in every one): for each packet shape, the march steps of the frame's camera rays (the steps
pass) against the lanes times the steps of the packets (each packet's slowest ray), alone and in
pairs of side-by-side packets as the kernels march them (4 x 4 with 16 lanes, 4 x 2 with 8).

    python bench/bench_lanes.py [--res 1280x1024]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_core  # noqa: E402  (the peer scene; puts the built module on the path)
import unbound_core as uc  # noqa: E402

SHAPES = ((4, 4), (8, 2), (16, 1), (4, 2), (8, 1), (2, 2), (4, 1), (2, 1))
PAIRED = ((4, 4), (4, 2))  # the kernels' blocks (kernel.h, UB_BLOCK_W x UB_BLOCK_H)


def steps_pass(width, height):
    """The peer scene's march steps per pixel (bench_core.py's camera and object)."""
    passes = {n: uc.pass_array(height, width, uc.PASS_CHANNELS[n]) for n in ("combined", "steps")}
    stats = uc.render(bench_core.camera(width, height), [bench_core.OBJECT], passes)
    steps = passes["steps"][..., 0].astype(np.float64)
    assert steps.sum() == stats["steps"], "the steps pass holds the camera rays' steps"
    return steps


def packet_steps(steps, bw, bh):
    """Each bw x bh packet's steps (its slowest ray's), on the grid of packets."""
    h, w = steps.shape
    return steps.reshape(h // bh, bh, w // bw, bw).max(axis=(1, 3))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--res", default="1280x1024")
    args = ap.parse_args(argv)
    width, height = (int(v) for v in args.res.split("x"))
    steps = steps_pass(width, height)
    total = steps.sum()
    print("peer scene %dx%d: %.3f M march steps of camera rays" % (width, height, total / 1e6))
    for bw, bh in SHAPES:
        if width % bw or height % bh:
            continue
        alone = packet_steps(steps, bw, bh)
        line = "%2d x %d packets (%2d lanes): %.1f %% of the lanes busy a step" % (
            bw, bh, bw * bh, 100 * total / (alone.sum() * bw * bh))
        if (bw, bh) in PAIRED and alone.shape[1] % 2 == 0:
            pair = np.maximum(alone[:, 0::2], alone[:, 1::2])
            line += ", %.1f %% in pairs" % (100 * total / (pair.sum() * 2 * bw * bh))
        print(line)


if __name__ == "__main__":
    main()
