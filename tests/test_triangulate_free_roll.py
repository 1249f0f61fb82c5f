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


def test_a_frame_off_the_line_that_is_dropped_does_not_hold_the_roll():
    """The check ran once, before the frames too sparse to adjust were dropped: a third frame off the line of two
    held them, then was dropped, and the two left went into an adjustment that cannot fix their roll. It is now
    made on the frames left, before each adjustment, naming the frame dropped."""
    block = _block(1, 3)
    c = np.array([e.centre for e in block.eo])
    across = np.cross(c[2] - c[0], [0.0, 0.0, 1.0])
    eo = list(block.eo)
    eo[1] = dataclasses.replace(eo[1], X=eo[1].X + 200 * across[0] / np.linalg.norm(across),
                                Y=eo[1].Y + 200 * across[1] / np.linalg.norm(across))  # 200 m off the line
    first = np.flatnonzero(block.obs_frame == 1)[:3]  # frame 1 keeps 3 observations: too sparse to adjust
    keep = (block.obs_frame != 1) | np.isin(np.arange(len(block.obs_frame)), first)
    block = dataclasses.replace(block, eo=tuple(eo), obs_frame=block.obs_frame[keep], obs_point=block.obs_point[keep],
                                obs_pixel=block.obs_pixel[keep],
                                obs_sigma=None if block.obs_sigma is None else np.asarray(block.obs_sigma)[keep])
    opts = BundleOptions(snooping=False, eo_sigma=(0.5, np.inf))
    assert free_roll(block, opts) is None  # three frames, one 200 m off the line: held
    with pytest.raises(ModelError, match=rf"only the positions of the frames are held .* the 2 centres make one line"
                                         rf".*--gcps.* \(dropped already: {block.frames[1]}\)$"):
        adjust_determined(block, opts, KW, None)


@pytest.mark.parametrize("tagged", [(True, True), (True, False), (False, False), "flag"])
def test_the_refusal_says_where_the_position_sigma_came_from(tagged):
    """The σ of the images' own GPS (accuracy tags, or a consumer receiver's 5 m) was named as
    ``--eo-sigma-position``, a flag the run was not given."""
    from fotogeo.tools.triangulate.sources import BlockStart
    block = _block(1, 2)
    start = BlockStart(CAMERA, (), list(block.frames), {}, None, "", "")
    if tagged != "flag":
        start.tagged = dict(zip(block.frames, tagged))
    source = start.sigma_source(0.5 if tagged == "flag" else None, None)
    text = free_roll(block, BundleOptions(eo_sigma=(0.02, np.inf)), source)
    expected = {(True, True): "σ 0.02 m from the images' GNSS accuracy tags",
                (True, False): "σ 0.02 m from the GNSS accuracy tags of 1 of the 2 images, 5 m for the others' GPS",
                (False, False): "σ 0.02 m for the images' GPS, 5 m when they carry no accuracy tag",
                "flag": "--eo-sigma-position 0.02 m"}[tagged]
    assert text.startswith(f"only the positions of the frames are held ({expected}")
    assert ("--eo-sigma-position" in text) == (tagged == "flag") and "--eo-sigma-angle" in text


def test_the_refusal_says_what_the_frames_files_lost():
    """Images whose XMP was cut lost their attitude tags: a warning per image said so, then the free-roll refusal
    asked for --eo-sigma-angle without saying why there was none. It now names the frames, so the refusal says what
    their files lost, and keeps the fix whole when the line is cut."""
    from fotogeo.errors import one_line
    from fotogeo.tools.triangulate.tool import _saying_what_was_lost
    block = _block(1, 2)
    lost = {n: "its XMP packet is not valid XML: its attitude, GPS accuracy and calibration tags were lost"
            for n in block.frames}
    with pytest.raises(ModelError) as err, _saying_what_was_lost(lost):
        adjust_determined(block, BundleOptions(snooping=False, eo_sigma=(0.5, np.inf)), KW, None)
    text = str(err.value)
    assert f"{', '.join(block.frames)}: its XMP packet is not valid XML: its attitude" in text
    assert "the roll about the base" in text
    assert one_line("y" * 900 + " " + text).endswith("(--eo-sigma-angle, e.g. the INS/gimbal accuracy in degrees), a "
                                                     "frame off that line, or ground control (--gcps, or --reference "
                                                     "with --dem)")
