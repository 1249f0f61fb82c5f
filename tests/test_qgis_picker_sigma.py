"""The picker's ``Click σ`` (the a priori precision of a click) is what the blunder test uses
(tests/picker_sigma_script.py): at 0.8 px click noise a 5 px blunder among 15 DLT GCPs is flagged alone at the
default 1 px; the same points at 10 px (a sloppy click) flag nothing; eight clean GCPs flag nothing; Rectify and
Report run orient with the same σ."""
from __future__ import annotations

import numpy as np
import pytest
from test_qgis_picker import FRAME, run_script, truth_gcps

pytestmark = [pytest.mark.qgis]


def test_click_sigma_drives_the_blunder_flags(data_dir, tmp_path):
    gcps, crs = truth_gcps(data_dir, n=24)
    rng = np.random.default_rng(11)  # held out: another seed and other points than the engine's tests
    noisy = [{**g, "col": g["col"] + rng.normal(0, 0.8), "row": g["row"] + rng.normal(0, 0.8)} for g in gcps[:15]]
    noisy[6] = {**noisy[6], "col": noisy[6]["col"] + 3.0, "row": noisy[6]["row"] - 4.0}  # a 5 px blunder: GCP 7
    clean = [{**g, "col": g["col"] + rng.normal(0, 0.8), "row": g["row"] + rng.normal(0, 0.8)} for g in gcps[15:23]]
    state = run_script("picker_sigma_script.py", {"frame": str(data_dir / FRAME), "crs": crs, "gcps": gcps,
                                                   "dem": str(data_dir / "ngi" / "dem.tif"), "noisy": noisy,
                                                   "clean": clean}, tmp_path)
    assert state["default_sigma"] == 1.0
    def flagged(fit):  # "not testable" (a point the others cannot check) is no verdict
        return sorted(i for i, f in fit["flags"].items() if "blunder" in f or "suspect" in f)
    at_1 = state["sigma_1"]
    assert at_1["ok"] and flagged(at_1) == ["7"] and "blunder" in at_1["flags"]["7"], at_1
    assert "1 suspected blunder" in at_1["summary"]
    assert at_1["orange_marks"] == ["7"]  # drawn as flagged on the map: the blunder, not the "not testable" points
    assert state["sigma_10"]["ok"] and not flagged(state["sigma_10"]), state["sigma_10"]
    assert abs(state["sigma_1"]["w"]["7"]) > 5 * abs(state["sigma_10"]["w"]["7"]) * 0.9  # w scales with 1/σ
    assert state["orient_sigma"] == 1.0
    assert state["clean"]["ok"] and not flagged(state["clean"]), state["clean"]
