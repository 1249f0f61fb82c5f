"""Area-based matching: NCC, LSM, pyramids, GCP transfer (fotogeo.matching).

Shifted/rotated/scaled search images are made from real orthophoto / Landsat patches by
exact float64 Lanczos-4 resampling from a known corner-convention affine (see ``warp``);
array indices are reached only through fotogeo.pixels.to_centre.
"""
from __future__ import annotations

import cv2
import numpy as np
from synthetic_images import warp
import pytest

from fotogeo.errors import InputError
from fotogeo.matching import (
    build_pyramid,
    from_level,
    lsm,
    lsm_many,
    ncc,
    pyramid_match,
    to_level,
    transfer_points,
)
from fotogeo.pixels import pixel_centres

rasterio = pytest.importorskip("rasterio")


def _grey(path, rows, cols):
    with rasterio.open(path) as ds:
        a = ds.read().astype(np.float64).mean(axis=0)
    a = a[rows, cols]
    assert (a > 0).all(), "test crop must not contain nodata"
    return cv2.GaussianBlur(a, (0, 0), 0.8)  # mild low-pass: makes cubic resampling near-exact


@pytest.fixture(scope="module")
def ortho(data_dir):
    return _grey(data_dir / "ngi" / "ortho" / "ngi_rgb_byte_1.tif", slice(500, 800), slice(250, 550))


@pytest.fixture(scope="module")
def landsat(data_dir):
    return _grey(data_dir / "landsat_rgb" / "RGB.byte.tif", slice(300, 500), slice(150, 350))


def affine(shift=(0.0, 0.0), angle_deg=0.0, scale=1.0, centre=(150.0, 150.0)):
    """2x3 corner-convention affine x_search = M x_ref + t, rotating/scaling about ``centre``."""
    a = np.deg2rad(angle_deg)
    M = scale * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    c = np.asarray(centre, dtype=np.float64)
    t = c - M @ c + np.asarray(shift, dtype=np.float64)
    return np.column_stack([M, t])


def apply(A, xy):
    xy = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    return xy @ A[:, :2].T + A[:, 2]


