"""A frame whose tie points are too few or cover a sliver is refused (or dropped) before the adjustment, not after.

The adjustment only rejects observations, so a frame failing the points/spread tests with all of them fails them
after any adjustment too: the run can say so in seconds. The eBee turn pair (IMG_2212/2213, points on < 2 % of each
frame) used to be refused only after the whole adjustment and its data snooping.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fotogeo.errors import ModelError
from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions
from fotogeo.orientation.bundle_quality import sparse_frames
from fotogeo.tools.triangulate import adjust_determined
from fotogeo.tools.triangulate import determinacy

CAMERA = FrameCamera(6.0, (4.0, 6.0), (400, 600))
KW = {"min_frame_points": 6, "max_angle_sigma": 0.5, "undetermined": "fail"}


@pytest.fixture(scope="module")
def sb():
    return simulate_block(seed=3, strips=2, frames_per_strip=3, camera=CAMERA, point_spacing=40.0, margin=3.0,
                          blunder_fraction=0.0, n_check=5)


def _corner_only(block, frame_index: int):
    """``block`` with frame ``frame_index``'s observations reduced to those in its top-left 12 % × 12 % corner."""
    w, h = CAMERA.image_size
    obs = block.obs_frame == frame_index
    far = obs & ((block.obs_pixel[:, 0] > 0.12 * w) | (block.obs_pixel[:, 1] > 0.12 * h))
    keep = ~far
    assert (obs & keep).sum() >= 1
    return dataclasses.replace(block, obs_frame=block.obs_frame[keep], obs_point=block.obs_point[keep],
                               obs_pixel=block.obs_pixel[keep], obs_sigma=block.obs_sigma[keep])


def _no_adjustment(*a, **k):
    raise AssertionError("adjusted although a frame was known to be undetermined")


def test_a_sliver_frame_is_named_before_any_adjustment(sb, monkeypatch):
    block = _corner_only(sb.block, 4)
    name = block.frames[4]
    sparse = sparse_frames(block)
    assert list(sparse) == [name] and "points cover" in sparse[name]
    monkeypatch.setattr(determinacy, "adjust_block", _no_adjustment)
    with pytest.raises(ModelError, match=f"does not determine frame\\(s\\) {name}: .*points cover.*"
                                         f"--undetermined drop"):
        adjust_determined(block, BundleOptions(snooping=False), KW, None)


def test_dropped_up_front_on_request_and_the_rest_adjusted(sb):
    block = _corner_only(sb.block, 4)
    name = block.frames[4]
    result, kept, quality, dropped, _ = adjust_determined(block, BundleOptions(snooping=False),
                                                          {**KW, "undetermined": "drop"}, None)
    assert [d["name"] for d in dropped] == [name] and "points cover" in dropped[0]["reason"]
    assert name not in kept.frames and len(result.eo) == len(block.frames) - 1
    truth = dict(zip(sb.block.frames, sb.true_eo))
    for n, e in zip(kept.frames, result.eo):
        assert np.hypot(e.X - truth[n].X, e.Y - truth[n].Y) < 2 * sb.gsd, n


def test_a_well_tied_block_has_no_sparse_frame(sb):
    assert sparse_frames(sb.block) == {}
