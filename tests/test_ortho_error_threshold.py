"""Orthorectification's interpolated cell positions (``error_threshold``, like ``gdalwarp -et``): on a rendered frame
over a DEM with a cliff and a hole, and on a real NGI frame, every cell's interpolated position is within the
threshold of the exact one (NaN where it is NaN); 0 gives the exact path's orthophoto byte for byte; a negative
threshold is a one-line error."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio
from affine import Affine
from click.testing import CliRunner

import fotogeo.geometry.lattice as lattice
from fotogeo.cli import main
from fotogeo.io.warp import windows_of
from fotogeo.tools.ortho.crs_rule import map_crs
from fotogeo.tools.ortho.inputs import image_models, terrain
from fotogeo.tools.ortho.tool import OrthoMapping, ortho, plan_grid
from test_bad_input import assert_one_line_error

CENTRE = (500100.0, 4200050.0)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """A tilted Brown frame (1200 x 800 px, about 14 cm on the ground) over a 4-m DEM: hills, a 25-m cliff along an
    oblique line, a 2 x 2-cell nodata hole."""
    d = tmp_path_factory.mktemp("et")
    rng = np.random.default_rng(5)
    img = rng.integers(0, 255, (3, 800, 1200), dtype=np.uint8)
    with rasterio.open(d / "frame.tif", "w", driver="GTiff", width=1200, height=800, count=3, dtype="uint8") as ds:
        ds.write(img)
    (d / "camera.yaml").write_text("cam:\n  type: brown\n  im_size: [1200, 800]\n  focal_len: 800.0\n"
                                   "  sensor_size: [1200.0, 800.0]\n  cx: 0.004\n  cy: -0.003\n  k1: -0.21\n"
                                   "  k2: 0.09\n  p1: 0.0017\n  p2: -0.0023\n  k3: -0.012\n")
    (d / "eo.txt").write_text(f"frame {CENTRE[0]} {CENTRE[1]} 260.0 4.0 -7.0 33.0\n")
    n, cell = 100, 4.0
    t = Affine(cell, 0, CENTRE[0] - 200, 0, -cell, CENTRE[1] + 200)
    X, Y = t * np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5)
    x, y = X - CENTRE[0], Y - CENTRE[1]
    z = 150 + 10 * np.sin(x / 40) * np.cos(y / 30) + 25.0 * (x + 0.6 * y > 15)
    z[47:49, 55:57] = -9999.0
    with rasterio.open(d / "dem.tif", "w", driver="GTiff", width=n, height=n, count=1, dtype="float32",
                       crs="EPSG:32635", transform=t, nodata=-9999.0) as ds:
        ds.write(z.astype(np.float32), 1)
    return {k: str(d / f) for k, f in (("frame", "frame.tif"), ("camera", "camera.yaml"), ("eo", "eo.txt"),
                                       ("dem", "dem.tif"))}


def _windows(frame, dem, camera, eo, res, tol, every=1):
    """Per window of the frame's grid at ``res``: the positions with ``error_threshold=tol`` and the exact ones."""
    crs = map_crs("auto", dem, eo, [frame], False, camera, None, "auto")[0]
    im = image_models([frame], crs, camera=camera, eo=eo, rpc=False, model=None, sfm_frame="auto", said=[])[0]
    heights = terrain(dem, None, crs, [im])[0]
    g = plan_grid(im, heights, crs, res, "unused.tif", dem)
    approx, exact = (OrthoMapping(im.model, heights, (im.width, im.height), error_threshold=e) for e in (tol, 0))
    return [(approx.grid(g.transform, *w), exact.grid(g.transform, *w))
            for w in windows_of(g.height, g.width, 512)[::every]]


def _check(pairs, tol):
    """Every cell within ``tol`` px, NaN alike; returns the share of windows interpolated and the largest error."""
    worst, used = 0.0, 0
    for a, e in pairs:
        assert e.dtype == np.float64 and a.shape == e.shape
        used += a.dtype == np.float32  # interpolated (the exact path gives float64)
        assert np.array_equal(np.isnan(a), np.isnan(e))
        err = np.hypot(*(a.astype(np.float64) - e))
        worst = max(worst, float(np.nanmax(err)) if np.isfinite(err).any() else 0.0)
    assert worst <= tol, worst
    return used / len(pairs), worst


@pytest.mark.parametrize("tol", [0.125, 0.03, 0.5])
def test_rendered_positions_within_the_threshold(rendered, tol):
    pairs = _windows(rendered["frame"], rendered["dem"], rendered["camera"], rendered["eo"], 0.2, tol)
    share, worst = _check(pairs, tol)
    assert share >= 0.5 and worst > 0.1 * tol  # interpolated, not exact by the back door
    assert any(np.isnan(e).any() for _, e in pairs)  # the hole (and the frame's edge) were on the grid


def test_cliff_cells_fall_back_to_exact(rendered):
    """Where the interpolation cannot follow the DEM (the cliff's ramp, the hole's edge), the cells are exact: some
    interpolated windows hold exact cells, and a threshold nothing meets gives the exact positions everywhere."""
    pairs = _windows(rendered["frame"], rendered["dem"], rendered["camera"], rendered["eo"], 0.2, 0.125)
    mixed = [np.mean(np.isclose(a, e, rtol=0, atol=1e-3).all(axis=0)) for a, e in pairs if a.dtype == np.float32]
    assert any(0 < m < 1 for m in mixed)
    for a, e in _windows(rendered["frame"], rendered["dem"], rendered["camera"], rendered["eo"], 0.2, 1e-9):
        assert np.array_equal(a, e, equal_nan=True)


