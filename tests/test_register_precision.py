"""Precision by default (issue 19): tie points refined by least-squares matching, each with its σ and
status; the report's CE90 / CE95 and the tie points' own precision apart from the model's residuals.

Known warps of real images (tests/known_warps.py; the full table with the SIFT variant and the
timings is benchmarks/register_precision_bench.py)."""
import geopandas as gpd
import numpy as np
import pytest

from fotogeo.tools.demo.tool import make_scene
from fotogeo.tools.register.tool import register
from known_warps import known_warp

#: issue 19: the dense error of the fitted model against the exact warp, reference pixels
TARGET_PX = 0.05


def dense_px(r, grid, truth, px):
    return float(np.sqrt(np.mean(np.sum((r.model.forward(grid) - truth) ** 2, axis=1)))) / px


@pytest.mark.parametrize("image, warp", [("ngi", "r30_s0.85_p"), ("s2", "r45_s1.2_p"), ("landsat", "r200_s0.9_p")])
def test_known_warp_within_five_hundredths_of_a_pixel_by_default(data_dir, tmp_path, image, warp):
    """Measured 0.003 (NGI), 0.010 (Sentinel-2), 0.011 (Landsat) px; without LSM 0.10, 0.10, 0.23 px."""
    ref, tgt, grid, truth = known_warp(data_dir, image, warp, tmp_path)
    r = register(ref, tgt, tmp_path / "o.tif", seed=0)
    rep = r.report
    px = rep["reference_pixel_size"]
    assert rep["refine"] == "lsm" and rep["options"]["refine"] == "auto"
    assert dense_px(r, grid, truth, px) < TARGET_PX
    lsm = rep["lsm"]
    assert lsm["refined"] >= 0.8 * lsm["tried"] and lsm["tried"] <= lsm["budget"]
    assert sum(lsm["status"].values()) == lsm["of"] == rep["matches"] + lsm["texture_windows"]
    assert rep["inliers"] <= lsm["refined"] and rep["check"]["n"] >= 20
    p = rep["precision"]
    assert 0 < p["tie_point_sigma_px"] < 0.1 and p["tie_point_sigma_m"] == pytest.approx(p["tie_point_sigma_px"] * px)
    assert p["model_rmse_px"] <= p["check_rmse_px"] == rep["check"]["rmse_px"] < 0.15


def test_report_layer_and_summary_of_a_refined_registration(data_dir, tmp_path):
    ref, tgt, grid, truth = known_warp(data_dir, "landsat", "r30_s0.85_p", tmp_path)
    r = register(ref, tgt, tmp_path / "o.tif", seed=0)
    rep, px = r.report, r.report["reference_pixel_size"]
    for role in ("control", "check"):
        s = rep[role]
        assert s["ce90_m"] <= s["ce95_m"] <= s["max_m"] and s["ce90_px"] == pytest.approx(s["ce90_m"] / px)
        assert s["median_m"] <= s["ce90_m"]
    assert rep["fit_weights"]["by"] == "spatial balance / (σ² + s0²)"
    assert {"radial_error", "precision", "refine", "lsm"} <= set(rep["notes"])
    text = "\n".join(rep["summary"])
    assert "tie points refined by LSM" in text and "CE90" in text and "CE95" in text
    assert "precision: tie points σ" in text
    tp = gpd.read_file(tmp_path / "o.gpkg", layer="tie_points")
    assert len(tp) == rep["inliers"] and set(tp.lsm_status) == {"converged"}
    assert np.allclose(tp.sigma, tp.sigma_px * px) and (tp.sigma_px > 0).all() and (tp.sigma_px < 0.5).all()
    assert float(np.median(tp.sigma_px[tp.role == "check"])) == pytest.approx(rep["precision"]["tie_point_sigma_px"])


def test_refine_none_keeps_the_keypoints_and_no_sigma(data_dir, tmp_path):
    ref, tgt, grid, truth = known_warp(data_dir, "landsat", "r30_s0.85_p", tmp_path)
    r = register(ref, tgt, tmp_path / "o.tif", seed=0, refine="none")
    rep = r.report
    assert rep["refine"] == "none" and "lsm" not in rep and "fit_weights" not in rep
    assert "tie_point_sigma_px" not in rep["precision"] and rep["precision"]["check_ce90_px"] > 0
    assert dense_px(r, grid, truth, rep["reference_pixel_size"]) > TARGET_PX  # measured 0.28 px: LSM is the gain
    tp = gpd.read_file(tmp_path / "o.gpkg", layer="tie_points")
    assert "sigma" not in tp.columns and "lsm_status" not in tp.columns


def test_auto_refines_the_terrain_aware_registration_too(tmp_path):
    """With a DEM, ``auto`` refines the tie points by LSM as in 2-D (the 3-D model is chosen by blocked
    cross-validation, which precise tie points do not mislead); ``none`` keeps the keypoints."""
    s = make_scene(tmp_path / "scene", seed=7, size=500, pixel=8.0)
    r = register(s.reference, s.target, tmp_path / "o.tif", dem=s.dem_path, model="dlt", seed=0, refine="none")
    assert r.report["refine"] == "none" and "lsm" not in r.report
    r = register(s.reference, s.target, tmp_path / "l.tif", dem=s.dem_path, model="dlt", seed=0)
    assert r.report["refine"] == "lsm" and r.report["lsm"]["refined"] > 50
    tp = gpd.read_file(tmp_path / "l.gpkg", layer="tie_points")
    assert {"z", "sigma_px", "lsm_status"} <= set(tp.columns)


def test_decimated_images_are_refined_at_full_resolution(data_dir, tmp_path):
    """Matched at about half resolution (max_match_pixels), the tie points are refined again on
    full-resolution windows: measured 0.014 px against 0.034 px with LSM on the decimated images only."""
    from synthetic_pair import apply_h, make_landsat_pair
    from fotogeo.pixels import pixel_centres, pixel_to_map
    ref, tgt, H = make_landsat_pair(data_dir / "landsat_rgb" / "RGB.byte.tif", tmp_path)
    r = register(ref, tgt, tmp_path / "o.tif", seed=1, max_match_pixels=100_000)
    lsm = r.report["lsm"]
    assert min(lsm["matched_at_factor"].values()) > 1.9
    full = lsm["full_resolution"]
    assert full["refined"] >= 0.8 * full["of"] and full["of"] == lsm["refined"]
    x, y = pixel_centres(64, 60)
    grid = np.column_stack([x.ravel(), y.ravel()]) * 10
    px = r.report["reference_pixel_size"]
    import rasterio
    with rasterio.open(ref) as ds:
        truth = pixel_to_map(ds.transform, apply_h(H, grid))
    assert dense_px(r, grid, truth, px) < 0.025
