"""fotogeo dsm on frames: a pixel without a partner is not matched to another without one
(:func:`fotogeo.stereo.dense.disparity`'s ``partner``, filled from :func:`fotogeo.tools.dsm.local.expected_disparity`).
At the bottom rows of a cross-strip oblique pair's rectified images the two images' valid columns do not overlap at
the surface's disparity; the left pixels whose partner lies outside the right image met right pixels whose partner
lies outside the left one, real texture on both sides, at one wrong disparity that passed the left–right check.
The strips' local heights (``local.strip_heights``) dropped the band where it fell outside them; here they are
switched off, so that what is measured is the matching itself (the −55° set flown east and south: the band lay
inside the local heights)."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.stereo import dense
from fotogeo.tools.dsm import dsm, frames, matching

from dsm_oblique_sets import CRS, ORIGIN, SETS, make_set


class _Stop(Exception):
    pass


def _pair_match(sc, monkeypatch, **kw):
    """The :class:`~fotogeo.tools.dsm.matching.PairMatch` and grid ``fotogeo dsm`` sets up for the set ``sc``
    (stopped before matching; ``kw`` more of its options)."""
    got = {}

    def capture(grid, matches, *a, **k):
        got.update(grid=grid, matches=matches)
        raise _Stop

    monkeypatch.setattr(matching, "match_tiles", capture)
    with pytest.raises(_Stop):
        dsm(sc["images"], sc["images"][0].parent / "dsm.tif", camera=sc["camera"], eo=sc["eo"], crs=sc["crs"],
            **kw)
    (m,) = got["matches"]
    return m, got["grid"]


def _true_dem(sc, path, res: float = 2.0, half: float = 1500.0) -> str:
    """A GeoTIFF DEM of the set's true surface, ``res`` metres, ``half`` metres around the set's origin."""
    import rasterio
    from rasterio.transform import from_origin
    n = int(2 * half / res)
    X, Y = np.meshgrid(ORIGIN[0] - half + (np.arange(n) + 0.5) * res, ORIGIN[1] + half - (np.arange(n) + 0.5) * res)
    Z = sc["surface"](np.column_stack([X.ravel(), Y.ravel()])).reshape(n, n).astype(np.float32)
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs=CRS,
                       transform=from_origin(ORIGIN[0] - half, ORIGIN[1] + half, res, res)) as ds:
        ds.write(Z, 1)
    return str(path)


@pytest.mark.parametrize("with_dem", [False, True], ids=["sparse heights", "dem"])
def test_partnerless_pixels_stay_holes_without_the_local_heights(tmp_path, monkeypatch, with_dem):
    """Two frames of the 1280 x 960 oblique set from strips flown 90° apart (S1_01 north, S2_01 east, −60°), the
    last strip of their rectified pair, every point kept within the pair's heights (not the strip's): before, a
    band of points about 20 m too low (the partnerless rows); now under 1 % more than 2 m off, and the good
    points stay. With a DEM (``--dem``, of the true surface) each strip searches and expects the DEM's heights
    around it (:mod:`fotogeo.tools.dsm.dem_guide`). The DEM's wider height range gives another grid and rectified
    scale (0.98): this pair's last strip then holds the rows the images barely share (1189 matchable pixels), the
    same 45 points within 0.5 m from the DEM's heights as from the matches' (over the whole pair 95 % either way)."""
    sc = make_set({**SETS["1280x960 full"], "frames": ["S1_01", "S2_01"]}, tmp_path / "set")
    m, grid = _pair_match(sc, monkeypatch, **({"dem": _true_dem(sc, tmp_path / "dem.tif")} if with_dem else {}))
    assert m.near is not None and m.local and (m.dem is not None) is with_dem
    monkeypatch.setattr(frames, "strip_heights", lambda near, box, zlim, local, *a: zlim)
    u0, v0, u1, v1 = m.box(grid)
    r0 = v0 + (v1 - 1 - v0) // frames.STRIP * frames.STRIP  # the last strip
    P = np.vstack([p for p, _ in m.dense((u0, r0, u1, v1))])
    err = np.abs(P[:, 2] - sc["surface"](P[:, :2]))
    assert (err > 2.0).mean() < 0.01, f"{(err > 2.0).sum()} of {len(err)} points more than 2 m off"
    assert (err <= 0.5).sum() > (30 if with_dem else 1000)


def test_a_pixel_with_a_partner_keeps_it_when_the_expected_disparity_errs():
    """Rendered texture, the right image the left shifted by 100 px, the valid areas overlapping over 60 columns:
    with the expected disparity right, or 30 px off, the overlap's pixels are matched as without it (the fill is
    blurred, ``dense.PARTNER_BLUR``: a true partner beats the copy) and none wrongly."""
    import cv2
    from fotogeo.orientation.block_render import texture
    rng = np.random.default_rng(3)
    tex = cv2.resize(texture(rng, (240, 1800)), (900, 120), interpolation=cv2.INTER_AREA)
    rows, cols, D = 120, 600, 100
    left = (tex[:, :cols] + rng.normal(0, 2, (rows, cols))).astype(np.float32)
    right = (tex[:, D:D + cols] + rng.normal(0, 2, (rows, cols))).astype(np.float32)
    vl, vr = np.zeros((rows, cols), bool), np.zeros((rows, cols), bool)
    vl[:, 300:560], vr[:, 20:260] = True, True
    plain = np.isfinite(dense.disparity(left, right, vl, vr, 0, 360)).sum()
    for g in (100.0, 70.0, 130.0):
        d = dense.disparity(left, right, vl, vr, 0, 360, partner=np.full((rows, cols), g, np.float32))
        ok = np.isfinite(d)
        assert not (ok & (np.abs(d - D) > 2)).any()
        assert ok.sum() >= 0.85 * plain, (g, ok.sum(), plain)


def test_the_right_images_coarse_pass_gets_the_partner_fill_too():
    """The coarse-to-fine step's right pass (``pyramid.coarse_disparity(side="right")``, the witness of the fine
    disparities and the test of the unsupported pixels) is the left pass of the mirrored pair, the partner fill
    included: each right pixel's expected disparity is :func:`dense.right_expected` of the left pixels' (main
    before this test gave the right pass no fill: its pixels without a partner met the left's without one)."""
    import cv2
    from fotogeo.orientation.block_render import texture
    from fotogeo.stereo import pyramid
    rng = np.random.default_rng(5)
    rows, cols, D = 160, 640, 120
    tex = cv2.resize(texture(rng, (320, 1600)), (cols + D, rows), interpolation=cv2.INTER_AREA)
    left = (tex[:, :cols] + rng.normal(0, 2, (rows, cols))).astype(np.float32)
    right = (tex[:, D:D + cols] + rng.normal(0, 2, (rows, cols))).astype(np.float32)
    vl, vr = np.zeros((rows, cols), bool), np.zeros((rows, cols), bool)
    vl[:, 320:600], vr[:, 40:300] = True, True  # partners only for left 320-420 / right 200-300
    g = np.full((rows, cols), float(D), np.float32)
    gr = dense.right_expected(g)
    assert np.isnan(gr[:, cols - D:]).all() and (gr[:, :cols - D] == D).all()
    dr = pyramid.coarse_disparity(left, right, vl, vr, 0, 400, side="right", partner=g)
    mirrored = pyramid.coarse_disparity(right[:, ::-1], left[:, ::-1], vr[:, ::-1], vl[:, ::-1], 0, 400,
                                        side="left", partner=gr[:, ::-1])
    both = np.isfinite(dr) | np.isfinite(mirrored[:, ::-1])
    assert both.any() and np.allclose(dr[both], mirrored[:, ::-1][both], equal_nan=False), \
        f"{int((np.isfinite(dr) != np.isfinite(mirrored[:, ::-1])).sum())} right pixels differ"
