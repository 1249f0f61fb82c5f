"""The DEM's margin (:func:`fotogeo.tools.dsm.dem_guide.fit`) from few sparse matches: an upper confidence bound of
the DEM error's quantile (:func:`fotogeo.tools.dsm.dem_guide.upper_quantile`), not the matches' own percentile,
which underestimates a heavy tail's from 20-40 of them."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from fotogeo.tools.dsm import dem_guide


def _flat(XY):
    return np.zeros(len(XY))


def _margin(errors) -> float:
    """The fit's margin for matches whose DEM error (DEM height minus theirs) is ``errors``."""
    P = np.column_stack([np.arange(len(errors)), np.zeros(len(errors)), -np.asarray(errors)])
    return dem_guide.fit(_flat, P).margin


@pytest.mark.parametrize("n", [20, 25, 40, 80])
def test_the_margin_from_few_matches_reaches_the_whole_grounds(n):
    """Errors with a heavy tail (Student's t, 3 degrees of freedom, 2 m): over 300 random sets of ``n`` matches
    the margin reaches the one the whole population gives in at least 90 % of them (stated: 95 %), and stays
    within 3.5 times its error part (before: 30-45 % of them, the percentile of n points being low)."""
    rng = np.random.default_rng(n)
    pop = 2.0 * rng.standard_t(3, 200_000) + 7.0
    whole = dem_guide.DEM_PAD_M + dem_guide.DEM_ERROR_K * float(np.percentile(np.abs(pop - np.median(pop)), 95))
    got = np.array([_margin(rng.choice(pop, n, replace=False)) for _ in range(300)])
    assert np.mean(got >= whole) >= 0.90, (np.mean(got >= whole), whole, np.median(got))
    part = (np.median(got) - dem_guide.DEM_PAD_M) / (whole - dem_guide.DEM_PAD_M)
    assert part < 3.5, part


def test_with_many_values_the_bound_is_the_binomial_order_statistic():
    """100 uniform values: the bound is their second largest (P(Binomial(100, 0.95) <= 98) >= 0.95 first at 98),
    which is above the 0.95 quantile in 96.3 % of samples; 20 values: beyond the largest (no order statistic
    reaches 95 % confidence), yet finite."""
    rng = np.random.default_rng(1)
    a = rng.uniform(size=100)
    assert dem_guide.upper_quantile(a) == np.sort(a)[98]
    reach = np.mean([dem_guide.upper_quantile(rng.uniform(size=100)) >= 0.95 for _ in range(2000)])
    expected = stats.binom.cdf(98, 100, 0.95)
    assert abs(reach - expected) < 0.015, (reach, expected)
    b = rng.uniform(size=20)
    assert b.max() < dem_guide.upper_quantile(b) < 10 * b.max()
