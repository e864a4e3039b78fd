"""render(clear_unfinished=True) (issue 21): a render cancelled in its first sample leaves zeros
(transparent black) in every tile it did not finish, so F12's bands need no clearing before each
render. The buffers start as NaN here: after the cancel each tile of the film's grid either holds
exactly the full render's bytes (finished before the cancel) or zeros in every pass (not finished,
or cut short), and no NaN is left anywhere. Without the flag the NaNs stay where no tile reached, as
before. Several samples: a cancel after the first leaves the first's sums, never zeros."""
import numpy as np
import pytest
import unbound_core as uc

from conftest import alloc_passes, make_camera

OBJECT = dict(mu=(-0.2, 0.8, 0.1, 0.0), max_iterations=80, detail=2.0)
SHADING = dict(shadows="soft", lights=[dict(type="area", position=(2.0, -2.0, 3.0), radius=0.5,
                                            color=(3.0, 3.0, 3.0))])
NAMES = ["combined", "depth", "normal", "shadow", "steps"]
WIDTH, HEIGHT, TILE = 480, 288, 32


def render(obj=OBJECT, shading=SHADING, cancel_at=None, **kw):
    """(stats, passes) of a render cancelled once its progress reaches `cancel_at` (None: not). An
    opaque background: no rendered tile is zero in every pass."""
    passes = alloc_passes(WIDTH, HEIGHT, NAMES)
    progress = None if cancel_at is None else (lambda fraction: fraction >= cancel_at)
    stats = uc.render(make_camera(WIDTH, HEIGHT), [obj], passes, shading=shading, tile_size=TILE, threads=2,
                      background=(0.1, 0.1, 0.1, 1.0), progress=progress, poll_interval=0.0001, **kw)
    return stats, passes


def tiles():
    for y in range(0, HEIGHT, TILE):
        for x in range(0, WIDTH, TILE):
            yield np.s_[y:y + TILE, x:x + TILE]


def classify(passes, full):
    """Counts of the tiles equal to the full render's in every pass and of those zero in every pass;
    an AssertionError for any other tile."""
    equal = zero = 0
    for t in tiles():
        same = all(np.array_equal(passes[n][t], full[n][t]) for n in NAMES)
        zeros = all(not passes[n][t].any() for n in NAMES)
        assert same or zeros, ("a tile neither rendered nor cleared", t)
        equal += same and not zeros
        zero += zeros
    return equal, zero


@pytest.mark.parametrize("normal_method", ["gradient_distance", "zbuffer"])
def test_a_cancel_in_the_first_sample_leaves_rendered_tiles_and_zeros(normal_method):
    """zbuffer: the two-phase render (camera rays into the hit buffer, then shading): the film's
    tiles are those of the shading phase; a cancel while tracing leaves every tile zero."""
    obj = dict(OBJECT, normal_method=normal_method)
    _, full = render(obj)
    assert not any(np.isnan(full[n]).any() for n in NAMES)
    kept = cleared = 0
    for cancel_at in (0.0, 0.2, 0.5, 0.8):
        stats, passes = render(obj, cancel_at=cancel_at, clear_unfinished=True)
        if not stats["cancelled"]:  # the render ended before its first poll: nothing to check
            continue
        assert not any(np.isnan(passes[n]).any() for n in NAMES), cancel_at
        # (A slow machine may poll only after the last tile ended: every tile kept, none cleared.)
        equal, zero = classify(passes, full)
        kept, cleared = kept + equal, cleared + zero
    assert cleared > 0, "no cancel left a tile unfinished: the test checked no clearing"
    assert kept > 0, "no cancel came after a finished tile: the test checked only zeros"


def test_without_the_flag_a_cancel_leaves_the_buffers_as_they_were():
    stats, passes = render(cancel_at=0.2)
    assert stats["cancelled"]
    assert np.isnan(passes["combined"]).all(axis=2).any()


def test_a_cancel_after_the_first_sample_keeps_its_sums():
    """With several samples the film holds the sums of the samples done: never cleared. Four
    samples, cancelled at 30 % of the render: in the second sample (the first sample's job ends
    below 25 %), with three samples' time left for the progress poll to see it, so a caller thread
    kept off the CPU for a while still cancels (with two samples and 75 % it once missed)."""
    shading = dict(SHADING, samples=4)
    stats, passes = render(shading=shading, cancel_at=0.3, clear_unfinished=True)
    assert stats["cancelled"]
    assert not np.isnan(passes["combined"]).any()
    assert all(passes["combined"][t][..., 3].any() for t in tiles())   # alpha 1 (background) or a hit's


def test_the_flag_changes_no_finished_render():
    _, full = render()
    _, cleared = render(clear_unfinished=True)
    for n in NAMES:
        assert np.array_equal(full[n], cleared[n]), n
