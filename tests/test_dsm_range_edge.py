"""Disparities cut off at the searched range's ends are dropped (:func:`fotogeo.stereo.dense.disparity`,
``RANGE_EDGE``): where a pixel's true disparity lies beyond the range (a local range from sparse matches that
misses it), SGBM's cost minimum sits at the range's end in both directions and the left–right check passes it —
issue 30's "1280x960 full" oblique set had bands of one wrong height (−22 m, +18 m) from such strips."""
from __future__ import annotations

import cv2
import numpy as np

from fotogeo.orientation.block_render import texture
from fotogeo.stereo.dense import disparity


def _ramp(seed):
    """A rendered texture and its copy displaced by a disparity ramp from −6 px (left) to 18 px (right)."""
    rng = np.random.default_rng(seed)
    left = cv2.GaussianBlur(texture(rng, (160, 480)), (0, 0), 1.0)
    xs, ys = np.meshgrid(np.arange(480, dtype=np.float32), np.arange(160, dtype=np.float32))
    a, b = -6.0, 24.0 / 479.0
    right = cv2.remap(left, xs + a + b * xs, ys, cv2.INTER_CUBIC)  # right(x) = left(x + a + b·x)
    truth = a + b * (xs - a) / (1 + b)  # d = u_left − u_right at the left pixel u
    return left, right + rng.normal(0, 1.0, right.shape).astype(np.float32), truth


def test_a_range_that_misses_the_disparities_leaves_holes_not_its_ends():
    left, right, truth = _ramp(21)
    ok = np.ones(left.shape, bool)
    lo, hi = -2.0, 9.0  # the true disparities run from -6 to 18: a third of the pixels lie beyond
    d = disparity(left, right, ok, ok, lo, hi)
    got = np.isfinite(d)
    inner = np.zeros_like(ok)
    inner[8:-8, 30:-30] = True
    err = np.abs(d - truth)[got & inner]
    assert got[inner & (truth > lo + 2) & (truth < hi - 2)].mean() > 0.9  # inside the range: matched
    assert (err > 1.0).mean() < 0.02, (err > 1.0).mean()  # before: 11 %, at the ends and beyond the top
    assert np.nanmin(d) >= lo + 0.5 and np.nanmax(d) <= hi - 0.5  # RANGE_EDGE = 1 px in, less what the median moves
