"""``fotogeo triangulate --orthorectify --uncertainty``: each orthophoto of the adjustment gets the σ raster
``fotogeo ortho --uncertainty`` writes from the same exterior orientation and report (issue 21's leftover)."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import rasterio
from rasterio.windows import from_bounds

from fotogeo.errors import FotogeoWarning, InputError
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.tools.ortho.tool import ortho
from fotogeo.tools.triangulate import triangulate

from test_triangulate import CAMERA, write_block
from test_triangulate_inputs import _write_dem

RES = 2.0


@pytest.fixture(scope="module")
def block():
    return simulate_block(seed=6, strips=2, frames_per_strip=3, camera=CAMERA, point_spacing=50.0, margin=3.0,
                          n_check=6, blunder_fraction=0.0)


def _triangulate(folder, frames, **kw):
    out = folder / "out"
    out.mkdir(exist_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        rep = triangulate(frames, folder / "camera.yaml", folder / "eo.txt", folder / "tie.csv", out,
                          gcps=folder / "gcp_list.txt", image_sigma=0.3, resolution=RES, **kw)
    return rep, out


def _overlap(a_path, b_path):
    """Band 1 of two rasters on the same lattice, cut to their common extent."""
    with rasterio.open(a_path) as a, rasterio.open(b_path) as b:
        assert a.transform.a == b.transform.a and a.crs == b.crs
        l, r = max(a.bounds.left, b.bounds.left), min(a.bounds.right, b.bounds.right)
        bo, t = max(a.bounds.bottom, b.bounds.bottom), min(a.bounds.top, b.bounds.top)
        return [d.read(1, window=from_bounds(l, bo, r, t, d.transform).round_offsets().round_lengths())
                for d in (a, b)]


@pytest.mark.parametrize("dem_sigma,self_calibration", [(1.5, None), (None, ("f", "k1"))])
def test_orthophotos_carry_the_sigma_raster_of_fotogeo_ortho(tmp_path, block, dem_sigma, self_calibration):
    """Given DEM σ and a fixed camera; the default DEM σ (half its 5 m cell) and a self-calibrated camera (the
    interior block of the covariance, ortho reading triangulate's camera.yaml)."""
    frames, _ = write_block(tmp_path, block)
    dem = _write_dem(tmp_path / "dem.tif", block)
    rep, out = _triangulate(tmp_path, frames, orthorectify=True, uncertainty=True, dem=dem, dem_sigma=dem_sigma,
                            self_calibration=self_calibration, eo_sigma_position=5.0 if self_calibration else None)
    name = block.block.frames[1]
    entry = rep["orthorectified"][name]["sigma"]
    sigma = out / f"{name}_ortho_sigma.tif"
    assert entry["path"] == str(sigma) and sigma.is_file() and rep["dem_sigma_m"] == (dem_sigma or 2.5)
    assert json.loads((out / "report.json").read_text())["orthorectified"][name]["sigma"]["max_m"] == entry["max_m"]
    with rasterio.open(sigma) as s, rasterio.open(out / f"{name}_ortho.tif") as o:
        assert (s.width, s.height, s.transform, s.crs) == (o.width, o.height, o.transform, o.crs)
        assert s.units == ("m",) and s.dtypes == ("float32",)
    # the same raster as fotogeo ortho --uncertainty from triangulate's EO and report.json
    camera = out / "camera.yaml" if self_calibration else tmp_path / "camera.yaml"
    rep2 = ortho([frames[1]], tmp_path / "ortho.tif", dem=dem, camera=camera, eo=out / "exterior_orientation.txt",
                 uncertainty=True, dem_sigma=dem_sigma, resolution=RES)
    assert rep2["dem_sigma_m"] == rep["dem_sigma_m"]
    a, b = _overlap(sigma, rep2["images"][name]["sigma"]["path"])
    both = np.isfinite(a) & np.isfinite(b)
    assert both.sum() > 0.9 * max(np.isfinite(a).sum(), np.isfinite(b).sum()) > 1000
    np.testing.assert_allclose(a[both], b[both], rtol=1e-6)  # measured: 2.4e-7 in both cases, float32 rounding
    assert 0 < np.nanmin(a) < np.nanmax(a) < 10


def test_uncertainty_needs_orthophotos_and_a_height_sigma(tmp_path, block):
    frames, _ = write_block(tmp_path, block)
    with pytest.raises(InputError, match="--orthorectify"):
        _triangulate(tmp_path, frames, uncertainty=True)
    with pytest.raises(InputError, match="constant height.*--dem-sigma"):
        _triangulate(tmp_path, frames, orthorectify=True, uncertainty=True)
    assert not any((tmp_path / "out").iterdir())  # nothing half-written
