"""Area-based co-registration (fotogeo.coreg, fotogeo.tools.coreg.tool): known fields removed,
seasonal and multi-sensor pairs registered, bad input refused in one line.

Scenes with a known field come from tests/coreg_scenes.py: ``target(q) = source(q + E(q))``
exactly (float64 cubic), the correcting field ``D(p) = −E(p + D(p))``.
"""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import rasterio
from affine import Affine

import coreg_scenes as cs
from fotogeo.coreg import (ArraySource, CoregOptions, coregister_strips, fit_field, match_windows,
                           phase_correlate, represent, window_grid)
from fotogeo.errors import Cancelled, InputError, MatchingError, OutputError
from fotogeo.models import get_model
from fotogeo.tools.coreg.tool import coregister


def _read_field(path):
    with rasterio.open(path) as ds:
        return ds.read().astype(np.float64)


def _node_truth(D, E, step):
    """True field at the centres of the field raster's nodes (step px apart)."""
    y, x = (np.mgrid[0:D.shape[1], 0:D.shape[2]] + 0.5) * step
    return x, y, cs.true_field(E, x, y)


def _near(x, y, shifts_path, radius):
    """Nodes within ``radius`` px of a reliable window (the field is measured there)."""
    import geopandas as gpd
    from scipy.spatial import cKDTree
    w = gpd.read_file(shifts_path)
    ok = (w.status == "ok").to_numpy()
    d, _ = cKDTree(np.c_[w.col[ok], w.row[ok]]).query(np.c_[x.ravel(), y.ravel()])
    return d.reshape(x.shape) <= radius


# -- the array layer ------------------------------------------------------------------------------

def test_phase_correlation_and_lsm_measure_a_subpixel_shift(data_dir):
    """A constant fractional shift of real texture: phase correlation finds it to the pixel,
    LSM on the gradient orientation to 0.02 px (the interpolation of the scene itself)."""
    src = cs.s2_crop()
    for shift in [(0.3, -0.2), (2.25, -1.75)]:
        tgt = cs.warp(src, cs.sinusoid(amplitude=0.0, offset=shift))
        g = window_grid((80, 80, src.shape[1] - 80, src.shape[0] - 80), 96, 128)  # windows inside the image
        res = match_windows(src, tgt, g.xy, window=128)
        assert res.ok.sum() >= 0.9 * len(g)
        err = res.shift[res.ok] + np.array(shift)  # the correcting shift is −E
        assert np.abs(err).max() < 0.03 and np.hypot(*err.T).mean() < 0.02
    w = src[200:328, 200:328][None]
    p = phase_correlate(w, src[197:325, 205:333][None])
    assert np.allclose(p.shift, [[-5, 3]], atol=0.05) and p.ratio[0] > 3  # f(x) = g(x + shift)


def test_representation_ignores_contrast_inversion_and_gain(data_dir):
    src = cs.s2_crop()[:200, :200]
    z = represent(src)
    assert np.allclose(z, represent(255.0 - src), atol=1e-4)
    assert np.allclose(z, represent(3.0 * src + 7.0), atol=1e-4)


def test_field_reproduces_the_global_model_and_fades_far_from_windows():
    m = get_model("affine").estimate(np.array([[0, 0], [100, 0], [0, 100], [100, 100.0]]),
                                     np.array([[1, 2], [101.1, 2.2], [0.8, 102], [101, 102.1]]))
    xy = np.stack(np.meshgrid(np.arange(50, 450, 50.0), np.arange(50, 450, 50.0)), -1).reshape(-1, 2)
    shift = m.forward(xy) - xy
    fld, w = fit_field(m, xy, shift, np.ones(len(xy)), width=500, height=500, spacing=50)
    dx, dy = fld.block(0, 0, 500, 500)
    yy, xx = np.mgrid[0:500, 0:500] + 0.5
    truth = m.forward(np.c_[xx.ravel(), yy.ravel()]) - np.c_[xx.ravel(), yy.ravel()]
    assert np.abs(dx.ravel() - truth[:, 0]).max() < 1e-4 and np.abs(dy.ravel() - truth[:, 1]).max() < 1e-4
    assert (w > 0).all()


