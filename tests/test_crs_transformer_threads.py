""":func:`fotogeo.crs.transformer` keeps the operation PROJ chose as its pipeline: a worker thread's first
transformation (pyproj makes a transformer again in every thread) parses that pipeline instead of searching PROJ's
database for the operation again, and the coordinates are ``Transformer.from_crs``'s bit for bit. A transformer
holding several operations chosen point by point (no single pipeline) stays as pyproj made it. Before, each of
``ortho``'s resampling threads repeated the search over a DEM in another CRS (docs/benchmarks/products.md)."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from fotogeo import crs as crs_module
from fotogeo.crs import transformer

LO25 = "+proj=tmerc +lat_0=0 +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs +type=crs"


@pytest.fixture
def searches(monkeypatch):
    """The number of operation searches (``Transformer.from_crs``'s maker runs), the transformer cache emptied."""
    from pyproj import transformer as pt
    count = [0]
    search = pt.TransformerFromCRS.__call__

    def counted(self):
        count[0] += 1
        return search(self)
    monkeypatch.setattr(pt.TransformerFromCRS, "__call__", counted)
    monkeypatch.setattr(crs_module, "_TRANSFORMERS", {})
    return count


def _in_thread(t, x, y, *z):
    out = {}
    worker = threading.Thread(target=lambda: out.update(r=t.transform(x, y, *z)))
    worker.start()
    worker.join()
    return out["r"]


@pytest.mark.parametrize("src, dst, x0, y0, span", [
    (LO25, "EPSG:32735", 10000.0, -3720000.0, 30000.0),  # NGI's frames over their DEM warped to UTM 35S
    ("EPSG:4326", "EPSG:32735", 25.5, -33.7, 1.0),
    ("EPSG:32735+3855", "EPSG:4979", 700000.0, 6270000.0, 30000.0),
])
def test_a_worker_thread_repeats_no_operation_search(searches, src, dst, x0, y0, span):
    from pyproj import CRS, Transformer
    t = transformer(src, dst)
    assert searches[0] == 1
    g = np.linspace(0.0, span, 41)
    x, y = (v.ravel() for v in np.meshgrid(x0 + g, y0 - g))
    z = (np.full(x.shape, 1200.0),) if CRS(src).is_compound else ()
    got = _in_thread(t, x, y, *z)
    assert searches[0] == 1  # the thread parsed the pipeline
    want = Transformer.from_crs(CRS(src), CRS(dst), always_xy=True).transform(x, y, *z)
    for a, b in zip(got, want):
        assert np.array_equal(np.asarray(a), np.asarray(b))
    assert np.isfinite(np.asarray(got[0])).all()


def test_several_operations_stay_as_pyproj_made_them(searches):
    """NAD27 -> WGS 84 holds one operation per area (grids chosen point by point): no single pipeline to keep."""
    from pyproj import Transformer
    t = transformer("EPSG:4267", "EPSG:4326")
    x, y = np.array([-100.0, -80.0, -120.0]), np.array([40.0, 35.0, 45.0])
    want = Transformer.from_crs("EPSG:4267", "EPSG:4326", always_xy=True).transform(x, y)
    for a, b in zip(t.transform(x, y), want):
        assert np.array_equal(np.asarray(a), np.asarray(b))
    assert t.to_proj4() is None
