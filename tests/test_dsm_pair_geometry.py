"""Pairs judged by the angle at which their rays meet (:mod:`fotogeo.stereo.pairs`), not by the whole base: the
base of obliques flown along the way they look lies mostly along the lines of sight (issue 30, oblique sets)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fotogeo.stereo.pairs import Limits, base_across, choose_pairs
from fotogeo.tools.dsm import dsm

from dsm_oblique_sets import SETS, make_set
from dsm_scenes import compare


def test_a_base_along_the_lines_of_sight_is_too_weak():
    """Two frames 15 m apart at 100 m both looking ahead along their base at ground 150 m ahead: the whole base
    gives B/H 0.083 (above the 0.08 limit, kept before), the rays meet at 2.6 degrees (2 tan(γ/2) 0.046): left out.
    The same two frames over ground below them (nadir) keep their pair: there the two ratios agree."""
    sq = np.array([[-30, -30, 0], [30, -30, 0], [30, 30, 0], [-30, 30, 0]], float)
    centres = [np.array([0, 0, 100.0]), np.array([15, 0, 100.0])]
    ahead = [sq + [157.5, 0, 0]] * 2
    axes = [np.array([150.0, 0, -100.0])] * 2
    p = choose_pairs(centres, axes, ahead)[0]
    assert p.base_height == pytest.approx(0.083, abs=0.002) and base_across(p) == pytest.approx(0.046, abs=0.003)
    assert not p.kept and "across the lines of sight" in p.reason and f"{p.convergence:.1f} degrees" in p.reason
    below = choose_pairs(centres, [np.array([0, 0, -1.0])] * 2, [sq + [7.5, 0, 0]] * 2)[0]
    assert below.kept and base_across(below) == pytest.approx(below.base_height, rel=0.03)


#: not one of :data:`dsm_oblique_sets.SETS`: strips flown east and south at −55°, two frames 20 m apart each
EAST_AND_SOUTH = {"strips": [(90, -55.0, 2), (180, -55.0, 2)], "base": 20.0, "seed": 31}


def test_oblique_strips_are_paired_across(tmp_path):
    """Within a strip the rays meet at about 5 degrees; across the two strips (views about 50 degrees apart, within
    the 70 the view-angle sweep supports) at 35–45. Those are matched now and the DSM meets issue 30's rendered
    targets, RMSE ≤ 1 GSD and ≥ 95 % complete (before: only the two within-strip pairs, the cross pairs left out
    for their views)."""
    assert EAST_AND_SOUTH not in SETS.values()
    sc = make_set(EAST_AND_SOUTH, tmp_path / "set")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = dsm(sc["images"], tmp_path / "dsm.tif", camera=sc["camera"], eo=sc["eo"], crs=sc["crs"])
    cross = [p for p in rep["pairs"] if p["images"][0][:2] != p["images"][1][:2]]
    assert cross and all(p["kept"] and p["convergence_deg"] > 20 for p in cross), [p["reason"] for p in cross]
    assert Limits().max_view_angle >= max(p["view_angle_deg"] for p in cross)
    c = compare(tmp_path / "dsm.tif", sc["surface"])
    assert c["rmse"] <= sc["gsd"], c["rmse"] / sc["gsd"]
    assert rep["completeness"] >= 0.95
