"""Coarse-to-fine disparity search (fotogeo.stereo.pyramid): the coarse disparities' offset and band, the
disparities found against the resampled right image turned back into the pair's, and a rendered pair matched
coarse to fine as accurately as over its whole range."""
from __future__ import annotations

import cv2
import numpy as np

from fotogeo.stereo import pyramid
from fotogeo.tools.dsm import frames

from dsm_scenes import compare, make_scene


def test_resolve_gives_the_pairs_disparity_exactly():
    """Right image resampled by ``D0(x) = 50 + 0.1 x``: a pixel ``x`` whose true disparity is ``d`` meets ``x'``
    with ``x' − D0(x') = x − d``; ``resolve`` of ``d' = x − x'`` gives ``d`` back."""
    cols = 200
    x = np.arange(cols, dtype=float)
    D0 = np.tile((50.0 + 0.1 * x).astype(np.float32), (3, 1))
    d = 55.0 + 0.1 * x + 3.0 * np.sin(x / 17.0)
    xp = (x - d + 50.0) / 0.9
    dprime = np.tile((x - xp).astype(np.float32), (3, 1))
    dprime[1, 7] = np.nan
    out = pyramid.resolve(dprime, D0)
    inside = (xp >= 0) & (xp <= cols - 1)
    assert np.allclose(out[0][inside], d[inside], atol=1e-3)
    assert np.isnan(out[1, 7])


def test_fill_holes_keeps_the_values_and_fills_from_the_surroundings():
    yy, xx = np.mgrid[0:60, 0:90].astype(np.float32)
    plane = 3.0 + 0.5 * xx - 0.25 * yy
    d = plane.copy()
    d[10:30, 20:50] = np.nan
    d[45:, :10] = np.nan
    f = pyramid.fill_holes(d)
    known = np.isfinite(d)
    assert np.isfinite(f).all()
    assert np.array_equal(f[known], d[known])
    assert np.abs(f - plane)[~known].max() < 0.25 * np.ptp(plane)  # a surface through the hole, not a constant
    assert np.isnan(pyramid.fill_holes(np.full((4, 4), np.nan))).all()


