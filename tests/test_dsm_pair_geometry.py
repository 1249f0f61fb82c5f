"""Pairs judged by the angle at which their rays meet (:mod:`fotogeo.stereo.pairs`), not by the whole base: the
base of obliques flown along the way they look lies mostly along the lines of sight (issue 30, oblique sets)."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.stereo.pairs import base_across, choose_pairs


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
