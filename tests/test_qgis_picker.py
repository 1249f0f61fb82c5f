"""The GCP picker dock (issue 14) in a real, headless QGIS: simulated mouse events on the image canvas and
on the map canvas create, move, snap and delete GCPs; the table matches ``fotogeo orient``; undo restores;
``.points`` round-trips; bad input is reported in the dock; proposals on the NGI frame become GCPs.

The dock runs in a fresh process with a GUI QgsApplication (``QT_QPA_PLATFORM=offscreen``; the other QGIS
tests share a non-GUI one): ``tests/picker_gui_script.py`` drives it and writes what it saw to a JSON file.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from qgis_env import need_qgis

ROOT = Path(__file__).resolve().parents[1]
FRAME = "ngi/frames/3324c_2015_1004_05_0182_RGB.tif"
pytestmark = [pytest.mark.qgis]


def truth_gcps(data_dir, n=20):
    """``n`` GCPs of NGI frame 0182 from its true geometry (exact pixels, ground on the DEM)."""
    from fotogeo.io.raster import read_dem
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.orientation.simulation import make_gcps
    ngi = data_dir / "ngi"
    dem = read_dem(ngi / "dem.tif")
    s = make_gcps(load_ngi_frame(ngi, "3324c_2015_1004_05_0182"), dem, n, 0, "homogeneous", noise=0.0, seed=3)
    return [{"col": float(p[0]), "row": float(p[1]), "x": float(g[0]), "y": float(g[1])}
            for p, g in zip(s.gcp_pixel, s.gcp_ground)], dem.crs.to_wkt()


def small_dem(data_dir, path, gcps):
    """A crop of the NGI DEM covering only the GCPs west of their median x."""
    import rasterio
    from rasterio.windows import from_bounds
    xs, ys = [g["x"] for g in gcps], [g["y"] for g in gcps]
    with rasterio.open(data_dir / "ngi" / "dem.tif") as ds:
        window = from_bounds(min(xs) - 100, min(ys) - 100, float(np.median(xs)), max(ys) + 100, ds.transform)
        window = window.round_offsets().round_lengths()
        profile = {**ds.profile, "width": int(window.width), "height": int(window.height),
                   "transform": ds.window_transform(window)}
        data = ds.read(window=window)
    with rasterio.open(path, "w", **profile) as out:
        out.write(data)
    return path


def run_script(script: str, args: dict, tmp_path: Path, timeout: int = 300) -> dict:
    need_qgis()
    args_file = tmp_path / "args.json"
    args_file.write_text(json.dumps({"root": str(ROOT), "out": str(tmp_path), **args}))
    temp = Path(tempfile.mkdtemp(prefix="picker-script-"))  # the script's temporary folder: what it leaves is seen
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", HOME=str(tmp_path / "home"), GDAL_PAM_ENABLED="NO",
               FOTOGEO_PYTHON=sys.executable, TMPDIR=str(temp))
    try:
        r = subprocess.run([sys.executable, str(ROOT / "tests" / script), str(args_file)], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=timeout)
    finally:
        left = sorted(p.name for p in temp.glob("fotogeo-preview-*"))
        shutil.rmtree(temp, ignore_errors=True)
    state_file = tmp_path / "state.json"
    assert state_file.exists(), f"{script} failed (rc {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    state = json.loads(state_file.read_text())
    assert "error" not in state, state["error"] + r.stderr[-2000:]
    assert not left, f"{script} left the live preview's temporary folders {left}"
    return state


def run_frame_script(script: str, data_dir, tmp: Path) -> dict:
    """``script`` on NGI frame 0182 with the 20 truth GCPs (``frame``, ``crs``, ``gcps`` in its arguments)."""
    gcps, crs = truth_gcps(data_dir)
    return run_script(script, {"frame": str(data_dir / FRAME), "crs": crs, "gcps": gcps}, tmp)


@pytest.fixture(scope="module")
def picked(data_dir, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("picker")
    gcps, crs = truth_gcps(data_dir)
    (tmp / "notes.txt").write_text("not an image\n")
    large = tmp / "large.tif"
    import rasterio
    with rasterio.open(large, "w", driver="GTiff", width=1500, height=1200, count=3, dtype="uint8") as ds:
        ds.write(np.random.default_rng(0).integers(0, 255, (3, 1200, 1500), dtype=np.uint8))
    args = {"large": str(large), "camera": str(data_dir / "ngi" / "interior_orientation.yaml"), "frame": str(data_dir / FRAME), "dem": str(data_dir / "ngi" / "dem.tif"), "crs": crs, "gcps": gcps,
            "small_dem": str(small_dem(data_dir, tmp / "small_dem.tif", gcps)), "not_raster": str(tmp / "notes.txt")}
    return run_script("picker_gui_script.py", args, tmp), gcps, tmp


def _by_id(rows):
    return {r["id"]: r for r in rows}


def test_the_click_guard_is_the_rule_orient_skips_by(monkeypatch):
    """The picker's image checks a click by fotogeo.image_extent.on_image (the rule of gcps.outside_image), not a
    copy of it, and words a refusal as orient does (outside_reason)."""
    need_qgis()
    from types import SimpleNamespace

    from fotogeo.io.gcps import outside_image, outside_reason
    from processing_provider.picker import image_source
    image = SimpleNamespace(width=640, height=1152)
    for col, row in [(0, 0), (640, 1152), (640.5, 3), (-0.2, 5), (3, 1152.01), (float("nan"), 4)]:
        assert image_source.PickerImage.inside(image, col, row) == (not outside_image([[col, row]], 640, 1152)[0])
    assert image_source.PickerImage.outside(image) == outside_reason(640, 1152)
    calls = []
    monkeypatch.setattr(image_source, "on_image", lambda *a: calls.append(a) or False)
    assert image_source.PickerImage.inside(image, 1.0, 2.0) is False and calls == [(1.0, 2.0, 640, 1152)]


def test_dock_rejects_a_file_that_is_not_a_raster(picked):
    state, _, tmp = picked
    opened, message = state["not_raster"]
    assert opened is False and "notes.txt" in message and "is not a raster GDAL can read" in message
    # a path typed is not judged per keystroke: nothing said while it names no file, one line when typing ends
    while_typing, opened, ended = state["typing"]
    assert while_typing == "" and not opened and "does not exist" in ended and ended.count("\n") == 0
    assert state["first_click"] == "(100.5, 200.5) px on the image noted: now click the same point on the map"


def test_image_canvas_shows_pixels_at_x_col_y_minus_row(picked):
    """Pixel (col, row) of the frame (georeferenced, rotated 180°) is drawn at x = col + 0.5, y = -(row + 0.5)
    of the image canvas: the layer's value there is GDAL's value of that pixel, not of the row mirrored."""
    state, _, _ = picked
    assert state["image_extent"] == "0.000,-1152.000 : 640.000,0.000"
    for col, row, shown, value, mirrored in state["samples"]:
        assert shown == value, (col, row)
    assert sum(v != m for *_, v, m in state["samples"]) >= 5


def test_clicks_on_both_canvases_create_gcps_with_snapping(picked):
    state, truth, _ = picked
    upp, mupp = state["image_units_per_pixel"], state["map_units_per_pixel"]
    got = state["picked"]["gcps"]
    assert [g["id"] for g in got] == [str(k) for k in range(1, 11)]
    for g, t in zip(got, truth):  # image first for odd ids, map first for even ids: same pairs
        assert abs(g["col"] - t["col"]) <= upp and abs(g["row"] - t["row"]) <= upp
        assert g["role"] == "control" and g["z"] is None
    for g, t in zip(got[1:], truth[1:]):
        assert abs(g["x"] - t["x"]) <= mupp and abs(g["y"] - t["y"]) <= mupp
    # GCP 1 was clicked 4.6 screen px from a road vertex: it snapped onto the vertex exactly
    vertex = state["vertex"]
    assert (got[0]["x"], got[0]["y"]) == pytest.approx(tuple(vertex), abs=1e-6)
    assert np.hypot(truth[0]["x"] - vertex[0], truth[0]["y"] - vertex[1]) > 4 * mupp
    assert state["indicator"] == [True, pytest.approx(vertex[0], abs=1e-6), pytest.approx(vertex[1], abs=1e-6)]


def test_drag_moves_and_right_click_deletes_and_undo_restores(picked):
    state, truth, _ = picked
    upp, mupp = state["image_units_per_pixel"], state["map_units_per_pixel"]
    m = state["moved"]  # dragged by (+8, +5) screen px on the image canvas: row grows downwards
    assert np.subtract(m["after"], m["before"]) == pytest.approx([8 * upp, 5 * upp], abs=1e-6)
    m = state["moved_map"]  # dragged by (-6, +3) screen px on the map: y decreases downwards
    assert np.subtract(m["after"], m["before"]) == pytest.approx([-6 * mupp, -3 * mupp], abs=1e-6)
    d = state["delete"]
    assert "5" in _by_id(d["before"]) and "5" not in _by_id(d["deleted"]) and len(d["deleted"]) == 9
    assert _by_id(d["undone"]) == _by_id(d["before"]) == _by_id(d["undone_again"])
    assert _by_id(d["redone"]) == _by_id(d["deleted"])
    # two more undos take back both moves: the points as clicked
    assert _by_id(state["after_undo_moves"]["gcps"]) == _by_id(state["picked"]["gcps"])


def test_delete_key_deletes_the_selected_rows_in_one_undo_step(picked):
    state, _, _ = picked
    d = state["delete_key"]
    before = _by_id(d["before"])
    assert _by_id(d["unselected"]) == before  # nothing selected: Delete deletes nothing
    assert sorted(d["selected"]) == sorted(d["last_two"]) and len(set(d["last_two"])) == 2  # table order: by id
    assert set(_by_id(d["deleted"])) == set(before) - set(d["last_two"]) and len(d["deleted"]) == len(before) - 2
    assert d["steps"] == 1 and d["undo_text"] == "delete 2 GCPs"
    assert d["undone"] == d["before"]  # one undo brings both back, unchanged and in the layer's order
    assert _by_id(d["redone"]) == _by_id(d["deleted"])
    assert sorted(d["table_ids"], key=int) == sorted(before, key=int)  # the table shows them again


def test_refit_keeps_the_gui_responsive(picked):
    """The refit runs off the GUI thread: refit() returns before the fit, and with the worker's answer held until a
    0 ms QTimer fires, the timer fires (the event loop runs while the fit is under way) before the fit arrives.
    A refit made in the GUI thread fails every line: its call runs in the GUI thread, the timer cannot release it."""
    r = picked[0]["refit"]
    assert r["gui_thread"] is False and r["released"] is True
    assert r["returned"] == {"busy": True, "fits": 0} and r["timer_fits"] == 0
    assert r["fits"] == 1 and r["ok"] is True


def test_prediction_follows_the_model(picked):
    state, _, _ = picked
    g2 = _by_id(state["picked"]["gcps"])["2"]  # the cursor over GCP 2 on the image: the prediction on the map
    assert np.hypot(state["predicted"][0] - g2["x"], state["predicted"][1] - g2["y"]) < 3 * state["map_units_per_pixel"]


def _orient(data_dir, gpkg, report):
    from fotogeo.tools.orient.tool import orient
    orient(data_dir / FRAME, gpkg, model="dlt", dem=data_dir / "ngi" / "dem.tif", layer="gcps", report=report)
    return json.loads(Path(report).read_text())


@pytest.mark.parametrize("step, gpkg", [("picked", "picked.gpkg"), ("role", "with_check.gpkg")])
def test_table_and_residuals_match_fotogeo_orient(picked, data_dir, step, gpkg):
    state, _, tmp = picked
    fit = state[step]["fit"]
    assert fit["ok"] and fit["model"] == "dlt"
    rep = _orient(data_dir, tmp / gpkg, tmp / f"{step}.json")
    rows = _by_id(fit["points"])
    assert set(rows) == {str(p["id"]) for p in rep["points"]}
    for p in rep["points"]:
        r = rows[str(p["id"])]
        assert (r["dx_px"], r["dy_px"]) == pytest.approx((p["dx_px"], p["dy_px"]), abs=1e-9)
        assert (r["dx_map"], r["dy_map"]) == pytest.approx((p["dx_ground"], p["dy_ground"]), abs=1e-6)
        assert r["role"] == p["role"] and r["z_source"] == "dem"
    assert fit["rms"]["control_px"] == pytest.approx(rep["control"]["rms_xy_px"], abs=1e-9)
    if step == "role":  # GCP 2 made a check point in the table's role column: measured but not fitted
        assert rows["2"]["role"] == "check" and fit["rms"]["n_check"] == 1
        assert fit["rms"]["check_px"] == pytest.approx(rep["check"]["rms_xy_px"], abs=1e-9)
    else:  # the table shows the same numbers
        table = {t["id"]: t for t in state[step]["table"]}
        for p in rep["points"]:
            assert table[str(p["id"])]["dx px"] == f"{p['dx_px']:.3f}"
            assert table[str(p["id"])]["dy map"] == f"{p['dy_ground']:.3f}"
        assert f"{rep['control']['rms_xy_px']:.3f} px" in state[step]["summary"]


def test_unticked_on_disables_a_point_as_the_georeferencer(picked, data_dir):
    """'on' unticked: GCP 3 is ignored (neither control nor check; orient reading the layer leaves it out too)
    but keeps its role for when it is ticked again; its residual to the model is still shown."""
    state, _, tmp = picked
    d = state["disabled"]
    g3 = _by_id(d["gcps"])["3"]
    assert g3["enabled"] is False and g3["role"] == "control"
    row = _by_id(d["fit"]["points"])["3"]
    assert row["role"] == "disabled" and row["residual_px"] is not None
    assert d["fit"]["rms"]["n_control"] == 8 and d["fit"]["rms"]["n_check"] == 1  # of 10: GCP 2 check, GCP 3 off
    t = _by_id(d["table"])["3"]
    assert t["on"] is False and t["role"] == "control"
    rep = _orient(data_dir, tmp / "with_disabled.gpkg", tmp / "disabled.json")
    assert "3" not in {str(p["id"]) for p in rep["points"]} and len(rep["points"]) == 9
    assert d["fit"]["rms"]["control_px"] == pytest.approx(rep["control"]["rms_xy_px"], abs=1e-9)
    assert _by_id(state["enabled_again"])["3"]["enabled"] is True  # undo


def test_layer_round_trips_through_points_file(picked):
    state, _, tmp = picked
    assert state["export_points"] and state["import_points"] == 10
    key = lambda g: (g["col"], g["row"], g["x"], g["y"], g["role"])  # noqa: E731
    assert sorted(map(key, state["reimported_points"])) == sorted(map(key, state["role"]["gcps"]))
    assert (tmp / "picked.points").read_text().startswith("#CRS: ")


def test_layer_round_trips_through_odm_gcp_list(picked):
    """ODM's gcp_list.txt: written with the DEM heights of the fit, read back by the dock and by fotogeo."""
    from fotogeo.io.block import read_gcp_list
    state, _, tmp = picked
    assert state["export_odm"] and state["import_odm"] == 10
    before, after = _by_id(state["role"]["gcps"]), _by_id(state["reimported_odm"])
    heights = {p["id"]: p["z"] for p in state["role"]["fit"]["points"]}
    assert set(before) == set(after)
    for i, g in before.items():
        a = after[i]
        assert (a["col"], a["row"], a["x"], a["y"]) == pytest.approx((g["col"], g["row"], g["x"], g["y"]), abs=1e-9)
        assert a["z"] == pytest.approx(heights[i], abs=1e-9)
    odm = read_gcp_list(tmp / "gcp_list.txt")
    assert list(odm.name) == list(before) and set(odm.frame) == {Path(FRAME).stem}
    assert odm.pixel == pytest.approx(np.array([[g["col"], g["row"]] for g in before.values()]), abs=1e-9)


