"""The heights a frame pair is searched over, from its sparse matches (fotogeo.tools.dsm.plan.matched_heights): a
few rays that meet far below the ground (a drone pair's 1st percentile lay 470 m below the median) must not set
the range — a range reaching above a camera has no disparity there, and the pair then matched nothing."""
from __future__ import annotations

import numpy as np

from fotogeo.tools.dsm.plan import matched_heights


def test_mismatched_rays_do_not_set_the_height_range():
    rng = np.random.default_rng(3)
    ground = rng.normal(162.0, 3.0, 660)
    z = np.concatenate([ground, [-309.0, -250.0, -180.0, 420.0, 600.0, 390.0, -400.0]])
    low, high = matched_heights(z, ceiling=265.0)
    assert np.percentile(ground, 1) - 1.0 <= low <= np.percentile(ground, 1) + 1.0
    assert np.percentile(ground, 99) - 1.0 <= high <= np.percentile(ground, 99) + 1.0


def test_real_relief_is_kept():
    """A hill 40 m above flat ground seen by a fifth of the matches, 100 m below the cameras: kept whole."""
    rng = np.random.default_rng(4)
    z = np.concatenate([rng.normal(150.0, 1.0, 400), rng.uniform(150.0, 190.0, 100)])
    assert matched_heights(z, ceiling=265.0) == (np.percentile(z, 1), np.percentile(z, 99))  # nothing dropped


def test_the_high_end_stays_below_the_cameras():
    z = np.concatenate([np.full(50, 100.0), np.linspace(100.0, 300.0, 10)])
    low, high = matched_heights(z, ceiling=200.0)
    assert high <= 100.0 + 0.75 * 100.0
