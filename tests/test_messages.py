"""Messages in the caller's words (issue 22): the command line's flags, QGIS's parameter labels, units named."""
from __future__ import annotations

from fotogeo.options import GCP, ORIENT, REGISTER, REGISTER_TERRAIN, in_labels
from fotogeo.tools.register.match import HINT
from fotogeo.tools.register.report import hint_lines


def test_every_flag_of_the_register_hint_becomes_its_label():
    text = in_labels(HINT, REGISTER_TERRAIN, REGISTER)
    assert "--" not in text
    for name in ("ratio", "max_keypoints", "hessian_threshold", "detector"):
        assert f"“{REGISTER[name].label}”" in text


def test_flags_of_other_tools_and_option_names_in_checks():
    assert in_labels("give --camera", GCP, ORIENT) == f"give “{GCP['camera'].label}”"
    assert in_labels("give --unknown-flag", GCP) == "give --unknown-flag"
    assert in_labels("ratio must be <= 1.0; got 2", REGISTER).startswith(f"“{REGISTER['ratio'].label}” must be")
    assert in_labels("--crs EPSG:1", REGISTER) == f"“{REGISTER['dst_crs'].label}” EPSG:1"  # flag differs from the name


def _report(check_px, terrain=False):
    rep = {"check": {"n": 30, "rmse_px": check_px, "rmse_m": check_px * 5}}
    return {**rep, "terrain": {}} if terrain else rep


def test_a_2d_fit_far_off_hints_at_the_dem():
    (line,) = hint_lines(_report(6.9))
    assert line.startswith("hint:") and "6.9 reference px (34.5 m)" in line and line.endswith("--dem")
    assert "DEM (terrain-aware" in in_labels(line, REGISTER_TERRAIN)
    assert hint_lines(_report(1.0)) == [] and hint_lines(_report(6.9, terrain=True)) == []
