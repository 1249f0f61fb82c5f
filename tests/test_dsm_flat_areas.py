"""A uniform area gets no disparity, not islands of wrong ones (:mod:`fotogeo.stereo.signal`): water, a saturated
roof or a specular reflection shows only the images' noise, SGM's paths carry disparities into it and the left-right
check passes whatever both directions settle on alike. Rendered pairs: a uniform "lake" on the ground (in both
images, each with its own noise) and a patch uniform in one image only; no disparity of the area or of its border
may be more than a pixel off (before, with a uniqueness ratio of 30: 210 and 325 pixels of the lakes up to 2.4 px
off, 50 of the patch up to 2.1 px; with 10: up to 4 px), and the textured ground around keeps its disparities."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from fotogeo.orientation.block_render import texture
from fotogeo.stereo.dense import disparity
from fotogeo.stereo.signal import noise_sigma

ROWS, COLS = 160, 420
#: the uniform area of the left image (rows, columns)
AREA = (slice(50, 110), slice(150, 290))


def _pair(seed, where: str):
    """A textured pair, right(x) = left(x + 4 + 0.02·x), both with noise of 2 levels, and a uniform area of
    grey 120: on the ground (``"both"``: in the right image where the ground is, each image its own noise) or in
    the left image only (``"left"``: no noise, as a saturated patch)."""
    rng = np.random.default_rng(seed)
    ground = cv2.GaussianBlur(texture(rng, (ROWS, COLS)), (0, 0), 1.0)
    if where == "both":
        ground[AREA] = 120.0
    xs, ys = np.meshgrid(np.arange(COLS, dtype=np.float32), np.arange(ROWS, dtype=np.float32))
    a, b = 4.0, 0.02
    right = cv2.remap(ground, xs + a + b * xs, ys, cv2.INTER_LINEAR)
    truth = a + b * (xs - a) / (1 + b)
    left = ground + rng.normal(0, 2.0, ground.shape).astype(np.float32)
    right = right + rng.normal(0, 2.0, right.shape).astype(np.float32)
    if where == "left":
        left[AREA] = 120.0
    return left, right, truth


@pytest.mark.parametrize("seed, where", [(8, "both"), (11, "both"), (13, "left")])
def test_a_uniform_area_is_a_hole_not_wrong_disparities(seed, where):
    left, right, truth = _pair(seed, where)
    ok = np.ones(left.shape, bool)
    d = disparity(left, right, ok, ok, -4.0, 20.0)
    err = np.abs(d - truth)
    near = np.zeros_like(ok)
    near[AREA[0].start - 8:AREA[0].stop + 8, AREA[1].start - 8:AREA[1].stop + 8] = True
    assert not (err[near] > 1.0).any(), (int((err[near] > 1.0).sum()), float(np.nanmax(err[near])))
    away = ~near
    away[:10] = away[-10:] = False
    away[:, :30] = away[:, -30:] = False
    assert np.isfinite(d[away]).mean() > 0.95  # the textured ground keeps its disparities


def test_the_noise_estimate():
    """Immerkær's estimate finds white noise on a textured image within a few percent."""
    rng = np.random.default_rng(4)
    img = cv2.GaussianBlur(texture(rng, (200, 300)), (0, 0), 1.0)
    ok = np.ones(img.shape, bool)
    for sigma in (1.0, 3.0, 6.0):
        got = noise_sigma(img + rng.normal(0, sigma, img.shape).astype(np.float32), ok)
        assert abs(got - sigma) < 0.1 * sigma, (sigma, got)