def test_guide_follows_a_slope_with_a_narrow_band():
    """Coarse disparities on a plane rising 150 px (full resolution) across the piece: the offset follows the
    plane, the band's half-width is that of the slope over the envelope's window plus the pad, not the range."""
    f = pyramid.FACTOR
    rows, cols = 96, 400
    yy, xx = np.mgrid[0:rows // f, 0:cols // f].astype(np.float32)
    dc = (20.0 + 37.5 * xx / (cols // f)).astype(np.float32)  # coarse px: 37.5 over the piece's 100 columns
    dc[5:7, 30:40] = np.nan
    valid = np.ones((rows, cols), bool)
    D0, R = pyramid.guide(dc, (rows, cols), valid)
    assert D0.shape == (rows, cols)
    full = f * (20.0 + 37.5 * ((np.arange(cols) + 0.5) / f - 0.5) / (cols // f))
    assert np.abs(D0[40, 20:-20] - full[20:-20]).max() < 0.5
    step = 37.5 / (cols // f)
    band = f * (pyramid.RADIUS * step + pyramid.PAD)
    assert band - 0.2 <= R <= band + f * step  # the smoothing bends the ramp at the piece's borders a little
    assert 2 * R < 0.15 * f * 37.5
    assert pyramid.guide(np.full_like(dc, np.nan), (rows, cols), valid) is None


def test_witness_refuses_a_match_the_right_pixels_coarse_match_contradicts():
    """Left pixels matched within a band: one whose right pixel's coarse disparity (the whole range's) agrees is
    kept, one it contradicts is refused; a right pixel without a coarse disparity is witnessed by its neighbours'
    (kept where ``d`` lies within their envelope, refused beyond it or without any near), and near a border
    (``near_border``) by its own only."""
    f = pyramid.FACTOR
    rows, cols = 16, 160
    dc_right = np.full((rows // f, cols // f), 5.0, np.float32)  # coarse px: 20 full px everywhere
    d = np.full((rows, cols), 20.0, np.float32)
    d[0, 40] = 20.0 + 2 * f * pyramid.WITNESS + 1  # a wrong match: its right pixel's coarse match says 20
    d[0, 50] = 21.0
    dc_right[1, 5] = np.nan  # no coarse match for the right pixels 20..23 of rows 4..7 (met from x 40..43)
    d[5, 41] = 20.0 + 2 * f * pyramid.WITNESS + 1  # in that hole, beyond its neighbours' envelope
    dc_right[:, 25:] = np.nan  # right pixels 100.. without a coarse match: a gap as wide as the image's rest
    out = pyramid.witnessed(d, dc_right)
    assert np.isnan(out[0, 40]) and out[0, 50] == 21.0 and out[0, 60] == 20.0
    assert out[4, 40] == 20.0 and out[4, 44] == 20.0 and np.isnan(out[5, 41])
    n = pyramid.WITNESS_NEAR
    assert out[0, 120 + 4 * n - 1] == 20.0 and np.isnan(out[0, 120 + 4 * n])  # right pixel 100 + 4 n: none near
    border = np.zeros((rows, cols), bool)
    border[4:8, :] = True
    strict = pyramid.witnessed(d, dc_right, near_border=border)
    assert np.isnan(strict[4, 40]) and strict[4, 44] == 20.0 and strict[0, 50] == 21.0
    assert np.isnan(pyramid.witnessed(np.full((rows, cols), np.nan, np.float32), dc_right)).all()


def test_fill_unsupported_matches_the_needing_pixels_over_the_whole_range():
    """A textured pair shifted by 37 px: the needing pixels get the whole range's disparity, the others stay."""
    rng = np.random.default_rng(3)
    rows, cols, shift = 96, 260, 37
    right = cv2.GaussianBlur(rng.uniform(0, 255, (rows, cols + shift)).astype(np.float32), (0, 0), 1.2)
    left, right = right[:, :cols].copy(), right[:, shift:].copy()  # left(x) = right(x - shift)
    valid = np.ones((rows, cols), bool)
    d = np.full((rows, cols), np.nan, np.float32)
    d[:, :100] = 5.0
    need = np.zeros((rows, cols), bool)
    need[40:70, 150:200] = True
    windows = pyramid.fill_windows(need, 0.0, 100.0)
    out, searched = pyramid.fill_unsupported(d, left, right, valid, valid, need, windows)
    assert np.array_equal(out[:, :100], d[:, :100]) and np.isnan(out[:, 200:]).all()
    got = out[need]
    assert np.isfinite(got).mean() > 0.9 and np.nanmax(np.abs(got - shift)) < 1.0
    assert searched > 0 and searched % 112 == 0  # window pixels x the range's 112 disparities
    assert pyramid.fill_cost(windows) == searched  # the estimate the choice of the search reads
    assert pyramid.fill_windows(np.zeros_like(need), 0.0, 100.0) == []
    # the windows derived once for more pixels than end up needing a fill: those without any are not matched
    same, none = pyramid.fill_unsupported(d, left, right, valid, valid, np.zeros_like(need), windows)
    assert none == 0 and np.array_equal(same, d, equal_nan=True)


def test_fill_windows_join_a_band_down_the_border_into_one_window():
    """Needing pixels in a band 30 columns wide down 384 rows (an image's border): the blocks' runs are joined
    into one window whose core holds every needing pixel, costing less than a window per block; two bands far
    apart stay two windows (a window over both would search the columns between)."""
    rows, cols = 384, 900
    need = np.zeros((rows, cols), bool)
    need[:, 100:130] = True
    windows = pyramid.fill_windows(need, 0.0, 100.0)
    assert len(windows) == 1
    covered = np.zeros_like(need)
    for r, c in windows[0].cores:
        covered[r, c] = True
    assert np.array_equal(covered & need, need)
    per_block = pyramid.FillWindow([], (0, pyramid.FILL_ROWS, 100, 130), 0.0, 100.0, need.shape)
    assert pyramid.fill_cost(windows) < (rows // pyramid.FILL_ROWS) * per_block.cost
    need[:, 700:730] = True
    assert len(pyramid.fill_windows(need, 0.0, 100.0)) == 2


def _run(sc, out, report):
    from fotogeo.tools.dsm import dsm
    rep = dsm(sc["images"][:2], out, camera=sc["camera"], eo=sc["eo"], crs=sc["crs"], report=report)
    return rep, compare(out, sc["surface"])


def test_rendered_pair_coarse_to_fine_as_accurate_as_its_whole_range(tmp_path, monkeypatch):
    """Two frames of the held-out block (±60 m of relief), every strip coarse to fine (switched on, no minimum
    range, whatever it saves: by default ranges this narrow are searched whole), against the same run over the strips' whole ranges: the
    RMSE within a tenth of a GSD of it and within a GSD. Completeness is allowed 8
    points less: the coarse copies of these 400-px frames match under half of their pixels, and at the rectified
    image's right border the band's last columns go unmatched (docs/benchmarks/dsm.md)."""
    sc = make_scene("held_out", tmp_path / "scene")
    monkeypatch.setattr(pyramid, "MIN_RANGE", 0)
    monkeypatch.setattr(pyramid, "MIN_COARSE", 0)
    monkeypatch.setattr(pyramid, "GAIN", np.inf)  # forced: by default a strip whose search would not shrink by half is matched whole
    monkeypatch.setattr(frames, "COARSE_TO_FINE", True)
    rep, ctf = _run(sc, tmp_path / "ctf.tif", tmp_path / "ctf.json")
    pair = next(p for p in rep["pairs"] if p["kept"])
    used, strips = (int(x) for x in pair["coarse_to_fine_strips"].split(" of "))
    assert strips >= 1 and used == strips, pair["coarse_to_fine_strips"]
    monkeypatch.setattr(frames, "COARSE_TO_FINE", False)
    rep_w, whole = _run(sc, tmp_path / "whole.tif", tmp_path / "whole.json")
    pair_w = next(p for p in rep_w["pairs"] if p["kept"])
    assert pair_w["coarse_to_fine_strips"] == f"0 of {strips}"
    # no assertion on the disparities searched: on these 400-px frames the whole-range fill of the pixels near the
    # borders costs more than the band saves (docs/benchmarks/dsm.md)
    assert ctf["rmse"] <= whole["rmse"] + 0.1 * sc["gsd"], (ctf, whole)
    assert ctf["rmse"] <= sc["gsd"]
    assert rep["completeness"] >= rep_w["completeness"] - 0.08


def test_a_strip_where_coarse_to_fine_would_not_pay_is_searched_whole(tmp_path, monkeypatch):
    """With the gate shut (``GAIN = 0``: no search is small enough) every strip goes through the coarse step (the
    left image's copy only: its band alone fails the gate) and is then matched over its whole range: the DSM is the
    switched-off one byte for byte, and the report counts the coarse search on top of the whole range's."""
    sc = make_scene("held_out", tmp_path / "scene")
    monkeypatch.setattr(pyramid, "MIN_RANGE", 0)
    monkeypatch.setattr(pyramid, "MIN_COARSE", 0)
    monkeypatch.setattr(pyramid, "GAIN", 0.0)
    monkeypatch.setattr(frames, "COARSE_TO_FINE", True)
    sides, coarse = [], pyramid.coarse_disparity
    monkeypatch.setattr(pyramid, "coarse_disparity", lambda *a, **k: sides.append(  # main's: right_too=True
        "both" if k.get("right_too") else k.get("side", "left")) or coarse(*a, **k))
    rep, _ = _run(sc, tmp_path / "gated.tif", tmp_path / "gated.json")
    assert sides and set(sides) == {"left"}  # the band alone fails the gate: the right copy is never matched
    monkeypatch.setattr(frames, "COARSE_TO_FINE", False)
    rep_w, _ = _run(sc, tmp_path / "whole.tif", tmp_path / "whole.json")
    pair, pair_w = (next(p for p in r["pairs"] if p["kept"]) for r in (rep, rep_w))
    assert pair["coarse_to_fine_strips"].startswith("0 of ")
    assert pair["disparities_searched"] > pair_w["disparities_searched"]
    assert (tmp_path / "gated.tif").read_bytes() == (tmp_path / "whole.tif").read_bytes()