def test_zero_is_the_exact_path_byte_for_byte(rendered, tmp_path, monkeypatch):
    """``error_threshold=0``: the orthophoto equals one resampled through the exact positions written out here (the
    DEM per row and column, the frame's separable projection), and the lattice is never asked."""
    from fotogeo.geometry.dem import Dem
    from fotogeo.io.warp import warp_to_grid
    crs = map_crs("auto", rendered["dem"], rendered["eo"], [rendered["frame"]], False, rendered["camera"], None,
                  "auto")[0]
    im = image_models([rendered["frame"]], crs, camera=rendered["camera"], eo=rendered["eo"], rpc=False, model=None,
                      sfm_frame="auto", said=[])[0]
    heights = terrain(rendered["dem"], None, crs, [im])[0]
    assert isinstance(heights, Dem)

    class Exact:
        def __call__(self, XY):
            raise AssertionError("the window grid is asked")

        def grid(self, t, r0, c0, h, w):
            X, Y = t.c + (c0 + 0.5 + np.arange(w)) * t.a, t.f + (r0 + 0.5 + np.arange(h)) * t.e
            return im.model.forward_grid(X, Y, heights.heights_grid(X, Y))

    calls = []
    real = lattice.piecewise_on_lattice
    monkeypatch.setattr("fotogeo.tools.ortho.tool.piecewise_on_lattice", lambda *a, **k: calls.append(1) or real(
        *a, **k))
    rep = ortho([rendered["frame"]], str(tmp_path / "zero.tif"), dem=rendered["dem"], camera=rendered["camera"],
                eo=rendered["eo"], resolution=0.2, resampling="bilinear", error_threshold=0)
    assert not calls
    r = rep["images"]["frame"]
    warp_to_grid(rendered["frame"], tmp_path / "exact.tif", Exact(), crs=crs, transform=Affine(*r["transform"]),
                 width=r["width"], height=r["height"], resampling="bilinear", reduce=True)
    ortho([rendered["frame"]], str(tmp_path / "approx.tif"), dem=rendered["dem"], camera=rendered["camera"],
          eo=rendered["eo"], resolution=0.2, resampling="bilinear")
    assert calls  # the default interpolates
    with rasterio.open(tmp_path / "zero.tif") as a, rasterio.open(tmp_path / "exact.tif") as b, \
            rasterio.open(tmp_path / "approx.tif") as c:
        za, zb, zc = a.read(), b.read(), c.read()
    assert np.array_equal(za, zb)
    assert not np.array_equal(za, zc)  # the default's positions differ slightly, so some pixels do


def test_ngi_frame_positions_within_the_threshold(data_dir):
    """A real frame (NGI 0182, 1152 x 640 px DMC, on the 24-m DEM) at 1 m: within 0.125 px everywhere."""
    ngi = data_dir / "ngi"
    pairs = _windows(str(ngi / "frames" / "3324c_2015_1004_05_0182_RGB.tif"), str(ngi / "dem.tif"),
                     str(ngi / "interior_orientation.yaml"), str(ngi / "exterior_orientation.txt"), 1.0, 0.125,
                     every=3)
    share, worst = _check(pairs, 0.125)
    assert share >= 0.5 and worst > 0


def test_negative_threshold_is_one_line(rendered, tmp_path):
    out = tmp_path / "o.tif"
    result = CliRunner().invoke(main, ["ortho", rendered["frame"], "--camera", rendered["camera"], "--eo",
                                       rendered["eo"], "--dem", rendered["dem"], "-o", str(out), "-q",
                                       "--error-threshold", "-0.1"])
    assert_one_line_error(result, "error-threshold")
    assert not out.exists()


def test_dem_breaks_are_its_cell_centre_lines_and_edges():
    """The kinks a window's lattice follows: the grid crosses the DEM's lines of cell centres and its edges there, and
    between two of them the heights are linear along the row (bilinear in the cell)."""
    from fotogeo.geometry.dem import Dem
    rng = np.random.default_rng(1)
    dem = Dem(rng.random((6, 8)) * 50, Affine(2.0, 0, 100.0, 0, -2.0, 200.0))
    X = 99.3 + 0.13 * np.arange(140)  # from west of the DEM to east of it
    Y = 199.1 - 0.07 * np.arange(3)
    cols, rows = dem.breaks_grid(X, Y)
    Xb = 99.3 + 0.13 * cols
    expected = 100.0 + 2.0 * np.r_[0.0, np.arange(8) + 0.5, 8.0]  # west edge, the 8 centre lines, east edge
    np.testing.assert_allclose(Xb, expected, atol=1e-9)
    assert rows.size == 1 and abs(199.1 - 0.07 * rows[0] - 199.0) < 1e-9  # the first row of centres
    z = dem.heights_grid(X, Y)[1]
    inside = np.isfinite(z)
    between = np.searchsorted(cols, np.arange(140))
    for k in np.unique(between[inside]):
        seg = z[(between == k) & inside]
        if len(seg) >= 3:
            np.testing.assert_allclose(np.diff(seg, 2), 0, atol=1e-9)