def test_tiled_field_equals_the_truth_like_one_spline():
    """3600 windows (above TILE_POINTS): the tiles of the spline blend without seams."""
    E = cs.sinusoid(amplitude=1.5, wavelength=3000.0, offset=(0.4, -0.3))
    xs = np.arange(60) * 100 + 50.0
    xy = np.stack(np.meshgrid(xs, xs), -1).reshape(-1, 2)
    shift = np.stack(cs.true_field(E, xy[:, 0], xy[:, 1]), 1) + np.random.default_rng(0).normal(0, 0.02, xy.shape)
    m = get_model("affine").estimate(xy, xy + shift)
    fld, w = fit_field(m, xy, shift, np.ones(len(xy)), width=6000, height=6000, spacing=100, step=32)
    D = fld.inside()
    y, x = (np.mgrid[0:D.shape[1], 0:D.shape[2]] + 0.5) * 32
    err = np.hypot(*(D - np.stack(cs.true_field(E, x, y))))[4:-4, 4:-4]
    assert (w > 0).all() and np.sqrt((err ** 2).mean()) < 0.03 and err.max() < 0.1


def test_robust_field_rejects_a_wrong_window():
    m = get_model("affine").estimate(np.array([[0, 0], [1, 0], [0, 1.0]]), np.array([[0, 0], [1, 0], [0, 1.0]]))
    xy = np.stack(np.meshgrid(np.arange(50, 450, 50.0), np.arange(50, 450, 50.0)), -1).reshape(-1, 2)
    shift = np.zeros_like(xy) + np.random.default_rng(0).normal(0, 0.02, xy.shape)
    shift[20] = [0.8, -0.6]
    fld, w = fit_field(m, xy, shift, np.ones(len(xy)), width=500, height=500, spacing=50)
    assert w[20] == 0 and (w > 0).sum() >= len(xy) - 2
    assert np.abs(fld.at(xy[20:21])).max() < 0.05


# -- (a) a known smooth local distortion is removed to <= 0.1 px --------------------------------

def test_sinusoidal_distortion_removed_to_a_tenth_of_a_pixel(data_dir):
    """Sentinel-2 crop, a 2-px ripple of 400-px wavelength plus an offset; dense error of the
    field against the truth on every pixel between the outermost windows."""
    src = cs.s2_crop()
    E = cs.sinusoid(amplitude=2.0, wavelength=400.0)
    tgt = cs.warp(src, E)
    H, W = src.shape
    opts = CoregOptions(grid_spacing=32, window=128)
    g = window_grid((0, 0, W, H), opts.grid_spacing, opts.window)
    res = coregister_strips(g, ArraySource(src, tgt), W, H, opts)
    assert res.reliable.sum() >= 0.9 * len(g)
    x0, y0 = 64, 64
    y, x = np.mgrid[y0:H - 64, x0:W - 64] + 0.5
    tx, ty = cs.true_field(E, x, y)
    fx, fy = res.field.block(y0, x0, H - 128, W - 128)
    err = np.hypot(fx - tx, fy - ty)
    assert np.sqrt((err ** 2).mean()) <= 0.1, np.sqrt((err ** 2).mean())
    assert np.percentile(err, 99) <= 0.3


def test_tool_removes_the_distortion_and_writes_its_outputs(data_dir, tmp_path):
    """The ripple of the test above through the tool, on the top 700 rows of the crop (1.75 wavelengths down,
    2 across; the whole crop is the array test's)."""
    src = cs.s2_crop()[:700]
    E = cs.sinusoid(amplitude=2.0, wavelength=400.0)
    ref = cs.write_geotiff(tmp_path / "ref.tif", src)
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", cs.warp(src, E))
    out, shifts, field = tmp_path / "out.tif", tmp_path / "shifts.gpkg", tmp_path / "field.tif"
    seen = []
    rep = coregister(ref, tgt, out, grid_spacing=32, window=128, shifts=shifts, field=field,
                     progress=lambda f, m: seen.append(f) or True)
    assert rep["windows"]["reliable"] >= 0.9 * rep["windows"]["total"]
    assert rep["after"]["rms"] < 0.1 and rep["before"]["rms"] > 1.5
    assert seen[-1] == 1.0 and all(b >= a for a, b in zip(seen, seen[1:]))
    D = _read_field(field)
    x, y, (tx, ty) = _node_truth(D, E, 16)
    near = _near(x, y, shifts, 32) & (x > 64) & (x < src.shape[1] - 64) & (y > 64) & (y < src.shape[0] - 64)
    err = np.hypot(D[0] - tx, D[1] - ty)[near]
    assert np.sqrt((err ** 2).mean()) <= 0.1
    with rasterio.open(out) as o, rasterio.open(tgt) as t:
        assert (o.width, o.height, o.crs, o.transform, o.dtypes) == (t.width, t.height, t.crs, t.transform, t.dtypes)
        corrected = o.read(1).astype(np.float64)
    inner = (slice(100, -100), slice(100, -100))
    # the corrected target is the reference again (cubic resampling twice, 8-bit scene)
    before = np.nanmean(np.abs(cs.warp(src, E)[inner] - src[inner]))
    assert np.nanmean(np.abs(corrected[inner] - src[inner])) < 0.3 * before


