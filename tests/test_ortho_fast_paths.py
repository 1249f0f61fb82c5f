"""The fast paths of orthorectification give the values of the plain ones: a frame's positions on a window's grid
(two planes, Brown's terms a block of rows at a time) equal its per-point model; a source read whole into memory
gives the windowed reads' pixels; overviews built before the file is closed equal those built on the reopened file."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio

import fotogeo.io.warp_source as warp_source
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
from fotogeo.io.warp import add_overviews
from fotogeo.orientation.adjusted_frame import AdjustedFrame
from test_warp_parallel import _read, _source, _warp

BROWN = {"k1": -0.21, "k2": 0.09, "k3": -0.012, "p1": 0.0017, "p2": -0.0023}


def _frame(distortion):
    camera = FrameCamera(focal_length=8.8, sensor_size=(13.2, 8.8), image_size=(5472, 3648))
    eo = ExteriorOrientation(500100.0, 4200050.0, 260.0, 4.0, -7.0, 33.0)
    return AdjustedFrame(camera, eo, distortion)


@pytest.mark.parametrize("distortion", [{}, BROWN, {"k1": -0.05}, {"p2": 0.004}, {**BROWN, "b3": 1e-5}],
                         ids=["pinhole", "brown", "k1", "p2", "ebner"])
def test_grid_positions_equal_the_per_point_model(distortion):
    m = _frame(distortion)
    rng = np.random.default_rng(3)
    X = 500100.0 - 90 + 0.25 * np.arange(700)  # 700 x 75 cells: several row blocks and a partial one
    Y = 4200050.0 + 10 - 0.4 * np.arange(75)
    Z = 150 + 30 * rng.random((75, 700))
    Z[5, 7] = 900.0  # above the camera: behind it
    g = m.forward_grid(X, Y, Z)
    XX, YY = np.meshgrid(X, Y)
    ref = m.forward(np.column_stack([XX.ravel(), YY.ravel(), Z.ravel()]))
    assert g.shape == (2, 75, 700)
    assert np.isnan(g[:, 5, 7]).all() and np.isnan(ref[5 * 700 + 7]).all()
    ok = np.isfinite(ref[:, 0])
    assert ok.sum() == ref.shape[0] - 1
    np.testing.assert_allclose(g.reshape(2, -1).T[ok], ref[ok], rtol=0, atol=1e-9)
    assert np.ptp(ref[ok, 0]) > 1000  # the window spans much of the frame, where the distortion is large


@pytest.mark.parametrize("dtype,bands,nodata,holes", [("uint8", 3, None, False), ("uint8", 3, 0, True),
                                                       ("int16", 1, -9, True), ("float32", 2, None, True),
                                                       ("uint16", 4, None, False)])
@pytest.mark.parametrize("resampling", ["nearest", "bilinear", "cubic"])
def test_whole_source_in_memory_gives_the_windowed_pixels(tmp_path, monkeypatch, dtype, bands, nodata, holes,
                                                          resampling):
    src = tmp_path / "s.tif"
    _source(src, dtype, bands=bands, nodata=nodata, holes=holes)
    read = []
    real = warp_source.whole_source

    def spy(*a, **k):
        r = real(*a, **k)
        read.append(r is not None)
        return r

    monkeypatch.setattr("fotogeo.io.warp.whole_source", spy)
    whole = _warp(src, tmp_path / "whole.tif", 2, resampling, block=64)
    monkeypatch.setattr("fotogeo.io.warp.whole_source", lambda *a, **k: None)
    windowed = _warp(src, tmp_path / "windowed.tif", 2, resampling, block=64)
    assert read == [True] and whole == windowed
    a, b = _read(tmp_path / "whole.tif"), _read(tmp_path / "windowed.tif")
    np.testing.assert_array_equal(a[0], b[0])
    assert repr(a[1]) == repr(b[1]) and a[2] == b[2]


def test_a_source_above_the_budget_is_read_window_by_window(tmp_path):
    _source(tmp_path / "s.tif", "uint8", bands=3, size=(300, 260))
    with rasterio.open(tmp_path / "s.tif") as src:
        from fotogeo.io.warp import make_plan
        plan = make_plan(src, lambda xy: xy, src.transform)
        assert warp_source.whole_source(src, plan, budget=300 * 260 * 3 - 1) is None
        pixels, mask = warp_source.whole_source(src, plan, budget=300 * 260 * 3)
        assert pixels.shape == (300, 260, 3) and mask is None
        np.testing.assert_array_equal(np.moveaxis(pixels, 2, 0), src.read())


@pytest.mark.parametrize("resampling", ["nearest", "bilinear"])
def test_overviews_built_before_closing_equal_those_of_the_reopened_file(tmp_path, resampling, monkeypatch):
    monkeypatch.setattr("fotogeo.io.warp.OVERVIEW_MIN", 64)  # several levels on this small output
    _source(tmp_path / "s.tif", "uint8", nodata=0, holes=True, size=(600, 520))
    _warp(tmp_path / "s.tif", tmp_path / "open.tif", 2, resampling, block=64)
    _warp(tmp_path / "s.tif", tmp_path / "later.tif", 2, resampling, block=64, overviews=False)
    with rasterio.open(tmp_path / "later.tif", "r+") as ds:
        add_overviews(ds, ds.width, ds.height, resampling)
    with rasterio.open(tmp_path / "open.tif") as a, rasterio.open(tmp_path / "later.tif") as b:
        assert a.overviews(1) == b.overviews(1) and len(a.overviews(1)) >= 2
        for level in range(len(a.overviews(1))):
            h, w = a.height // a.overviews(1)[level], a.width // a.overviews(1)[level]
            np.testing.assert_array_equal(a.read(out_shape=(a.count, h, w)), b.read(out_shape=(b.count, h, w)))
        np.testing.assert_array_equal(a.read(), b.read())


@pytest.mark.parametrize("shape, factors", [((1030, 1100), [2, 4]), ((2066, 2080), [2, 4, 8]),
                                            ((783, 1397), [2]), ((511, 4000), [2]), ((60000, 448), [2, 4, 8, 16, 32])])
def test_overview_ladder_stops_where_the_level_is_256_px_on_its_short_side(tmp_path, shape, factors):
    """orthority's ladder (docs/benchmarks/products.md): on main the levels went on down to 128 px ([2, 4, 8] for
    1030 x 1100, [2, 4] for 783 x 1397, [2] for 511 x 4000). Outputs over 4:1 keep levels while the long side keeps
    1024 px: a 448 x 60000 corridor got none on int19 622ee5c (its short side is under 512 px), 511 x 4000 none."""
    h, w = shape
    with rasterio.open(tmp_path / "o.tif", "w", driver="GTiff", width=w, height=h, count=1, dtype="uint8",
                       tiled=True, blockxsize=256, blockysize=256) as ds:
        ds.write(np.zeros((1, h, w), np.uint8))
        add_overviews(ds, w, h, "bilinear")
    with rasterio.open(tmp_path / "o.tif") as ds:
        assert ds.overviews(1) == factors


def test_the_source_is_read_with_one_gdal_decoding_thread(tmp_path, monkeypatch):
    """Whole or window by window, the source is read with ``GDAL_NUM_THREADS=1`` whatever fotogeo's thread count
    (GDAL's decoding pool cost a TIFF of one-row strips several times the read's CPU time; docs/benchmarks/
    products.md); the overviews keep their threads. On main the reads saw "3"."""
    from rasterio.env import get_gdal_config
    import fotogeo.io.warp as warp
    seen = []

    def spy(real):
        def wrapped(*a, **k):
            seen.append(str(get_gdal_config("GDAL_NUM_THREADS")))
            return real(*a, **k)
        return wrapped

    _source(tmp_path / "s.tif", "uint8", bands=3, size=(300, 260))
    monkeypatch.setattr(warp, "whole_source", spy(warp.whole_source))
    monkeypatch.setattr(warp, "add_overviews", spy(warp.add_overviews))
    monkeypatch.setattr(warp, "OVERVIEW_MIN", 64)
    _warp(tmp_path / "s.tif", tmp_path / "whole.tif", 3, "bilinear", block=64)
    monkeypatch.setattr(warp, "whole_source", lambda *a, **k: None)
    monkeypatch.setattr(warp, "_source_window", spy(warp._source_window))
    _warp(tmp_path / "s.tif", tmp_path / "windowed.tif", 3, "bilinear", block=64)
    assert seen[0] == "1" and seen[1] == "3" and set(seen[2:-1]) == {"1"} and seen[-1] == "3" and len(seen) > 4


def test_keep_freed_memory_is_a_process_setting_that_reports_itself():
    assert warp_source.keep_freed_memory() is True  # glibc (Linux): mallopt accepts both values
