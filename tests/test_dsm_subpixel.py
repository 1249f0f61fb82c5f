"""Sub-pixel error cancellation of the dense matcher (fotogeo.stereo.dense, Shimizu & Okutomi 2005): on a
textured pair with a disparity ramp that runs through every sub-pixel fraction, the half-pixel-shifted second
matching cuts the pixel-locking bias (the error's dependence on the true fraction) and the disparities' NMAD, and
keeps the holes of the first matching."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from fotogeo.orientation.block_render import texture
from fotogeo.stereo.dense import disparity


def _pair(seed, shift, slope):
    rng = np.random.default_rng(seed)
    left = cv2.GaussianBlur(texture(rng, (200, 520)), (0, 0), 1.0)
    xs, ys = np.meshgrid(np.arange(520, dtype=np.float32), np.arange(200, dtype=np.float32))
    right = cv2.remap(left, xs + shift + slope * xs, ys, cv2.INTER_CUBIC)  # right(u) = left(u + shift + slope·u)
    right = right + rng.normal(0, 1.0, right.shape).astype(np.float32)
    return left, right, (slope * xs + shift) / (1 + slope)


def _locking(err, truth) -> float:
    """The largest |median error| over eight bins of the true disparity's fractional part."""
    f = truth - np.floor(truth)
    return max(abs(float(np.median(err[(f >= k / 8) & (f < (k + 1) / 8)]))) for k in range(8))


def _nmad(e) -> float:
    return float(1.4826 * np.median(np.abs(e - np.median(e))))


@pytest.mark.parametrize("seed, shift, slope", [(1, 2.2, 0.008), (9, -4.6, -0.007)])
def test_half_shift_cancels_pixel_locking(seed, shift, slope):
    left, right, truth = _pair(seed, shift, slope)
    ok = np.ones(left.shape, bool)
    plain = disparity(left, right, ok, ok, -12, 12, half_shift=False)
    both = disparity(left, right, ok, ok, -12, 12)
    inner = np.isfinite(plain)
    inner[:, :30] = inner[:, -30:] = False
    e0, e1 = (plain - truth)[inner], (both - truth)[inner]
    lock0, lock1 = _locking(e0, truth[inner]), _locking(e1, truth[inner])
    assert lock1 <= 0.5 * lock0, (lock0, lock1)
    assert _nmad(e1) <= 0.85 * _nmad(e0), (_nmad(e0), _nmad(e1))
    assert abs(np.median(e1)) < 0.03
    assert np.array_equal(np.isnan(both), np.isnan(plain))
