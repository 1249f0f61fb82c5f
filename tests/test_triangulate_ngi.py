"""The real NGI pair (frames 0182/0184) triangulated with automatic control from the orthophotos + DEM.

Truth: ``ngi/exterior_orientation.txt`` from a professional aerial triangulation. The approximate
orientation is the truth perturbed by 20 m and 0.5° (seeded); the block gets its control from the
two orthophoto tiles and the DEM only. Compared: the adjusted orientations against the truth, and
the dense-grid ground accuracy (every 10th frame pixel at its true height, adjusted vs true
geometry) beside the single-frame terrain-aware registration (``register --dem``, collinearity with
the camera) of the same frames. The pipeline and its measures are those of
``tests/ngi_triangulation.py``, shared with ``benchmarks/triangulate_ngi_bench.py``.
"""
from __future__ import annotations

import pytest

from fotogeo.io.raster import read_dem
from fotogeo.io.camera import load_camera, read_exterior_orientation
from ngi_triangulation import NAMES, dense_grid, registration_rmse, run_seed


@pytest.fixture(scope="module")
def adjusted(data_dir):
    return run_seed(data_dir / "ngi", seed=0, level=1)


def test_adjusted_orientations_come_close_to_the_professional_triangulation(adjusted):
    assert adjusted["control_points"] >= 100 and adjusted["tie_tracks"] >= 30
    for name in NAMES:
        f = adjusted["frames"][name]
        a, b = f["approx"], f["adjusted"]
        assert a["position_m"] > 10 and a["angle_deg"] > 0.2  # the start is far off: the test can fail
        # measured 2.5 / 4.4-4.6 m and 0.019-0.020 / 0.035-0.038° over 3 seeds; the control is a 5 m orthophoto on a
        # 24 m DEM, and the adjusted solution is the same from every start
        assert b["position_m"] < 8.0 and b["angle_deg"] < 0.08, (name, b)


def test_dense_ground_accuracy_beats_single_frame_registration(data_dir, adjusted):
    ngi = data_dir / "ngi"
    cam = load_camera(ngi / "interior_orientation.yaml")
    true = read_exterior_orientation(ngi / "exterior_orientation.txt")
    dem = read_dem(ngi / "dem.tif")
    for name in NAMES:
        d = adjusted["frames"][name]["dense_rmse_m"]
        assert d["approx"] > 15.0 and d["truth"] < 1e-6, d
        px, truth = dense_grid(cam, true[name], dem)
        single = registration_rmse(ngi, name, "collinearity", px, truth)
        # measured: bundle 1.1 / 1.5 m, registration 1.4 / 2.0 m (frames 0182 / 0184); a 5 m orthophoto pixel
        assert d["bundle"] < 2.5, (name, d)
        assert d["bundle"] < single, (name, d["bundle"], single)


def _ngi_mosaic_run(ngi, out, **kw):
    from fotogeo.tools.triangulate import triangulate
    frames = [ngi / "frames" / f"{n}.tif" for n in NAMES]
    return triangulate(frames, ngi / "interior_orientation.yaml", ngi / "exterior_orientation.txt", None, out,
                       dem=ngi / "dem.tif", eo_sigma_position=0.5, eo_sigma_angle=0.01, mosaic=True, resolution=12.0,
                       **kw)


def test_triangulate_mosaics_its_orthophotos(data_dir, tmp_path):
    """--mosaic: the frames orthorectified on one lattice and mosaicked by fotogeo mosaic; inside a frame's own part,
    away from the seam, the mosaic is that frame's orthophoto up to the balancing's gain and offset."""
    import numpy as np
    import pyogrio
    import rasterio

    ngi = data_dir / "ngi"
    rep = _ngi_mosaic_run(ngi, tmp_path / "out")
    out = tmp_path / "out"
    assert (out / "mosaic.tif").exists() and "error" not in rep["mosaic"], rep["mosaic"]
    assert {name for name, _ in pyogrio.list_layers(out / "mosaic.gpkg")} >= {"seamlines", "regions"}
    assert rep["timings_s"]["mosaic"] > 0 and rep["timings_s"]["total"] >= rep["timings_s"]["mosaic"]
    with rasterio.open(out / "mosaic.tif") as m:
        assert m.res == (12.0, 12.0)
        mos = m.read(1).astype(float)
        for k, name in enumerate(NAMES):
            with rasterio.open(out / f"{name}_ortho.tif") as o:
                assert o.res == m.res and o.crs == m.crs
                c0, r0 = ~m.transform * (o.transform.c, o.transform.f)
                assert abs(c0 - round(c0)) < 1e-6 and abs(r0 - round(r0)) < 1e-6  # one lattice
                own = np.zeros(mos.shape, bool)
                r0, c0 = int(round(r0)), int(round(c0))
                own[r0:r0 + o.height, c0:c0 + o.width] = o.read_masks(1) > 0
                img = np.zeros(mos.shape)
                img[r0:r0 + o.height, c0:c0 + o.width] = o.read(1)
            others = [n for n in NAMES if n != name]
            with rasterio.open(out / f"{others[0]}_ortho.tif") as o2:
                c2, r2 = (int(round(v)) for v in ~m.transform * (o2.transform.c, o2.transform.f))
                covered = np.zeros(mos.shape, bool)
                covered[r2:r2 + o2.height, c2:c2 + o2.width] = o2.read_masks(1) > 0
            alone = own & ~covered  # only this frame covers these cells: the mosaic must be it
            assert alone.sum() > 1000, (name, alone.sum())
            corr = np.corrcoef(mos[alone], img[alone])[0, 1]
            assert corr > 0.999, (name, corr)  # measured 0.99997 and 0.99996: gain·v + offset rounded to bytes


def test_a_failing_mosaic_keeps_the_adjustment_outputs(data_dir, tmp_path, monkeypatch):
    import json

    import fotogeo.tools.ortho.mosaic as mosaic_tool
    from fotogeo.errors import FotogeoError, FotogeoWarning

    def broken(*a, **k):
        raise FotogeoError("the mosaic broke here")
    monkeypatch.setattr(mosaic_tool, "mosaic", broken)
    with pytest.warns(FotogeoWarning, match="no mosaic: the mosaic broke here"):
        rep = _ngi_mosaic_run(data_dir / "ngi", tmp_path / "out")
    out = tmp_path / "out"
    assert not (out / "mosaic.tif").exists() and not (out / "mosaic.gpkg").exists()
    assert (out / "exterior_orientation.txt").exists() and all((out / f"{n}_ortho.tif").exists() for n in NAMES)
    saved = json.loads((out / "report.json").read_text())
    assert "the mosaic broke here" in saved["mosaic"]["error"] == rep["mosaic"]["error"]
    assert "no mosaic" in (out / "report.html").read_text(encoding="utf-8")
