"""What triangulate's report lists (issue 20 item 8): image residuals sorted by size with the adjusted image
coordinates, the mean σ of the adjusted points per type, matching statistics, the timings of every stage and the
angle σ of each frame — in report.json and report.html."""
from __future__ import annotations

import re

import numpy as np
import pytest
from pyproj import CRS

from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import adjust_block
from fotogeo.orientation.adjusted_frame import AdjustedFrame
from fotogeo.tools.triangulate.outputs import block_layers, report
from fotogeo.tools.triangulate.report import write_html
from fotogeo.tools.triangulate.statistics import LARGEST

MATCHING = {"pairs": [{"pair": [0, 1], "frames": ["a", "b"], "matches": 90, "inliers": 70},
                      {"pair": [1, 2], "frames": ["b", "c"], "matches": 40, "inliers": 12},
                      {"pair": [0, 2], "frames": ["a", "c"], "matches": 5, "inliers": 0}],
            "detection_level": 1, "tracks": 81, "rays_per_track": {"2": 70, "3": 11}}
STAGES = {"inputs": 0.5, "control": 1.25, "matching": 3.0, "adjustment": 2.0}


@pytest.fixture(scope="module")
def adjusted():
    sb = simulate_block(seed=3, strips=2, frames_per_strip=3)
    result = adjust_block(sb.block)
    rep = report(result, sb.block, CRS.from_epsg(32635), {"folder": "out", "matching": MATCHING}, stages=STAGES)
    return sb.block, result, rep


def test_residuals_largest_first_with_the_adjusted_image_coordinates(adjusted):
    """Sorted by |v|; the adjusted coordinate is where the adjusted point projects through the adjusted frame."""
    block, result, rep = adjusted
    rows = rep["residuals_by_size"]
    sizes = [r["v_px"] for r in rows]
    n_live = int(np.isfinite(result.residuals).all(axis=1).sum())
    assert n_live > LARGEST and len(rows) == LARGEST and sizes == sorted(sizes, reverse=True)  # the largest ones
    assert sizes[0] == pytest.approx(float(np.nanmax(np.hypot(*result.residuals.T))))
    index, ids = {n: j for j, n in enumerate(block.frames)}, {str(p): k for k, p in enumerate(block.point_ids)}
    for r in rows[:20]:
        frame = AdjustedFrame(result.camera, result.eo[index[r["frame"]]], result.distortion)
        projected = frame.forward(result.point_xyz[[ids[r["point"]]]])[0]
        np.testing.assert_allclose([r["col_adjusted"], r["row_adjusted"]], projected, atol=1e-6)
        assert r["v_px"] == pytest.approx(np.hypot(r["col_adjusted"] - r["col"], r["row_adjusted"] - r["row"]))
    layer = block_layers(result, block)["residuals"]
    np.testing.assert_allclose(layer["col_adjusted"] - layer["col"], layer["dx_px"])


def test_mean_point_sigma_per_point_type(adjusted):
    block, result, rep = adjusted
    by_role = rep["point_sigma_by_role"]
    assert {"tie", "control"} <= set(by_role)
    for role, s in by_role.items():
        mine = result.point_sigma[(result.roles == role) & np.isfinite(result.point_xyz).all(axis=1)]
        assert s["n"] == len(mine)
        np.testing.assert_allclose([s["sigma_x_m"], s["sigma_y_m"], s["sigma_z_m"]], mine.mean(axis=0))
    assert by_role["tie"]["sigma_z_m"] > by_role["tie"]["sigma_x_m"] > 0  # near-nadir frames: height the weakest


def test_matching_statistics_and_stage_timings(adjusted):
    _, result, rep = adjusted
    m = rep["matching_summary"]
    assert (m["pairs_tried"], m["pairs_matched"]) == (3, 2)
    assert m["inliers_per_pair"] == {"min": 0, "median": 12.0, "max": 70, "total": 82}
    tie = (result.roles == "tie") & np.isfinite(result.point_xyz).all(axis=1)
    assert sum(m["rays_per_tie_point_adjusted"].values()) == tie.sum()
    t = rep["timings_s"]
    assert [k for k in t if k in STAGES] == list(STAGES) and t["total"] == pytest.approx(sum(STAGES.values()))
    assert t["adjustment_steps"] == result.timings


def test_report_html_lists_them(adjusted, tmp_path):
    block, result, rep = adjusted
    write_html(tmp_path / "report.html", rep, result, block, {"geometry": []})
    text = (tmp_path / "report.html").read_text(encoding="utf-8")
    for heading in ("Largest image residuals", "Mean σ of the adjusted points", "Tie-point matching",
                    "Rays per track", "Inliers per pair", "Timings (s)"):
        assert f">{heading}" in text, heading
    assert "σ rx°" in text and "σ rz°" in text and "col adj." in text
    first = rep["residuals_by_size"][0]
    assert re.search(rf"<td>{re.escape(first['frame'])}</td><td>{re.escape(first['point'])}</td>", text)
    assert text.index("<td>a – c</td>") < text.index("<td>b – c</td>") < text.index("<td>a – b</td>")  # weakest first


def test_the_accuracy_lines_import_without_the_readers():
    """The QGIS plugin imports outputs.accuracy_lines in QGIS's own process, where rasterio is not importable:
    the package must not load the tool (and io.raster) with it."""
    import subprocess
    import sys
    code = ("import sys; import fotogeo.tools.triangulate.outputs as o; o.accuracy_lines; "
            "assert 'rasterio' not in sys.modules and 'fotogeo.tools.triangulate.tool' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)