def test_height_sources_and_models(picked):
    state, _, _ = picked
    assert not state["constant_dlt"]["ok"] and "coplanar" in state["constant_dlt"]["message"]
    constant = state["constant"]
    assert constant["ok"] and constant["model"] == "projective" and all(p["z"] == 300.0 and p["z_source"] == "constant" for p in constant["points"])
    typed = state["typed_height"]  # a z typed into the table is the layer's height; undo takes it back
    assert typed["typed"] == 123.5 and typed["undone"] is None
    assert (typed["row"]["id"], typed["row"]["z"], typed["row"]["z_source"]) == ("1", 123.5, "field")
    assert (typed["row_undone"]["z"], typed["row_undone"]["z_source"]) == (None, "none")
    col = state["collinearity"]
    assert col["fit"]["ok"] and col["fit"]["model"] == "collinearity" and col["summary"].startswith("collinearity")


def test_large_multiband_image_shows_at_once_and_gets_pyramids(picked):
    state, _, tmp = picked
    large = state["large"]
    assert large["opened"] and large["bands"] == 3 and large["task"] and state["frame_vrt_removed"]
    assert large["overviews"] >= 3 and large["message"] == "pyramids built"
    assert not Path(large["vrt"]).is_relative_to(tmp) and sorted(p.name for p in tmp.glob("large*")) == ["large.tif"]


