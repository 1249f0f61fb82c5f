"""The GCP picker's refit (fotogeo.tools.gcp.fit.fit_gcps): the same residuals and RMS as
``fotogeo orient`` on the same points, heights from the field / DEM / a constant, data-snooping
flags, "needs N more", a DEM that misses a point, and the prediction grids against the NGI
frame's true geometry (tests/ngi_truth.py)."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from pyproj import CRS

from fotogeo.tools.gcp.fit import NO_DEM_HEIGHT, fit_gcps
from fotogeo.tools.orient.tool import orient
from ngi_truth import FRAMES, truth_points

MAP_CRS = "EPSG:32735"
FRAME = FRAMES[0][0]


@pytest.fixture(scope="module")
def ngi(data_dir) -> Path:
    return data_dir / "ngi"


@pytest.fixture(scope="module")
def truth(ngi):
    return truth_points(ngi, FRAME, step=10)


def pick(truth, n, n_check, seed=1, noise_px=0.3, with_z=False):
    """``n`` GCPs of the true geometry, the last ``n_check`` check points, image noise ``noise_px``."""
    px, ground = truth
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(px), n, replace=False)
    noisy = px[idx] + rng.normal(0, noise_px, (n, 2))
    return [{"id": f"g{k}", "col": float(c), "row": float(r), "x": float(ground[i, 0]), "y": float(ground[i, 1]),
             "z": float(ground[i, 2]) if with_z else None, "role": "check" if k >= n - n_check else "control"}
            for k, ((c, r), i) in enumerate(zip(noisy, idx))]


def write_csv(path, gcps):
    fields = ["id", "x", "y", "col", "row", "role"] + (["z"] if gcps[0]["z"] is not None else [])
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fields, extrasaction="ignore")
        w.writeheader()
        w.writerows(gcps)
    return path


def as_read_by_orient(path, gcps):
    """The GCPs as orient reads them back from the CSV (pandas' float parser may differ in the last bit)."""
    from fotogeo.io.gcps import read_gcps
    g = read_gcps(path, crs=MAP_CRS)
    return [{**p, "col": c, "row": r, "x": x, "y": y, "z": None if p["z"] is None else z}
            for p, (c, r), (x, y, z) in zip(gcps, g.pixel.tolist(), g.ground.tolist())]


@pytest.mark.parametrize("model, n, with_z", [("affine", 12, False), ("projective", 12, True), ("dlt", 16, False),
                                              ("rfm-poly", 40, False), ("rfm-i2g", 40, False), ("collinearity", 10, False),
                                              ("auto", 16, False)])
def test_residuals_and_rms_are_orients(ngi, truth, tmp_path, model, n, with_z):
    gcps = pick(truth, n, 4, with_z=with_z)
    image = ngi / "frames" / f"{FRAME}_RGB.tif"
    camera = ngi / "interior_orientation.yaml"
    rep = orient(image, write_csv(tmp_path / "g.csv", gcps), model=model, crs=MAP_CRS, dem=ngi / "dem.tif",
                 camera=camera)
    gcps = as_read_by_orient(tmp_path / "g.csv", gcps)
    fit = fit_gcps(gcps, model, crs=MAP_CRS, image=str(image), dem=str(ngi / "dem.tif"), camera=str(camera))
    assert fit["ok"] and fit["model"] == rep["model_name"] and fit["needed"] == 0
    assert model != "auto" or fit["model_selection"]["chosen"] == rep["model_selection"]["chosen"] == fit["model"]
    ours = {p["id"]: p for p in fit["points"]}
    for p in rep["points"]:
        q = ours[p["id"]]
        assert (q["dx_px"], q["dy_px"]) == (p["dx_px"], p["dy_px"])
        assert (q["dx_map"], q["dy_map"]) == (p["dx_ground"], p["dy_ground"])
        assert q["role"] == p["role"] and q["z_source"] == ("field" if with_z else "dem")
    assert (fit["rms"]["control_px"], fit["rms"]["check_px"]) == (rep["control"]["rms_xy_px"], rep["check"]["rms_xy_px"])
    assert (fit["rms"]["n_control"], fit["rms"]["n_check"]) == (n - 4, 4)
    assert 0.05 < fit["rms"]["control_px"] < (30 if model in ("affine", "projective") else 1.0)


def test_degenerate_points_are_reported_not_raised():
    line = [{"id": f"p{k}", "col": 10.0 * k, "row": 10.0 * k, "x": 100.0 * k, "y": 100.0 * k, "z": None,
             "role": "control"} for k in range(5)]  # all on one line: no affine transformation
    r = fit_gcps(line, "affine", crs=MAP_CRS)
    assert r["ok"] is False and r["needed"] == 0 and "degenerate" in r["message"] and r["forward"] is None


def test_a_blunder_is_flagged_as_orient_flags_it(ngi, truth, tmp_path):
    gcps = pick(truth, 14, 0, seed=4, noise_px=0.2)
    gcps[5]["col"] += 6.0
    image = ngi / "frames" / f"{FRAME}_RGB.tif"
    rep = orient(image, write_csv(tmp_path / "g.csv", gcps), model="dlt", crs=MAP_CRS, dem=ngi / "dem.tif")
    fit = fit_gcps(gcps, "dlt", crs=MAP_CRS, image=str(image), dem=str(ngi / "dem.tif"))
    flagged = [p["id"] for p in fit["points"] if p["flag"].startswith("blunder")]
    orient_flagged = [f["id"] for f in rep["snooping"] if f["flag"] == "blunder"]
    assert flagged == orient_flagged == ["g5"]
    w = {p["id"]: p["w"] for p in fit["points"]}
    assert w["g5"] == pytest.approx(rep["snooping"][0]["w"], rel=1e-9)
    critical = float(fit["blunder_test"].split("> ")[1].split(" ")[0])
    assert max(v for k, v in w.items() if k != "g5" and v is not None) < critical < w["g5"]
    assert "blunder at g5" in fit["message"] and fit["blunder_test"] == rep["blunder_test"]
    assert all(0 < p["redundancy"] < 1 for p in fit["points"] if p["redundancy"] is not None)
    off = fit_gcps(gcps, "dlt", crs=MAP_CRS, image=str(image), dem=str(ngi / "dem.tif"), snooping=False)
    assert all(p["w"] is None and p["flag"] == "" for p in off["points"])


@pytest.mark.parametrize("seed", [1, 2])
def test_redundancy_aware_blunder_flags(ngi, truth, seed):
    """A planted 5 px blunder among 12 DLT GCPs is flagged; 8 clean GCPs (2n − u = 5) get no flag — the plain
    |w| > 3.29 rule flagged residuals of 0.2-0.7 px there."""
    image, dem = str(ngi / "frames" / f"{FRAME}_RGB.tif"), str(ngi / "dem.tif")
    gcps = pick(truth, 12, 0, seed=seed, noise_px=0.2)
    gcps[5]["col"] += 5.0
    fit = fit_gcps(gcps, "dlt", crs=MAP_CRS, image=image, dem=dem)
    assert [p["id"] for p in fit["points"] if p["flag"].startswith("blunder")] == ["g5"]
    clean = fit_gcps(pick(truth, 8, 0, seed=seed, noise_px=0.2), "dlt", crs=MAP_CRS, image=image, dem=dem)
    assert clean["ok"] and not any(f in p["flag"] for p in clean["points"] for f in ("blunder", "suspect"))
    assert "blunder" not in clean["message"] and "suspect" not in clean["message"]


def test_heights_field_dem_constant_and_a_dem_that_misses_a_point(ngi, truth):
    gcps = pick(truth, 9, 0, seed=2, with_z=True)
    for p in gcps[3:6]:
        p["z"] = None
    gcps[6]["z"] = None
    gcps[6]["x"] += 2e5  # far outside the DEM (the image position no longer matches: it is left out anyway)
    fit = fit_gcps(gcps, "dlt", crs=MAP_CRS, dem=str(ngi / "dem.tif"), width=640, height=1152)
    rows = {p["id"]: p for p in fit["points"]}
    assert [rows[f"g{k}"]["z_source"] for k in range(9)] == ["field"] * 3 + ["dem"] * 3 + ["none"] + ["field"] * 2
    assert rows["g6"]["flag"] == NO_DEM_HEIGHT and rows["g6"]["z"] is None and rows["g6"]["dx_px"] is None
    # 8 control points with heights: dlt fits; the DEM heights are the DEM's, bilinear
    assert fit["ok"] and fit["rms"]["n_control"] == 8
    px, ground = truth
    for k in (3, 4, 5):
        i = np.flatnonzero((ground[:, 0] == gcps[k]["x"]) & (ground[:, 1] == gcps[k]["y"]))[0]
        assert rows[f"g{k}"]["z"] == pytest.approx(ground[i, 2], abs=1e-3)  # truth_points sampled the same DEM
    # a 2-D model does not need the height: the row keeps its flag but is fitted
    two_d = fit_gcps(gcps, "affine", crs=MAP_CRS, dem=str(ngi / "dem.tif"))
    assert two_d["rms"]["n_control"] == 9 and {p["id"]: p for p in two_d["points"]}["g6"]["dx_px"] is not None
    camera = str(ngi / "interior_orientation.yaml")
    flat = [{**p, "z": None} for p in gcps[:6] + gcps[7:]]
    const = fit_gcps(flat, "collinearity", crs=MAP_CRS, default_height=450.0, camera=camera)
    assert {p["z_source"] for p in const["points"]} == {"constant"} and {p["z"] for p in const["points"]} == {450.0}
    on_dem = fit_gcps(flat, "collinearity", crs=MAP_CRS, dem=str(ngi / "dem.tif"), camera=camera)
    assert const["ok"] and const["rms"]["control_px"] > 3 * on_dem["rms"]["control_px"]  # wrong heights show


def test_too_few_points_say_how_many_more(ngi, truth):
    gcps = pick(truth, 7, 0, seed=3)
    r = fit_gcps(gcps[:4], "dlt", crs=MAP_CRS, dem=str(ngi / "dem.tif"))
    assert (r["ok"], r["needed"], r["message"]) == (False, 2, "dlt needs 6 control points: 2 more")
    assert r["rms"]["control_px"] is None and r["forward"] is None and r["inverse"] is None
    no_z = fit_gcps(gcps[:6], "dlt", crs=MAP_CRS)
    assert no_z["needed"] == 6 and no_z["message"] == "dlt needs 6 control points with heights (6 without a height): 6 more"
    disabled = [{**p, "role": "disabled" if k < 2 else p["role"]} for k, p in enumerate(gcps)]
    assert fit_gcps(disabled, "dlt", crs=MAP_CRS, dem=str(ngi / "dem.tif"))["needed"] == 1
    assert fit_gcps(gcps[:2], "auto", crs=MAP_CRS)["message"] == "auto needs 3 control points (similarity): 1 more"
    assert fit_gcps(gcps[:2], "collinearity", crs=MAP_CRS, dem=str(ngi / "dem.tif"),
                    camera=str(ngi / "interior_orientation.yaml"))["message"] == \
        "collinearity needs 4 control points: 2 more"


def test_disabled_points_get_the_models_prediction_but_stay_out_of_the_fit(ngi, truth):
    gcps = pick(truth, 10, 0, seed=5)
    all_on = fit_gcps(gcps[:9], "dlt", crs=MAP_CRS, dem=str(ngi / "dem.tif"))
    with_off = fit_gcps(gcps[:9] + [{**gcps[9], "role": "disabled"}], "dlt", crs=MAP_CRS, dem=str(ngi / "dem.tif"))
    as_check = fit_gcps(gcps[:9] + [{**gcps[9], "role": "check"}], "dlt", crs=MAP_CRS, dem=str(ngi / "dem.tif"))
    assert with_off["rms"] == all_on["rms"] and as_check["rms"]["n_check"] == 1
    off, check = with_off["points"][-1], as_check["points"][-1]
    assert off["role"] == "disabled" and off["w"] is None and off["residual_px"] > 0
    assert (off["dx_px"], off["dy_px"], off["dx_map"]) == pytest.approx((check["dx_px"], check["dy_px"], check["dx_map"]))


def test_prediction_grids_follow_the_true_geometry(ngi, truth):
    from fotogeo.crs import transform_points
    from fotogeo.io.raster import read_dem
    from fotogeo.io.camera import load_ngi_frame
    gcps = pick(truth, 20, 0, seed=6, noise_px=0.0)
    fit = fit_gcps(gcps, "dlt", crs=MAP_CRS, image=str(ngi / "frames" / f"{FRAME}_RGB.tif"),
                   dem=str(ngi / "dem.tif"), grid=9)
    frame, dem = load_ngi_frame(ngi, FRAME), read_dem(ngi / "dem.tif")
    dem_crs = CRS.from_wkt(dem.crs.to_wkt())
    fw = fit["forward"]
    assert fw["cols"][0] == 0 and fw["cols"][-1] == 640 and fw["rows"][-1] == 1152
    px = np.array([[c, r] for r in fw["rows"] for c in fw["cols"]])
    true_xy = transform_points(dem_crs, CRS.from_user_input(MAP_CRS), frame.pixel_to_world(px, dem)[:, :2])
    grid_xy = np.column_stack([np.ravel(fw["x"]), np.ravel(fw["y"])]).astype(float)
    ok = np.isfinite(true_xy).all(axis=1)
    # metres (GSD about 6 m); the grid intersects the DEM resampled into the map CRS (dem_on_map_grid)
    assert ok.sum() > 60 and np.abs(grid_xy[ok] - true_xy[ok]).max() < 2.0
    inv = fit["inverse"]
    assert inv["ys"][0] > inv["ys"][-1] and inv["xs"][0] < inv["xs"][-1]
    XY = np.array([[x, y] for y in inv["ys"] for x in inv["xs"]])
    xy_dem = transform_points(CRS.from_user_input(MAP_CRS), dem_crs, XY)
    z = dem.heights(xy_dem)
    inside = np.isfinite(z)
    true_px = frame.world_to_pixel(np.column_stack([xy_dem, z])[inside])
    grid_px = np.column_stack([np.ravel(inv["col"]), np.ravel(inv["row"])]).astype(float)[inside]
    assert inside.sum() > 40 and np.abs(grid_px - true_px).max() < 0.5


def test_bad_input_is_one_line(ngi):
    from fotogeo.errors import InputError
    with pytest.raises(InputError, match="GCP a: col, row, x and y must be numbers"):
        fit_gcps([{"id": "a", "col": "x", "row": 1, "x": 1, "y": 1}], "affine", crs=MAP_CRS)
    with pytest.raises(InputError, match="used more than once"):
        fit_gcps([{"id": "a", "col": 1, "row": 1, "x": 1, "y": 1}] * 2, "affine", crs=MAP_CRS)
    with pytest.raises(InputError, match="crs"):
        fit_gcps([], "affine", crs="EPSG:99999")
    from fotogeo.errors import ModelError
    with pytest.raises(ModelError, match="camera"):
        fit_gcps([], "collinearity", crs=MAP_CRS)
    out = fit_gcps([{"id": "o", "col": 700, "row": 5, "x": 1, "y": 1, "role": "control"}], "affine", crs=MAP_CRS,
                   width=640, height=1152)
    assert out["points"][0]["flag"] == "outside the image (640x1152 px)" and out["needed"] == 3


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_auto_with_eight_gcps_on_dem_heights_chooses_the_3d_model(ngi, truth, seed):
    """8 GCPs on a frame over relief, heights from the DEM, no check points: auto compares the median
    leave-one-out error — the DLT fits every point to < 1 px while the 2-D models leave ~5 px; the RMS of the
    leave-one-out errors let one corner point of high leverage (78 px) hand the choice to affine (4.9 px)."""
    gcps = pick(truth, 8, 0, seed=seed, noise_px=0.5, with_z=False)
    fit = fit_gcps(gcps, "auto", crs=MAP_CRS, dem=str(ngi / "dem.tif"))
    sel = fit["model_selection"]
    assert sel["compared"] == "loo_median_px" and fit["model"] == "dlt", sel["candidates"]
    assert fit["rms"]["control_px"] < 1.5


def test_the_picker_and_orient_skip_the_same_points_in_the_same_words(ngi, truth, tmp_path):
    """The picker flags a point outside the image by the rule and wording orient skips it with
    (fotogeo.io.gcps.outside_image / outside_reason): the points on the border (col = width) stay in both."""
    from fotogeo.io.gcps import outside_reason
    gcps = pick(truth, 10, 0)
    gcps[0] = {**gcps[0], "col": 640.0}  # on the right edge: inside
    gcps[1] = {**gcps[1], "col": 640.5}  # half a pixel beyond it: outside
    gcps[2] = {**gcps[2], "row": -0.2}
    image = ngi / "frames" / f"{FRAME}_RGB.tif"
    with pytest.warns(UserWarning, match="lie outside the image") as caught:
        rep = orient(image, write_csv(tmp_path / "g.csv", gcps), model="affine", crs=MAP_CRS)
    fit = fit_gcps(as_read_by_orient(tmp_path / "g.csv", gcps), "affine", crs=MAP_CRS, image=str(image))
    flagged = {p["id"]: p["flag"] for p in fit["points"] if p["flag"] and "outside" in p["flag"]}
    assert flagged == {s["id"]: s["reason"] for s in rep["skipped"]} == {
        gcps[1]["id"]: outside_reason(640, 1152), gcps[2]["id"]: outside_reason(640, 1152)}
    assert outside_reason(640, 1152) in str(caught[0].message)


def test_one_rule_for_a_position_on_the_image_numbers_and_arrays_alike():
    """fotogeo.image_extent.on_image is the rule of orient's skipping (gcps.outside_image) and of the QGIS
    picker's click guard; it imports the standard library only (the plugin loads it in QGIS's Python)."""
    import subprocess
    import sys

    from fotogeo.io.gcps import outside_image
    from fotogeo.image_extent import on_image
    code = ("import importlib.abc, sys\n"
            "class Block(importlib.abc.MetaPathFinder):\n"
            "    def find_spec(self, name, path=None, target=None):\n"
            "        if name.split('.')[0] in ('numpy', 'pyproj', 'rasterio', 'qgis'): raise ImportError(name)\n"
            "sys.meta_path.insert(0, Block())\n"
            "from fotogeo.image_extent import on_image\n"
            "print(on_image(640.0, 0.0, 640, 1152), on_image(640.5, 3.0, 640, 1152))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.split() == ["True", "False"], r.stderr
    pts = np.array([[0, 0], [640, 1152], [640.5, 3], [-0.2, 5], [3, 1152.01], [np.nan, 4], [320, 600]], float)
    scalar = [bool(on_image(c, r, 640, 1152)) for c, r in pts]
    assert scalar == [True, True, False, False, False, False, True]
    assert (~outside_image(pts, 640, 1152)).tolist() == scalar == on_image(pts[:, 0], pts[:, 1], 640, 1152).tolist()
