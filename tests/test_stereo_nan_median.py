"""The fusion's median across pairs (fotogeo.stereo.fusion.nan_median): numpy's nanmedian values exactly — odd and
even counts, ties, cells without any height — from one sort."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fotogeo.stereo.fusion import nan_median


@pytest.mark.parametrize("layers", [1, 2, 3, 4, 7])
def test_nan_median_is_numpys(layers):
    rng = np.random.default_rng(layers)
    for case in range(4):
        a = rng.normal(300.0, 40.0, (layers, 60, 50)).astype(np.float32)
        a[rng.random(a.shape) < 0.35] = np.nan
        if case == 1:
            a[:, :4] = np.nan  # no pair gave a height
        if case == 2:
            a = np.round(a / 8.0) * 8.0  # ties
        if case == 3:
            a[:, 10:] = a[:1, 10:]  # all pairs agree
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            expected = np.nanmedian(a, axis=0)
        got = nan_median(a)
        assert got.dtype == np.float32 and np.array_equal(got, expected, equal_nan=True)
