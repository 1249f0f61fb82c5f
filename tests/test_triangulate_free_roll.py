"""Two frames (or a straight strip) held only by their positions: the roll of the block about the line of the
centres is a datum defect. The refusal said "no angle σ (the normal equations are singular there: near-parallel rays
or no datum)" for each frame; it now says why (the rotation about the base moves no centre) and the fix
(--eo-sigma-angle, a frame off that line, or GCPs), before adjusting."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fotogeo.errors import ModelError
from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions
from fotogeo.tools.triangulate import adjust_determined
from fotogeo.tools.triangulate.determinacy import free_roll

CAMERA = FrameCamera(6.0, (4.0, 6.0), (400, 600))
KW = {"min_frame_points": 6, "max_angle_sigma": 0.5, "undetermined": "drop"}


def _block(strips: int, frames: int):
    return simulate_block(seed=2, strips=strips, frames_per_strip=frames, camera=CAMERA, point_spacing=40.0,
                          margin=3.0, blunder_fraction=0.0, n_check=0, n_control=0).block


def test_two_frames_held_by_their_positions_only_are_refused_with_why_and_the_fix():
    block = _block(1, 2)
    with pytest.raises(ModelError, match=r"only the positions of the frames are held \(--eo-sigma-position 0.5 m\), "
                                         r"and the 2 centres make one line: a rotation of the whole block about that "
                                         r"line \(the roll about the base\).*--eo-sigma-angle.*a frame off that "
                                         r"line.*--gcps"):
        adjust_determined(block, BundleOptions(snooping=False, eo_sigma=(0.5, np.inf)), KW, None)


def test_a_straight_strip_within_its_position_sigma_of_a_line_is_refused_alike():
    block = _block(1, 4)
    assert "the 4 centres lie on one line within their σ" in free_roll(block, BundleOptions(eo_sigma=(10.0, np.inf)))
    assert free_roll(block, BundleOptions(eo_sigma=(0.5, np.inf))) is None  # 4.8 m off the line: σ decides


@pytest.mark.parametrize("what", ["angles", "control", "two strips", "no prior"])
def test_anything_that_fixes_the_roll_lets_the_block_through(what):
    block, sigma = _block(1, 2), (0.5, np.inf)
    if what == "angles":
        sigma = (0.5, 1.0)
    elif what == "control":
        block = dataclasses.replace(block, role=np.where(np.arange(len(block.role)) == 0, "control", block.role))
    elif what == "two strips":
        block = _block(2, 4)
    else:
        sigma = None
    assert free_roll(block, BundleOptions(eo_sigma=sigma)) is None