# -- (b) seasonal and multi-sensor pairs ----------------------------------------------------------

def test_seasonal_sensor_pair_where_feature_matching_fails(data_dir, tmp_path):
    """Landsat red against blue, gamma 0.6, inverted, blurred, noisy, under a rotation, scale,
    shift and ripple: SURF and SIFT registration find 4-5 inliers among 30-52 matches
    (benchmarks/coreg_bench.py); the gradient orientation registers it."""
    ref_a, tgt_a, E = cs.seasonal_landsat()
    ref = cs.write_geotiff(tmp_path / "ref.tif", ref_a, dtype="uint8")
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", tgt_a, dtype="uint8")
    rep = coregister(ref, tgt, tmp_path / "out.tif", grid_spacing=32, window=128, shifts=tmp_path / "s.gpkg",
                     field=tmp_path / "f.tif")
    assert rep["windows"]["reliable"] >= 200
    D = _read_field(tmp_path / "f.tif")
    x, y, (tx, ty) = _node_truth(D, E, 16)
    err = np.hypot(D[0] - tx, D[1] - ty)[_near(x, y, tmp_path / "s.gpkg", 32)]
    assert np.sqrt((err ** 2).mean()) <= 0.3, np.sqrt((err ** 2).mean())
    with pytest.raises(MatchingError):  # the plain grey values: no window correlates
        coregister(ref, tgt, None, grid_spacing=32, window=128, representation="intensity")


def test_orthophoto_against_sentinel2_other_sensor_and_pixel_size(data_dir, tmp_path):
    """NGI 5-m orthophoto (target) against the Sentinel-2 10-m scene (reference, read on the
    target's grid by averaging): another sensor, date, sun and pixel size."""
    ref = shutil.copy(cs.S2_CROP, tmp_path / "s2.tif")
    tgt = shutil.copy(cs.NGI_ORTHO, tmp_path / "ngi.tif")
    rep = coregister(ref, tgt, tmp_path / "out.tif", grid_spacing=64, window=128)
    assert rep["reference_resampling"] == "cubic"  # 10 m read on a 5 m grid
    assert rep["windows"]["reliable"] >= 150
    assert rep["after"]["rms"] < 0.3
    with rasterio.open(tmp_path / "out.tif") as o, rasterio.open(tgt) as t:
        assert (o.count, o.transform, o.nodata) == (t.count, t.transform, t.nodata)


def test_two_dates_with_clouds_keep_more_windows_than_arosics(data_dir, tmp_path):
    """s2_pair (one date cloudy), AROSICS' own test pair: with its 100-px grid and 256-px
    windows AROSICS keeps 322 of 454 points; fotogeo keeps more, and what its field leaves at
    them is below 0.1 px (CE90)."""
    d = cs.S2_PAIR
    ref = shutil.copy(d / "ref_S2A_20160608T153121_T33UUU_sub.jp2", tmp_path / "ref.jp2")
    tgt = shutil.copy(d / "tgt_S2A_20160529T153631_T33UUU_sub.jp2", tmp_path / "tgt.jp2")
    rep = coregister(ref, tgt, None, grid_spacing=100, window=256, reference_nodata=0, target_nodata=0)
    assert rep["windows"]["reliable"] > 322
    assert 1.7 < rep["before"]["median"] < 2.2  # the real misregistration, ~(0.6, -1.8) px
    assert rep["after"]["ce90"] < 0.1


# -- (c) bad input ----------------------------------------------------------------------------

def test_no_overlap_is_refused_in_one_line(data_dir, tmp_path):
    src = cs.s2_crop()[:300, :300]
    ref = cs.write_geotiff(tmp_path / "ref.tif", src)
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", src, transform=Affine(10.0, 0, 500000.0, 0, -10.0, 5800000.0))
    with pytest.raises(MatchingError, match=r"do not overlap: 0 valid windows of 0") as e:
        coregister(ref, tgt, tmp_path / "out.tif")
    assert "\n" not in str(e.value) and not (tmp_path / "out.tif").exists()


