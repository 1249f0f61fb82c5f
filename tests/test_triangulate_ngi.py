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
