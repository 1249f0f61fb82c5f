"""The GCP picker in the real desktop ``qgis`` under Xvfb: the plugin's menu action opens the dock, simulated
clicks pick GCPs on the NGI frame and on its orthophoto in QGIS's map canvas, the fit runs in the plugin's
runtime (the installed plugin and its worker session, not this venv), and screenshots are taken.

``FOTOGEO_UPDATE_SCREENSHOTS=1`` copies them to ``docs/picker_*.png`` (shown in the README).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from test_qgis_picker import truth_gcps
from test_qgis_picker_preview import template_shift
from test_qgis_real_programs import _env, config, inputs  # noqa: F401 - fixtures: the installed plugin, copied data

ROOT = Path(__file__).resolve().parents[1]
QGIS_DESKTOP = "/usr/bin/qgis.bin"
FRAME, ORTHO = "3324c_2015_1004_05_0182_RGB.tif", "ngi_rgb_byte_1.tif"
pytestmark = [pytest.mark.qgis, pytest.mark.skipif(
    not shutil.which("xvfb-run") or not os.path.exists(QGIS_DESKTOP),
    reason="xvfb and the qgis desktop are not installed (make test installs them)")]


def run_desktop(config, tmp_path, args: dict, timeout=400) -> dict:  # noqa: F811 - config is the fixture's value
    out = tmp_path / "desktop"
    out.mkdir()
    args_file = tmp_path / "picker_args.json"
    args_file.write_text(json.dumps({**args, "out": str(out), "tests": str(ROOT / "tests")}))
    env = {**_env(config, pam="NO"), "FOTOGEO_PICKER_ARGS": str(args_file)}
    env.pop("QT_QPA_PLATFORM")
    subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1600x1000x24", QGIS_DESKTOP, "--nologo", "--noversioncheck",
                    "--code", str(ROOT / "tests" / "picker_desktop_script.py")], capture_output=True, text=True,
                   timeout=timeout, env=env, cwd=tmp_path)
    # QGIS 3.22 may abort while quitting (after the script wrote its result): judge by the result
    state = json.loads((out / "result.json").read_text())
    assert "error" not in state, state.get("error")
    return state, out


def test_desktop_picker_picks_and_shows_the_fit(config, inputs, data_dir, tmp_path):  # noqa: F811
    gcps, crs = truth_gcps(data_dir, n=12)
    state, out = run_desktop(config, tmp_path, {
        "frame": str(inputs / FRAME), "ortho": str(inputs / ORTHO), "dem": str(inputs / "dem.tif"), "crs": crs,
        "gcps": gcps, "propose": True})
    assert state["action"] == "GCP picker" and state["dock_visible"]
    assert len(state["gcps"]) == 12 and sum(g["role"] == "check" for g in state["gcps"]) == 2
    fit = state["fit"]
    # clicks are whole screen pixels (~2.5 image px and ~7 m on the map here): DLT residuals of that order; the
    # two check points lie near the image edge, where the fit extrapolates
    assert fit["ok"] and fit["model"] == "dlt" and fit["rms"]["n_control"] == 10 and fit["rms"]["n_check"] == 2
    assert 0 < fit["rms"]["control_px"] < 3 and 0 < fit["rms"]["check_px"] < 10
    assert [t["id"] for t in state["table"]] == [g["id"] for g in state["gcps"]]
    assert all(t["z from"] == "dem" and t["res px"] for t in state["table"])
    residual = {t["id"]: float(t["res px"]) for t in state["table"]}  # the header clicked: largest residual first
    assert [residual[i] for i in state["sorted_ids"]] == sorted(residual.values(), reverse=True)
    # Propose GCPs against the orthophoto in the desktop: the task ran in the plugin's runtime
    assert state["propose_error"] is None and state["proposals"] == 30
    accepted = state["accepted_fit"]
    assert accepted["ok"] and accepted["rms"]["n_check"] == 10 and accepted["rms"]["check_px"] < 1.0
    # the live preview: none with 5 GCPs, DLT's minimum is 6; from the sixth on the frame warped onto the map
    assert not state["preview_below_minimum"]["drawn"]
    at_min = state["preview_at_minimum"]
    assert at_min["drawn"] and at_min["ok"] and at_min["model"] == "dlt" and at_min["covered"] > 0.05
    # at the minimum, the control point farthest inside the image dragged by (15, -10) screen px on the map: the
    # picture around it moves along (DLT on 6 points, redundancy 1, follows it, overshooting a little)
    d = state["drag"]
    assert state["preview_after_drag"]["drawn"] and np.hypot(*d["moved_map"]) > 0
    # (the fit also turns and stretches the picture: the match is found where the point went, far better than where
    # it was, not perfect)
    moved, best, where = template_shift(out / "preview_before.png", out / "preview_after.png", d["screen"],
                                        d["canvas"][0])
    along = float(np.dot(moved, d["by"]) / np.hypot(*d["by"]))
    assert best > 0.45 and best > where + 0.25, (best, where)
    assert 0.5 * np.hypot(*d["by"]) < along < 2 * np.hypot(*d["by"]), moved
    for png in ("picker_dock.png", "picker_table.png", "picker_preview.png", "picker_proposals.png",
                "picker_accepted.png"):
        assert (out / png).stat().st_size > 20_000, png
        if os.environ.get("FOTOGEO_UPDATE_SCREENSHOTS"):
            shutil.copy(out / png, ROOT / "docs" / png)