def test_featureless_windows_are_refused_with_the_count(tmp_path):
    flat = np.full((400, 400), 100.0)
    ref = cs.write_geotiff(tmp_path / "ref.tif", flat + np.random.default_rng(1).normal(0, 5, flat.shape))
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", flat + np.random.default_rng(2).normal(0, 5, flat.shape))
    with pytest.raises(MatchingError) as e:
        coregister(ref, tgt, tmp_path / "out.tif", grid_spacing=64, window=128, shifts=tmp_path / "s.gpkg")
    msg = str(e.value)
    assert "\n" not in msg and "0 reliable windows of 49" in msg and "try larger windows" in msg
    assert not (tmp_path / "out.tif").exists() and not (tmp_path / "s.gpkg").exists()


def test_too_few_reliable_windows_refused_never_a_wild_field(data_dir, tmp_path):
    src = cs.s2_crop()[:400, :400]
    ref = cs.write_geotiff(tmp_path / "ref.tif", src)
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", cs.warp(src, cs.sinusoid(amplitude=0.5)))
    with pytest.raises(MatchingError, match=r"only \d+ reliable windows of 16 .*at least 40 are needed"):
        coregister(ref, tgt, tmp_path / "out.tif", grid_spacing=100, window=128, min_windows=40)


def test_band_out_of_range_and_bad_outputs_are_named(data_dir, tmp_path):
    src = cs.s2_crop()[:300, :300]
    ref = cs.write_geotiff(tmp_path / "ref.tif", src)
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", src)
    with pytest.raises(InputError, match=r"target_band 3 is out of range: .* has 1 band \(1..1\)"):
        coregister(ref, tgt, tmp_path / "out.tif", target_band=3)
    with pytest.raises(OutputError, match="is also an input"):
        coregister(ref, tgt, tgt)
    with pytest.raises(InputError, match="window"):
        coregister(ref, tgt, tmp_path / "out.tif", window=8)
    with pytest.raises(InputError, match="window must be an even number of pixels .* got 129, use 130"):
        coregister(ref, tgt, tmp_path / "out.tif", window=129)


def test_cancel_leaves_no_output(data_dir, tmp_path):
    src = cs.s2_crop()[:400, :400]
    ref = cs.write_geotiff(tmp_path / "ref.tif", src)
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", cs.warp(src, cs.sinusoid(amplitude=0.5)))
    calls = []
    with pytest.raises(Cancelled):
        coregister(ref, tgt, tmp_path / "out.tif", grid_spacing=64, window=128, field=tmp_path / "f.tif",
                   progress=lambda f, m: calls.append(f) or f < 0.9)
    assert calls and sorted(p.name for p in tmp_path.iterdir()) == ["ref.tif", "tgt.tif"]


def test_refusal_hints_stay_within_the_image_and_speak_the_dialogs_words(tmp_path):
    """A 400 px image: window 256 is not told to double to 512 but to try the image's 400; the QGIS dialog reads
    the options by their labels (no API names such as min_peak_ratio)."""
    from fotogeo.options.table import in_labels
    from fotogeo.options.coreg import COREG
    flat = np.full((400, 400), 100.0)
    ref = cs.write_geotiff(tmp_path / "ref.tif", flat + np.random.default_rng(1).normal(0, 5, flat.shape))
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", flat + np.random.default_rng(2).normal(0, 5, flat.shape))
    with pytest.raises(MatchingError) as e:
        coregister(ref, tgt, tmp_path / "out.tif", grid_spacing=64, window=256)
    msg = str(e.value)
    assert "larger windows (--window 400, the image's size)" in msg and "512" not in msg
    assert "--grid-spacing 32, now 64" in msg and "min_peak_ratio" not in msg
    dialog = in_labels(msg, COREG)
    assert "--" not in dialog and f"“{COREG['window'].label}”" in dialog


def test_georeferences_farther_apart_than_max_shift_are_told_max_shift(data_dir, tmp_path):
    """A target whose georeference is 7 px off (s2_pair crop, --max-shift 5): the refusal names --max-shift with a
    value that works (10) instead of only window sizes, bands and thresholds, which change nothing here."""
    src = cs.s2_crop()[:400, :400]
    ref = cs.write_geotiff(tmp_path / "ref.tif", src)
    tgt = cs.write_geotiff(tmp_path / "tgt.tif", src, transform=Affine(10.0, 0.0, 400070.0, 0.0, -10.0, 5800000.0))
    with pytest.raises(MatchingError) as e:
        coregister(ref, tgt, tmp_path / "out.tif", grid_spacing=64, window=128)
    assert "\n" not in str(e.value) and "--max-shift 10, now 5" in str(e.value)
    rep = coregister(ref, tgt, tmp_path / "out.tif", grid_spacing=64, window=128, max_shift=10)
    assert abs(rep["before"]["mean_dx"] - 7) < 0.1 and abs(rep["before"]["mean_dy"]) < 0.1
