"""The texture rule's noise (:func:`fotogeo.stereo.texture.noise_sigma`) against clipped pixels and against
photon noise (review of issue 30's rule, s28).

* Saturated pixels (a cloud, snow, a white roof at 255) have no gradient and no noise: counted among the
  homogeneous pixels they made σ 0 (the NGI frame 0182 with its top 5 % rows at 255: 1.729 → 0.005; the rendered
  lake with its top 8 % rows saturated: 109 cells more than 5 m off).
* The noise grows with the brightness (photon noise, Foi et al. 2008): one σ per image, set by the bright pixels,
  removed the correct matches of a dark shadow (a Poisson pair: 57.3 % of its pixels matched, all right → 0.2 %).
"""
from __future__ import annotations

import pickle

import cv2
import numpy as np
import pytest

from fotogeo.orientation.block_render import texture as ground_texture
from fotogeo.stereo.dense import disparity
from fotogeo.stereo.texture import noise_sigma


def _scene(rng, shape=(300, 400), sigma=1.5):
    g = cv2.GaussianBlur(ground_texture(rng, shape), (0, 0), 1.0)
    return np.clip(g + rng.normal(0, sigma, shape).astype(np.float32), 1, 254)


@pytest.mark.parametrize("clipped", [0.05, 0.2])
def test_saturated_rows_do_not_collapse_the_noise(clipped):
    rng = np.random.default_rng(4)
    img = _scene(rng)
    ok = np.ones(img.shape, bool)
    clean = noise_sigma([img], [ok])
    sat = img.copy()
    sat[: int(clipped * img.shape[0])] = 255.0
    got = noise_sigma([sat], [ok])
    assert abs(got - clean) < 0.2 * clean, (clean, got)


def test_the_noise_level_follows_the_brightness():
    """Poisson noise (σ² = I/4 in grey units of a quarter electron): the model's σ at a dark and a bright grey
    within 25 % of the truth; a constant noise gives b near 0."""
    rng = np.random.default_rng(6)
    base = cv2.GaussianBlur(ground_texture(rng, (300, 400)), (0, 0), 1.0)
    mean = 40.0 + 6.0 * base  # photo-electrons ~ 40 .. 1500
    img = rng.poisson(np.maximum(mean, 1)).astype(np.float32) / 2.0
    got = noise_sigma([img], [np.ones(img.shape, bool)])
    for grey in (50.0, 500.0):
        truth = np.sqrt(grey / 2.0)
        assert abs(float(got.at(grey)) - truth) < 0.25 * truth, (grey, float(got.at(grey)), truth, got.a, got.b)
    flat = noise_sigma([120 + 0.3 * base + rng.normal(0, 2.0, base.shape).astype(np.float32)],
                       [np.ones(base.shape, bool)])
    assert abs(float(flat.at(200.0)) - 2.0) < 0.4 and abs(float(flat.at(20.0)) - 2.0) < 0.4, (flat.a, flat.b)
    back = pickle.loads(pickle.dumps(got))  # a Dask task gets it
    assert (float(back), back.a, back.b) == (float(got), got.a, got.b)


def test_a_dark_shadow_keeps_its_matches_under_photon_noise():
    """A scene 90 % bright (3000 e⁻) with a shadow of 100 e⁻ and texture of 40 e⁻, Poisson noise, true disparity
    6 px: the noise rule keeps at least 95 % of the shadow's matches the stretch's test alone keeps (one σ per
    image: 0.2 % of 57.3 %), all right."""
    rng = np.random.default_rng(3)
    rows, cols, shift = 400, 640, 6

    def tex(corr, std, w):
        b = cv2.GaussianBlur(rng.normal(0, 1, (rows, w)).astype(np.float32), (0, 0), corr)
        return b * std / b.std()
    wide = cols + shift
    shade = np.zeros((rows, wide), bool)
    shade[:, int(wide * 0.9):] = True
    mean = np.maximum(np.where(shade, 100 + tex(2, 40, wide), 3000 + tex(4, 10, wide)), 1)
    left = rng.poisson(mean[:, shift:]).astype(np.float32) / 4
    right = rng.poisson(mean[:, :cols]).astype(np.float32) / 4
    ok = np.ones((rows, cols), bool)
    noise = (noise_sigma([left], [ok]), noise_sigma([right], [ok]))
    area = np.zeros((rows, cols), bool)
    area[10:-10, int(wide * 0.9) - shift + 10:cols - 10] = True
    before = np.isfinite(disparity(left, right, ok, ok, -16, 16)) & area
    d = disparity(left, right, ok, ok, -16, 16, noise=noise)
    got = np.isfinite(d) & area
    assert before.mean() > 0.02  # the shadow has matches to keep
    assert got.sum() >= 0.95 * before.sum(), (got.sum(), before.sum())
    assert (np.abs(np.abs(d[got]) - shift) < 1).mean() > 0.99
