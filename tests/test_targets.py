"""X-shaped fiducial / calibration targets (fotogeo.matching.measure_target), seed 000."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from fotogeo.errors import InputError
from fotogeo.matching import measure_target, synthetic_x_target
from fotogeo.pixels import pixel_centres


def make_target(rng, centre, angles=(45.0, 135.0), width=3.0, target=200.0, background=50.0,
                blur=0.7, noise=2.0, size=81):
    """A realistic target image: area-sampled at 16x16, blurred (optics), noisy, uint8."""
    img = synthetic_x_target((size, size), centre, width, angles, target, background, supersample=16)
    img = cv2.GaussianBlur(img, (0, 0), blur) + rng.normal(0, noise, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def test_synthetic_target_centre_is_where_it_says():
    """The generator itself: a disc-limited X has its grey-value centroid at the centre
    (corner convention), so the tests below measure against a true position."""
    c = (30.37, 28.81)
    img = synthetic_x_target((60, 60), c, 3.0, (45.0, 135.0), 1.0, 0.0, radius=20.0, supersample=16)
    X, Y = pixel_centres(60, 60)
    w = img / img.sum()
    np.testing.assert_allclose([(w * X).sum(), (w * Y).sum()], c, atol=0.01)
    # a centre on a pixel centre gives a mirror-symmetric image about that pixel
    sym = synthetic_x_target((41, 41), (20.5, 20.5), 3.0, (45.0, 135.0))
    np.testing.assert_allclose(sym, sym[::-1, ::-1])
    np.testing.assert_allclose(sym, sym[:, ::-1])


def test_x_targets_within_five_hundredths_of_a_pixel():
    rng = np.random.default_rng(42)
    errors = []
    for _ in range(25):
        centre = np.array([40.0, 40.0]) + rng.uniform(-0.5, 0.5, 2)
        rot = rng.uniform(-12, 12)
        angles = (45.0 + rot, 135.0 + rot + rng.uniform(-5, 5))
        img = make_target(rng, centre, angles, width=rng.uniform(2.5, 4.5))
        res = measure_target(img, centre + rng.uniform(-2.5, 2.5, 2))
        assert res.ok, res.status
        errors.append(res.xy - centre)
        assert np.all(res.sigma < 0.05)
        # MGL/MBGL are means of the classes (blurred edge pixels included): between the levels
        assert 140 < res.target_grey <= 205 and 45 < res.background_grey < 80
    errors = np.array(errors)
    assert np.abs(errors).max() < 0.05, np.abs(errors).max()
    assert np.sqrt((errors ** 2).mean()) < 0.02


def test_dark_target_and_approximate_edge_method():
    rng = np.random.default_rng(1)
    centre = np.array([35.62, 41.27])
    img = make_target(rng, centre, (40.0, 128.0), width=3.5, target=30.0, background=220.0, size=80)
    res = measure_target(img, centre + [2.0, -2.0], polarity="auto")
    assert res.ok, res.status
    assert np.hypot(*(res.approx_xy - centre)) < 0.3  # the edge method alone
    assert np.hypot(*(res.xy - centre)) < 0.05
    assert abs(res.arm_width - 3.5) < 0.5
    np.testing.assert_allclose(sorted(res.arm_angles), [40.0, 128.0], atol=2.0)


@pytest.mark.parametrize("angles", [(30.0, 120.0), (60.0, 150.0), (25.0, 110.0)])
def test_tilted_x_targets(angles):
    """The edge method scans rows and columns: X targets tilted by ±20° are found."""
    rng = np.random.default_rng(9)
    centre = np.array([40.21, 39.64])
    res = measure_target(make_target(rng, centre, angles, width=3.0), centre + [1.5, 1.0])
    assert res.ok, res.status
    assert np.hypot(*(res.xy - centre)) < 0.05


def test_plus_shaped_target_needs_its_shape():
    rng = np.random.default_rng(10)
    centre = np.array([40.21, 39.64])
    img = make_target(rng, centre, (5.0, 95.0), width=3.0)
    assert measure_target(img, centre + [1.0, -1.0]).status.startswith("edge method")
    res = measure_target(img, centre + [1.0, -1.0], arm_width=3.0, arm_angles=(5.0, 95.0))
    assert res.ok, res.status
    assert np.hypot(*(res.xy - centre)) < 0.05


def test_target_failures_are_reported():
    flat = np.full((60, 60), 100.0)
    assert measure_target(flat, (30, 30)).status.startswith("edge method")
    rng = np.random.default_rng(0)
    img = make_target(rng, (40.3, 40.6)).astype(float)
    assert measure_target(img, (5.0, 40.0)).status == "window outside image"
    img[38, 44] = np.nan
    assert measure_target(img, (40.3, 40.6)).status == "nodata in window"
    with pytest.raises(InputError, match="polarity"):
        measure_target(img, (40, 40), polarity="white")
    with pytest.raises(InputError, match="image"):
        measure_target(np.zeros((5, 5, 3)), (2, 2))
