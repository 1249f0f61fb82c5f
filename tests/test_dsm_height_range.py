"""The heights a frame pair is searched over, from its sparse matches (fotogeo.tools.dsm.plan.matched_heights): a
few rays that meet far below the ground (a drone pair's 1st percentile lay 470 m below the median) must not set
the range — a range reaching above a camera has no disparity there, and the pair then matched nothing; a height
reached when neighbouring matches support it (:func:`fotogeo.tools.dsm.plan.supported`): a small roof carrying
several matches is not cut as the 99th percentile cut it, and the range is never narrower than the percentiles."""
from __future__ import annotations

import numpy as np

from fotogeo.tools.dsm.plan import matched_heights, supported


def _points(z, seed=0, side=600.0):
    """Matches at heights ``z`` scattered over a square of ``side`` metres."""
    xy = np.random.default_rng(seed).uniform(0.0, side, (len(z), 2))
    return np.column_stack([xy, z])


def test_mismatched_rays_do_not_set_the_height_range():
    rng = np.random.default_rng(3)
    ground = rng.normal(162.0, 3.0, 660)
    z = np.concatenate([ground, [-309.0, -250.0, -180.0, 420.0, 600.0, 390.0, -400.0]])
    low, high = matched_heights(_points(z), ceiling=265.0)
    assert ground.min() - 1.0 <= low <= np.percentile(ground, 1) + 1.0
    assert np.percentile(ground, 99) - 1.0 <= high <= ground.max() + 1.0


def test_real_relief_is_kept():
    """A hill 40 m above flat ground seen by a fifth of the matches, 100 m below the cameras: kept whole."""
    rng = np.random.default_rng(4)
    xy = rng.uniform(0.0, 500.0, (500, 2))
    z = 150.0 + np.where(xy[:, 0] > 400.0, 0.4 * (xy[:, 0] - 400.0), 0.0) + rng.normal(0.0, 1.0, 500)
    low, high = matched_heights(np.column_stack([xy, z]), ceiling=265.0)
    assert low <= np.percentile(z, 1) and high >= z.max() - 2.0, (low, high, z.max())


def test_the_high_end_stays_below_the_cameras():
    z = np.concatenate([np.full(50, 100.0), np.linspace(100.0, 300.0, 10)])
    low, high = matched_heights(_points(z), ceiling=200.0)
    assert high <= 100.0 + 0.75 * 100.0


def _ground_and_roof(seed, n=1000, side=600.0, roof_side=60.0, rise=30.0):
    """``n`` matches on gently sloping ground over ``side`` metres, those on a block ``roof_side`` metres wide in its
    middle (1 % of the area) ``rise`` metres higher; and which are on the roof."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0.0, side, (n, 2))
    z = 100.0 + 0.02 * xy[:, 0] + rng.normal(0.0, 0.5, n)
    roof = (np.abs(xy - side / 2) < roof_side / 2).all(axis=1)
    z[roof] += rise
    return xy, z, roof


def test_a_small_roof_is_kept_without_a_dem():
    """A roof over 1 % of the overlap carries about 1 % of the matches: the range reaches its top (before: the 99th
    percentile, padded as a pair's range is, stopped it under the roof for most draws)."""
    for seed in range(5):
        xy, z, roof = _ground_and_roof(seed)
        assert 4 <= roof.sum() <= 20, roof.sum()
        low, high = matched_heights(np.column_stack([xy, z]), ceiling=1000.0, widen=0.5, pad=10.0)  # the pair's
        assert high > z[roof].max(), (seed, high, z[roof].max())
        assert supported(xy, z)[roof].sum() >= roof.sum() // 2


def test_a_height_no_neighbour_supports_is_searched_as_far_as_the_percentiles_reach():
    """One match 28 m over ground among few (a mismatch, or a roof that carries one match): not supported, but the
    range is never narrower than the 1st-99th percentiles, which reach it when the matches are few."""
    xy, z, _ = _ground_and_roof(1, n=60, rise=0.0)
    z[17] += 28.0
    assert not supported(xy, z)[17]
    low, high = matched_heights(np.column_stack([xy, z]), ceiling=1000.0, widen=0.5, pad=10.0)
    assert high >= z[17] and low <= np.percentile(z, 1)