def test_a_new_geopackage_gcp_layer_is_what_fotogeo_reads(picked):
    """GCPs picked into a new GeoPackage layer are in the file at once, as fotogeo's GCP reader reads them."""
    from fotogeo.io.gcps import read_gcps
    state, _, tmp = picked
    assert state["gpkg_layer"]["provider"] == "ogr"
    picked_ = state["gpkg_layer"]["gcps"]
    g = read_gcps(tmp / "new_gcps.gpkg", layer="gcps")
    assert list(g.ids) == [p["id"] for p in picked_] and list(g.role) == ["control"] * 3
    assert g.pixel == pytest.approx(np.array([[p["col"], p["row"]] for p in picked_]), abs=1e-9)
    assert g.ground[:, :2] == pytest.approx(np.array([[p["x"], p["y"]] for p in picked_]), abs=1e-6)


def test_too_few_points_and_a_dem_that_misses_gcps_are_shown(picked):
    state, truth, _ = picked
    assert "dlt needs 6 control points: 3 more" in state["few"]["summary"]
    small = state["small_dem"]
    median_x = float(np.median([t["x"] for t in truth]))
    flags = {t["id"]: t["flag"] for t in small["table"]}
    gcps = _by_id(state["role"]["gcps"])
    outside = {i for i, g in gcps.items() if g["x"] > median_x + 50}
    assert outside and all(flags[i] == "no height: the DEM does not cover this point" for i in outside)
    assert all(flags[i] == "" for i, g in gcps.items() if g["x"] < median_x - 50)
    assert "more" in small["summary"] and "without a height" in small["summary"]


