"""The DEM's bilinear heights gather each cell's four corners with one index (:meth:`fotogeo.geometry.dem.Dem._quads`)
and a DEM in another CRS is sampled with one transformer per pair of CRSs (:func:`fotogeo.crs.transformer`) and one
transformation per gradient (:meth:`~fotogeo.geometry.dem.DemSampler.heights_and_gradient`): the same values as the
four gathers, the 2-D indexing and the five separate samplings (NGI 5 m over its DEM in UTM 35S: the heights of a
512² window 0.023 -> 0.011 CPU s; docs/benchmarks/products.md)."""
from __future__ import annotations

import pickle

import numpy as np
import pytest
from rasterio.transform import from_origin

from fotogeo.crs import transformer
from fotogeo.geometry import dem as dem_module
from fotogeo.geometry.dem import Dem, DemSampler

LO25 = "+proj=tmerc +lat_0=0 +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs +type=crs"


def _dem(order="C"):
    rng = np.random.default_rng(3)
    z = 1200 + np.cumsum(rng.normal(0, 9, (120, 90)), axis=1)
    z[50:54, 30:33] = np.nan  # a hole
    return Dem(np.asarray(z, order=order), from_origin(680000.0, 6230000.0, 24.0, 24.0), "EPSG:32735")


def _points(d, n=20000):
    rng = np.random.default_rng(4)
    t = d.transform
    return np.column_stack([rng.uniform(t.c - 30, t.c + 90 * 24 + 30, n), rng.uniform(t.f - 120 * 24 - 30, t.f + 30, n)])


def test_one_gather_per_cell_is_the_four_gathers_and_the_2d_indexing(monkeypatch):
    d = _dem()
    P = _points(d)
    quads = d.heights(P)
    assert d.__dict__.get("_quads_") is not None  # the one-gather path ran
    assert np.isnan(quads).any() and np.isfinite(quads).sum() > 15000  # the hole and the outside
    fortran = _dem("F")
    monkeypatch.setattr(dem_module, "QUAD_CELLS", 0)  # a DEM too large for the cache
    assert np.array_equal(quads, _dem().heights(P), equal_nan=True)  # the four gathers of the flat array
    assert not fortran.data.flags.c_contiguous
    assert np.array_equal(quads, fortran.heights(P), equal_nan=True)  # the 2-D indexing
    X, Y = np.linspace(680010, 682100, 300), np.linspace(6229990, 6227200, 200)
    monkeypatch.setattr(dem_module, "QUAD_CELLS", 1 << 22)
    XX, YY = np.meshgrid(X, Y)
    assert np.array_equal(d.heights_grid(X, Y), d.heights(np.column_stack([XX.ravel(), YY.ravel()])).reshape(200, 300),
                          equal_nan=True)


def test_the_cache_is_not_pickled_nor_compared():
    d = _dem()
    d.heights(_points(d, 10))
    back = pickle.loads(pickle.dumps(d))
    assert "_quads_" in d.__dict__ and "_quads_" not in back.__dict__
    assert np.array_equal(back.heights(_points(d)), d.heights(_points(d)), equal_nan=True)


@pytest.mark.parametrize("step", [1.0, 7.5])
def test_sampler_gradient_is_the_five_samplings(step):
    s = DemSampler(_dem(), LO25)
    t = transformer("EPSG:32735", LO25)
    x, y = t.transform(681000.0 + np.arange(0, 1500, 37.0), 6229000.0 - np.arange(0, 1500, 37.0))
    XY = np.column_stack([x, y])
    h, gx, gy = s.heights_and_gradient(XY, step)
    assert np.array_equal(h, s.heights(XY), equal_nan=True)
    assert np.array_equal(gx, (s.heights(XY + [step, 0]) - s.heights(XY - [step, 0])) / (2 * step), equal_nan=True)
    assert np.array_equal(gy, (s.heights(XY + [0, step]) - s.heights(XY - [0, step])) / (2 * step), equal_nan=True)
    assert np.isfinite(gx).sum() > 10


def test_one_transformer_per_pair_of_crss():
    from pyproj import CRS
    a = transformer("EPSG:32735", LO25)
    assert transformer(CRS.from_epsg(32735), CRS.from_user_input(LO25)) is a  # the same CRSs as objects
    assert transformer(LO25, "EPSG:32735") is not a
    x, y = a.transform(681000.0, 6229000.0)
    assert np.allclose(transformer(LO25, "EPSG:32735").transform(x, y), (681000.0, 6229000.0), atol=1e-6)
