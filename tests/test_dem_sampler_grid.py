"""A DEM in another CRS than the map's is sampled per output window on a lattice of exactly transformed points
(:meth:`fotogeo.geometry.dem.DemSampler.heights_grid`): the heights equal the per-point sampler's within the
interpolation's bound, refuse (None) when the bound is not met, and an orthophoto over such a DEM is the per-point
one's. Before, every output cell went through pyproj (NGI 5 m over a UTM copy of its DEM: 2.5 CPU s, orthority
1.7; docs/benchmarks/products.md)."""
from __future__ import annotations

import numpy as np
import pytest
from rasterio.transform import from_origin

from fotogeo.geometry import dem as dem_module
from fotogeo.geometry.dem import Dem, DemSampler
from fotogeo.tools.ortho.tool import OrthoMapping

LO25 = "+proj=tmerc +lat_0=0 +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs +type=crs"


def _utm_dem():
    """A rough 24 m DEM in UTM 35S (heights 1000-1400 m with cell-to-cell steps up to ~40 m) under NGI's area."""
    rng = np.random.default_rng(7)
    rows, cols = 300, 300
    y, x = np.mgrid[0:rows, 0:cols]
    z = 1200 + 150 * np.sin(x / 17.0) * np.cos(y / 23.0) + rng.normal(0, 12, (rows, cols))
    z[140:150, 60:75] = np.nan  # a hole
    return Dem(z, from_origin(680000.0, 6230000.0, 24.0, 24.0), "EPSG:32735")


def _window(sampler, size=(700, 530), res=5.0):
    """A window of Lo25 cell centres over the DEM (rows, columns), reaching past its edge."""
    from pyproj import Transformer
    x0, y0 = Transformer.from_crs("EPSG:32735", LO25, always_xy=True).transform(681000.0, 6229000.0)
    X = x0 + (np.arange(size[1]) + 0.5) * res
    Y = y0 - (np.arange(size[0]) + 0.5) * res
    return X, Y


def test_heights_grid_across_crss_is_the_per_point_sampler_within_its_bound():
    dem = _utm_dem()
    s = DemSampler(dem, LO25)
    X, Y = _window(s)
    grid = s.heights_grid(X, Y)
    XX, YY = np.meshgrid(X, Y)
    exact = s.heights(np.column_stack([XX.ravel(), YY.ravel()])).reshape(grid.shape)
    assert np.array_equal(np.isnan(grid), np.isnan(exact))  # the hole and the DEM's edge at the same cells
    assert np.isnan(exact).any() and np.isfinite(exact).sum() > 100_000
    step = np.nanmax(np.abs(np.diff(dem.data, axis=0)))  # the largest height step between neighbouring cells
    err = np.nanmax(np.abs(grid - exact))
    assert err <= dem_module.GRID_TOL_PX * max(step, np.nanmax(np.abs(np.diff(dem.data, axis=1)))) * 2
    assert err > 0  # interpolated, not transformed per point


def test_heights_grid_refuses_when_the_bound_is_not_met(monkeypatch):
    s = DemSampler(_utm_dem(), LO25)
    X, Y = _window(s)
    monkeypatch.setattr(dem_module, "GRID_TOL_PX", 0.0)
    assert s.heights_grid(X, Y) is None


def test_heights_grid_in_the_dems_own_crs_is_the_dems():
    dem = _utm_dem()
    X = 681000.0 + (np.arange(300) + 0.5) * 5.0
    Y = 6229000.0 - (np.arange(200) + 0.5) * 5.0
    assert np.array_equal(DemSampler(dem, "EPSG:32735").heights_grid(X, Y), dem.heights_grid(X, Y), equal_nan=True)


def test_frame_positions_over_a_dem_in_another_crs_are_the_per_cell_ones():
    """OrthoMapping.grid takes the sampler's grid of heights: the positions of a nadir frame's cells equal those
    of every cell's own height (per-point pyproj) within 0.001 image px."""
    from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
    from fotogeo.tools.triangulate.ortho import AdjustedFrame
    s = DemSampler(_utm_dem(), LO25)
    X, Y = _window(s, size=(400, 300))
    cam = FrameCamera(120.0, (92.16, 92.16), (4000, 4000))
    frame = AdjustedFrame(cam, ExteriorOrientation(X.mean(), Y.mean(), 6000.0, 0.3, -0.2, 10.0), {}, "f")
    m = OrthoMapping(frame, s, (4000, 4000))
    t = from_origin(X[0] - 2.5, Y[0] + 2.5, 5.0, 5.0)
    fast = m.grid(t, 0, 0, 400, 300)
    XX, YY = np.meshgrid(X, Y)
    slow = m(np.column_stack([XX.ravel(), YY.ravel()]))
    fast = fast.reshape(2, -1).T if fast.ndim == 3 else fast
    ok = np.isfinite(slow).all(axis=1)
    assert np.array_equal(ok, np.isfinite(fast).all(axis=1))
    assert np.abs(fast[ok] - slow[ok]).max() < 1e-3


@pytest.mark.parametrize("n", [1, 2, 65, 66, 130])
def test_with_middles(n):
    nodes = dem_module.lattice(n, 64)
    out = dem_module._with_middles(nodes)
    assert np.array_equal(out[::2], nodes) and len(out) == 2 * len(nodes) - 1
    assert ((out[:-1] <= out[1:])).all()


def test_bilinear_heights_alike_whatever_the_dems_memory_order():
    """The flat-index corners (a C-ordered DEM) and the 2-D ones (any other) give the same heights."""
    dem = _utm_dem()
    other = Dem(np.asfortranarray(dem.data), dem.transform, dem.crs)
    assert not other.data.flags.c_contiguous
    rng = np.random.default_rng(3)
    XY = np.column_stack([rng.uniform(679990, 687210, 5000), rng.uniform(6222790, 6230010, 5000)])
    h = dem.heights(XY)
    assert np.isnan(h).any() and np.isfinite(h).any()
    assert np.array_equal(h, other.heights(XY), equal_nan=True)