def test_a_point_layer_without_the_gcp_fields_is_refused(picked):
    plain = picked[0]["plain_layer"]
    assert plain["store"] is False
    assert plain["message"] == ("layer 'plain points' lacks the GCP field(s) col, row (the image position): choose a "
                                "layer made by the picker or by fotogeo's points-to-layer")


def test_project_crs_other_than_the_layers(picked):
    state, truth, _ = picked
    w = state["wgs84"]
    assert w["canvas_crs"] == "EPSG:4326" and 'PARAMETER["central_meridian",25]' in w["layer_crs_wkt"]
    # clicked on a lon/lat canvas, stored in the layer's metres: within a screen pixel (~7 m) of the truth
    t = truth[12]
    assert np.hypot(w["gcp"]["x"] - t["x"], w["gcp"]["y"] - t["y"]) < 12.0
    assert abs(w["gcp"]["col"] - t["col"]) <= state["image_units_per_pixel"]


def test_proposals_on_the_ngi_frame_become_gcps_with_dlt_check_rms_below_a_pixel(data_dir, tmp_path):
    """Propose GCPs (a QgsTask running fotogeo's propose_gcps) on frame 0182 against its orthophoto; a first run
    cancelled after 1 s leaves no proposals; of the second run's 30, one accepted and one rejected by clicks on their
    markers, the other 28 accepted at once, every third a check point."""
    _, crs = truth_gcps(data_dir, n=6)
    state = run_script("picker_gui_script.py", {
        "mode": "propose", "frame": str(data_dir / FRAME), "dem": str(data_dir / "ngi" / "dem.tif"), "crs": crs,
        "reference": str(data_dir / "ngi" / "ortho" / "ngi_rgb_byte_1.tif")}, tmp_path, timeout=900)
    print(f"Propose GCPs in the dock: {state['propose_s']:.1f} s for {len(state['proposals'])} candidates; "
          f"DLT check RMS {state['fit']['rms']['check_px']:.3f} px")
    cancel = state["cancel"]
    assert cancel["error"].startswith("cancelled") and cancel["proposals"] == 0 and "cancelled" in cancel["message"]
    assert state["task_error"] is None and len(state["proposals"]) == 30
    # a click on the first square accepted it (GCP 1 at its image position), a right click rejected the second
    first, clicked = state["proposals"][0], state["clicked"]
    assert clicked["left"] == 28 and [g["id"] for g in clicked["gcps"]] == ["1"]
    assert (clicked["gcps"][0]["col"], clicked["gcps"][0]["x"]) == pytest.approx((first["col"], first["x"]), abs=1e-6)
    assert state["accepted"] == 28
    fit = state["fit"]
    assert fit["ok"] and fit["model"] == "dlt" and fit["rms"]["n_control"] == 20 and fit["rms"]["n_check"] == 9
    assert fit["rms"]["check_px"] < 1.0
    assert all(p["z_source"] == "dem" for p in fit["points"])
    # Report and Rectify ran fotogeo orient on the same GCPs, model and DEM heights: the same check RMS
    assert state["runs"] == {"report": [True, None], "rectify": [True, None], "options": [True, None],
                             "html": [True, None]}
    import rasterio
    with rasterio.open(tmp_path / "rectified_utm34.tif") as r:  # Rectify's options honoured
        assert r.crs.to_epsg() == 32734 and r.res == pytest.approx((12.5, 12.5))
    page = (tmp_path / "orient.html").read_text(encoding="utf-8")
    assert "<h2>GCPs</h2>" in page and "<h2>Residuals per role</h2>" in page
    report = json.loads((tmp_path / "orient.json").read_text())
    assert report["model_name"] == "dlt" and report["check"]["rms_xy_px"] == pytest.approx(fit["rms"]["check_px"], abs=1e-9)
    assert (tmp_path / "rectified.tif").stat().st_size > 100_000 and "rectified.tif" in state["layers"]
    # RPC: orient's one-line refusal for the DLT reaches the dock; with the RFM the frame gets RPC00B metadata
    assert state["rpc"]["dlt"][0] is False and "is not one" in state["rpc"]["dlt"][1]
    assert not (tmp_path / "rpc_dlt.tif").exists()
    assert state["rfm_fit"]["ok"] and state["rpc"]["rfm"] == [True, None]
    import rasterio
    with rasterio.open(tmp_path / "rpc.tif") as ds:
        assert {"LINE_OFF", "SAMP_OFF", "LINE_NUM_COEFF"} <= set(ds.tags(ns="RPC"))