def grid_points(n, lo, hi, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(lo, hi, (n, 2))


# -- the half-pixel convention ------------------------------------------------------------


def blob(shape, centre, sigma=2.5, amplitude=100.0):
    X, Y = pixel_centres(shape[1], shape[0])
    return 20.0 + amplitude * np.exp(-((X - centre[0]) ** 2 + (Y - centre[1]) ** 2) / (2 * sigma ** 2))


def test_half_pixel_convention_lsm_and_ncc():
    """A blob centred on pixel [15, 15] is at (15.5, 15.5); one centred on the pixel corner
    (20, 30) must be found at (20.0, 30.0) — not at (19.5, 29.5) or (20.5, 30.5)."""
    ref = blob((40, 40), (15.5, 15.5))
    assert np.unravel_index(np.argmax(ref), ref.shape) == (15, 15)
    sea = blob((50, 45), (20.0, 30.0))
    # a round blob fixes no rotation: match its shift (the affine model converges slowly)
    r = lsm(ref, sea, (15.5, 15.5), (20.4, 29.7), half_window=7, model="shift")
    assert r.ok, r.status
    np.testing.assert_allclose(r.xy, [20.0, 30.0], atol=0.01)
    n = ncc(ref, sea, (15.5, 15.5), (21.5, 28.5), half_window=7, search_radius=4)
    assert n.ok, n.status
    np.testing.assert_allclose(n.xy, [20.0, 30.0], atol=0.15)


def test_identity_match_returns_the_same_coordinates(ortho):
    for p in [(100.5, 120.5), (100.0, 120.0), (100.25, 120.75)]:
        n = ncc(ortho, ortho, p, np.add(p, 1.0), half_window=8, search_radius=4)
        # integer peak exact; the parabola through a non-symmetric peak moves it slightly
        assert n.ok and n.ncc > 0.999 and np.allclose(n.xy, p, atol=0.1), (p, n)
        r = lsm(ortho, ortho, p, np.add(p, 0.6))
        assert r.ok and np.allclose(r.xy, p, atol=2e-3), (p, r)


def test_pyramid_level_coordinates():
    """pyrDown keeps pixel 2j (centre convention) as pixel j: level coordinates are
    (x - 0.5) / 2**k + 0.5 in the corner convention; a blob must land there."""
    np.testing.assert_allclose(to_level([[0.5, 0.5], [8.5, 4.5]], 1), [[0.5, 0.5], [4.5, 2.5]])
    np.testing.assert_allclose(from_level(to_level([[3.3, 7.9]], 3), 3), [[3.3, 7.9]])
    centre = (40.5, 36.5)  # centre-convention (40, 36): even -> exactly on a level-1 pixel
    img = blob((80, 80), centre, sigma=4.0)
    pyr = build_pyramid(img, 2)
    for k in (1, 2):
        lev = pyr[k] - 20.0
        X, Y = pixel_centres(lev.shape[1], lev.shape[0])
        w = lev / lev.sum()
        np.testing.assert_allclose([(w * X).sum(), (w * Y).sum()], to_level([centre], k)[0], atol=0.02)


# -- recovery of known transformations on real images ---------------------------------------


@pytest.mark.parametrize("interpolation", ["bilinear", "bicubic"])
def test_lsm_recovers_subpixel_affine_on_orthophoto(ortho, interpolation):
    A = affine(shift=(2.37, -1.61), angle_deg=6.0, scale=1.07)
    sea = warp(ortho, A)
    pts = grid_points(60, 60, 240, seed=1)
    truth = apply(A, pts)
    rng = np.random.default_rng(2)
    b = lsm_many(ortho, sea, pts, truth + rng.uniform(-1.0, 1.0, truth.shape), half_window=10,
                 interpolation=interpolation)
    assert b.ok.mean() > 0.95, np.unique(b.status, return_counts=True)
    err = b.xy[b.ok] - truth[b.ok]
    assert np.sqrt((err ** 2).mean()) < 0.05
    assert np.abs(err).max() < 0.15
    # affine parameters: the Jacobian of A
    np.testing.assert_allclose(np.median(b.affine[b.ok][:, :, :2], axis=0), A[:, :2], atol=0.01)


def test_lsm_half_turn_with_approximate_jacobian(ortho):
    """Frames are rotated ~180° against the orthophotos: LSM starts from the given Jacobian."""
    A = affine(shift=(0.37, -0.21), angle_deg=183.0, scale=0.9)
    sea = warp(ortho, A)
    pts = grid_points(30, 90, 210, seed=11)
    truth = apply(A, pts)
    b = lsm_many(ortho, sea, pts, truth + [0.8, -0.6], approx_jacobian=-np.eye(2) * 0.9)
    assert b.ok.mean() > 0.9, np.unique(b.status, return_counts=True)
    assert np.sqrt(((b.xy[b.ok] - truth[b.ok]) ** 2).mean()) < 0.05
    np.testing.assert_allclose(np.median(b.affine[b.ok][:, :, :2], axis=0), A[:, :2], atol=0.01)
    # without the Jacobian the identity start cannot reach a half turn
    assert not lsm_many(ortho, sea, pts[:5], truth[:5]).ok.any()


def test_lsm_radiometric_change_and_uint8_input(landsat):
    A = affine(shift=(-0.43, 0.71), angle_deg=-3.0, scale=0.95, centre=(100.0, 100.0))
    sea = warp(landsat, A)
    sea8 = np.clip(np.round(0.6 * sea + 40.0), 0, 255).astype(np.uint8)
    pts = grid_points(30, 50, 150, seed=3)
    truth = apply(A, pts)
    b = lsm_many(landsat, sea8, pts, np.round(truth) + 0.5)
    assert b.ok.mean() > 0.9, np.unique(b.status, return_counts=True)
    err = b.xy[b.ok] - truth[b.ok]
    assert np.sqrt((err ** 2).mean()) < 0.05
    # f ≈ r0 + r1·g with g = 0.6 f + 40  ->  r1 ≈ 1/0.6, r0 ≈ -40/0.6
    np.testing.assert_allclose(np.median(b.radiometry[b.ok], axis=0), [-40 / 0.6, 1 / 0.6], rtol=0.05)


def test_lsm_sigma_predicts_error_under_noise(ortho):
    """σ from σ0²·N⁻¹ must describe the real scatter: the bulk of normalised errors e/σ
    (robust spread) near 1 and the RMSE within a factor 2 of the RMS σ."""
    rng = np.random.default_rng(7)
    A = affine(shift=(0.3, -0.45), angle_deg=3.0, scale=1.03)
    ref = ortho + rng.normal(0, 2.0, ortho.shape)
    sea = warp(ortho, A) + rng.normal(0, 2.0, ortho.shape)
    pts = grid_points(150, 40, 260, seed=8)
    truth = apply(A, pts)
    b = lsm_many(ref, sea, pts, truth + 0.5, half_window=10)
    ok = b.ok
    assert ok.mean() > 0.9
    err = b.xy[ok] - truth[ok]
    z = err / b.sigma[ok]
    robust = 1.4826 * np.median(np.abs(z), axis=0)
    assert np.all((robust > 0.7) & (robust < 1.5)), robust
    ratio = np.sqrt((err ** 2).mean(axis=0)) / np.sqrt((b.sigma[ok] ** 2).mean(axis=0))
    assert np.all((ratio > 0.7) & (ratio < 2.0)), ratio


def test_ncc_recovers_shift_on_landsat(landsat):
    A = affine(shift=(3.4, -2.2))
    sea = warp(landsat, A)
    for p in [(60.5, 70.5), (120.5, 90.5), (100.5, 140.5)]:
        r = ncc(landsat, sea, p, p, half_window=10, search_radius=8)
        assert r.ok, r.status
        assert r.ncc > 0.95
        np.testing.assert_allclose(r.xy, apply(A, p)[0], atol=0.2)


def test_transfer_points_with_poor_approximation(ortho):
    A = affine(shift=(17.3, -21.6), angle_deg=2.0)
    sea = warp(ortho, A)
    pts = grid_points(25, 80, 220, seed=4)
    truth = apply(A, pts)
    approx = truth + np.random.default_rng(5).uniform(-12, 12, truth.shape) - [17.3, -21.6]
    res = transfer_points(ortho, sea, pts, approx, search_radius=40)
    assert res.levels >= 2
    assert res.ok.mean() > 0.9, np.unique(res.status, return_counts=True)
    err = res.xy[res.ok] - truth[res.ok]
    assert np.sqrt((err ** 2).mean()) < 0.05
    one = pyramid_match(ortho, sea, pts[0], approx[0], search_radius=40)
    assert one.ok and np.allclose(one.xy, truth[0], atol=0.1)


# -- failure modes: explicit statuses -------------------------------------------------------


def test_flat_patch(ortho):
    img = ortho.copy()
    img[100:140, 100:140] = 77.0
    assert ncc(img, ortho, (120.5, 120.5), (120.5, 120.5)).status == "flat patch"
    assert lsm(img, ortho, (120.5, 120.5), (120.5, 120.5)).status == "flat patch"
    noise = np.random.default_rng(0).normal(100, 3, (120, 120))
    r = lsm(noise, np.random.default_rng(1).normal(100, 3, (120, 120)), (60.5, 60.5), (60.5, 60.5))
    assert not r.ok and np.isnan(r.xy).all(), r.status


def test_repetitive_pattern_is_ambiguous():
    X, Y = pixel_centres(160, 160)
    stripes = 100 + 50 * np.sin(2 * np.pi * X / 7.0) + 0.5 * np.sin(2 * np.pi * Y / 23.0)
    r = ncc(stripes, stripes, (80.5, 80.5), (81.5, 80.5), half_window=8, search_radius=12)
    assert r.status == "ambiguous" and r.ambiguity > 0.9


def test_window_at_image_edge(ortho):
    assert ncc(ortho, ortho, (3.5, 50.5), (3.5, 50.5), half_window=5).status == "window outside image"
    assert lsm(ortho, ortho, (50.5, 2.5), (50.5, 2.5), half_window=5).status == "window outside image"
    # reference fine, search window leaves the image
    r = lsm(ortho, ortho, (150.5, 150.5), (296.5, 150.5), half_window=5)
    assert r.status == "window outside image"


def test_nodata_inside_window(ortho):
    bad = ortho.copy()
    bad[148, 152] = np.nan
    for ref, sea in [(bad, ortho), (ortho, bad)]:
        assert lsm(ref, sea, (150.5, 150.5), (150.5, 150.5)).status == "nodata in window"
    assert ncc(bad, ortho, (150.5, 150.5), (150.5, 150.5)).status == "nodata in window"
    mask = np.ones(ortho.shape, bool)
    mask[150, 150] = False
    assert lsm(ortho, ortho, (150.5, 150.5), (150.5, 150.5), search_mask=mask).status == "nodata in window"
    # nodata in the search area but not under the best template position: still matches
    r = ncc(ortho, bad, (165.5, 160.5), (165.5, 160.5), half_window=8, search_radius=8, keep_surface=True)
    assert r.ok and np.allclose(r.xy, (165.5, 160.5), atol=0.1), r.status
    assert np.isinf(r.surface).any()  # the positions touching the NaN were excluded


def test_approximation_too_far_off(ortho):
    A = affine(shift=(25.0, 0.0))
    sea = warp(ortho, A)
    p = np.array([120.5, 140.5])
    r = ncc(ortho, sea, p, p, half_window=8, search_radius=10)
    assert not r.ok and r.status in ("peak at search border", "low correlation"), r.status
    far = lsm(ortho, sea, p, p)
    assert not far.ok, far.status
    assert np.isnan(far.xy).all()
    # a few pixels off: either it converges to the truth or it says it failed
    for off in (3.0, 5.0, 7.0):
        m = lsm(ortho, sea, p, apply(A, p)[0] + [off, -off])
        assert (not m.ok) or np.allclose(m.xy, apply(A, p)[0], atol=0.1), (off, m)


def test_transfer_progress_and_cancel(ortho):
    from fotogeo.errors import Cancelled

    seen = []
    pts = grid_points(5, 80, 220, seed=6)
    transfer_points(ortho, ortho, pts, pts + 3.0, search_radius=8, progress=lambda f, m: seen.append(f))
    assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)
    with pytest.raises(Cancelled):
        transfer_points(ortho, ortho, pts, pts + 3.0, search_radius=8, progress=lambda f, m: f < 0.5)


