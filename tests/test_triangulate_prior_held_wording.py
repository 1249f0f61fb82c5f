"""Frames whose attitude rests on its prior are warned about with what *this* flight cannot fix: a strip its roll
about the line, a ring or a block the tilt of the whole block to σ_z / √(Σ d²) (before: "e.g. a short strip cannot
fix its roll" whatever the flight, also for a ring)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from fotogeo.errors import FotogeoWarning
from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions
from fotogeo.tools.triangulate import adjust_determined
from fotogeo.tools.triangulate.determinacy import prior_held_warning


def _stand_in(centres, angle_sigma):
    """A block of frames at ``centres`` and a frame quality with their largest angle σ (what the warning reads)."""
    names = tuple(f"f{k}" for k in range(len(centres)))
    eo = [SimpleNamespace(centre=np.asarray(c, float)) for c in centres]
    return (SimpleNamespace(frames=names, eo=eo, role=np.array(["tie"])),
            SimpleNamespace(frames=names, angle_sigma=np.full(len(names), angle_sigma)))


def test_a_ring_flight_is_told_the_tilt_its_positions_fix_not_a_strip_roll():
    a = np.radians(np.arange(12) * 30.0)
    block, quality = _stand_in(np.c_[60 * np.cos(a), 60 * np.sin(a), np.full(12, 100.0)], 1.5)
    text = prior_held_warning(quality, 0.5, block, SimpleNamespace(eo_sigma=(3.0, 2.0)))
    # σ_θ = 3 / √(12 · 60² / 2) = 0.0204 rad
    assert "the 12 centres spread 120 × 120 m" in text and "tilt of the whole block to 1.2° at best" in text
    assert "strip" not in text and "roll" not in text and "RTK" in text


def test_a_strip_is_told_its_roll_about_the_line():
    block, quality = _stand_in(np.c_[np.arange(6) * 80.0, np.array([0, 2, -1, 1, -2, 0.0]), np.full(6, 300.0)], 1.0)
    text = prior_held_warning(quality, 0.5, block, SimpleNamespace(eo_sigma=(5.0, 2.0)))
    assert "the 6 centres fly one line, 400 m long and 3 m across" in text
    assert "roll about that line hardly at all" in text and "cross strip" in text


def test_with_control_the_frames_own_ties_are_named():
    block, quality = _stand_in([[0, 0, 100], [50, 0, 100], [0, 50, 100]], 1.0)
    block.role = np.array(["tie", "control"])
    assert "their own tie points do not fix it" in prior_held_warning(quality, 0.5, block,
                                                                      SimpleNamespace(eo_sigma=(3.0, 2.0)))
    assert prior_held_warning(SimpleNamespace(frames=("a",), angle_sigma=np.array([0.1])), 0.5) is None


@pytest.mark.parametrize("strips, expected", [
    (1, r"the 4 centres fly one line, 1188 m long and 6 m across.*fix the roll about that line hardly at all"
        r".*cross strip"),
    (2, r"the 6 centres spread 1245 × 564 m.*fix the tilt of the whole block to 0.3° at best")])
def test_simulated_blocks_adjusted_are_warned_for_their_own_geometry(strips, expected):
    """GNSS 3 m and attitude 1° priors, no control: a strip's roll rests on the prior; a 2 × 4 block's tilt is
    fixed by its positions to the bound (its frames' angle σ 0.27–0.28°, the bound 0.3°)."""
    sb = simulate_block(seed=2, strips=strips, frames_per_strip=4, camera=FrameCamera(6.0, (4.0, 6.0), (400, 600)),
                        point_spacing=40.0, margin=3.0, blunder_fraction=0.0, n_check=0, n_control=0)
    kw = {"min_frame_points": 6, "max_angle_sigma": 0.05, "undetermined": "drop"}
    with pytest.warns(FotogeoWarning, match=expected) as record:
        adjust_determined(sb.block, BundleOptions(snooping=False, eo_sigma=(3.0, 1.0)), kw, None)
    assert not any("short strip" in str(w.message) for w in record)