def test_transfer_reports_stage_of_failure(ortho):
    bad = ortho.copy()
    bad[90:110, 90:110] = np.nan
    res = transfer_points(ortho, bad, [[100.5, 100.5], [200.5, 200.5]], [[101.0, 99.0], [201.0, 199.0]],
                          search_radius=8)
    assert "nodata" in res.status[0] and res.status[0].startswith("ncc level")
    assert res.status[1] == "converged"


# -- bad input -> InputError naming the argument --------------------------------------------


@pytest.mark.parametrize("call, word", [
    (lambda im: ncc(np.dstack([im, im]), im, (50, 50), (50, 50)), "reference"),
    (lambda im: lsm(im, im.astype(complex), (50, 50), (50, 50)), "search"),
    (lambda im: lsm(im, im, (50, 50, 1), (50, 50)), "ref_xy"),
    (lambda im: lsm(im, im, (50, 50), (np.nan, 50)), "approx_xy"),
    (lambda im: lsm(im, im, (50, 50), (50, 50), interpolation="cubic"), "interpolation"),
    (lambda im: lsm(im, im, (50, 50), (50, 50), half_window=1), "half_window"),
    (lambda im: ncc(im, im, (50, 50), (50, 50), max_ambiguity=2), "max_ambiguity"),
    (lambda im: lsm(im, im, (50, 50), (50, 50), search_mask=np.ones((3, 3), bool)), "search_mask"),
    (lambda im: lsm_many(im, im, [[1, 2]], [[1, 2], [3, 4]]), "approx_xy"),
    (lambda im: transfer_points(im, im, [[1, 2]], [[1, 2]], search_radius=0), "search_radius"),
])
def test_bad_input_raises_input_error(call, word):
    im = np.random.default_rng(0).normal(100, 10, (100, 100))
    with pytest.raises(InputError, match=word):
        call(im)
