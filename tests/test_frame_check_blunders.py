"""The frame check refuses a frame that the adjustment turned the wrong way and that therefore rejects its own tie
points as blunders (``fotogeo.orientation.bundle_quality``, the blunder share).

The scene is built, not matched, so that it holds whatever the detector: a simulated 3 x 5 block (600 x 400 px frames,
60/30 overlap, ±40 m relief, 9 GCPs) whose corner frame s3_01 sees 72 % of its tie points where a wrong orientation
(the centre 30 m off, κ turned 5°) puts them — as wrong matches on a repeated pattern would — and the rest where they
are. The wrong observations agree with each other, so the adjustment follows them: the frame comes out 29 m wrong
with enough points, spread and a small σ (0.33°, limit 0.5°), and only the share of its observations rejected as
blunders (20 of 69, limit 25 %) tells that it is wrong. Measured over 4 seeds of the choice and noise: 28–38 m wrong,
refused on the blunder share alone in 3, on its angle σ in the fourth.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.orientation.bundle_quality import frame_quality, undetermined_frames

#: share of the corner frame's tie observations moved to where the wrong orientation sees their ground points
WRONG_SHARE = 0.72


@pytest.fixture(scope="module")
def turned():
    cam = FrameCamera(6.0, (6.0, 4.0), (600, 400))
    sb = simulate_block(seed=3, strips=3, frames_per_strip=5, camera=cam, point_spacing=80.0, blunder_fraction=0.0,
                        margin=5.0, n_control=9, n_check=40)
    b = sb.block
    j = b.frames.index("s3_01")
    t = sb.true_eo[j]
    wrong = ExteriorOrientation(t.X + 30.0, t.Y - 10.0, t.Z, t.omega, t.phi, t.kappa + 5.0)
    mine = np.flatnonzero((b.obs_frame == j) & (b.role[b.obs_point] == "tie"))
    moved = OrientedFrame(sb.true_camera, wrong).world_to_pixel(sb.true_xyz[b.obs_point[mine]])
    w, h = cam.image_size
    inside = (np.isfinite(moved).all(axis=1) & (moved[:, 0] > 0) & (moved[:, 0] < w) & (moved[:, 1] > 0)
              & (moved[:, 1] < h))
    rng = np.random.default_rng(0)
    pick = rng.permutation(np.flatnonzero(inside))[:int(round(WRONG_SHARE * len(mine)))]
    pixel = b.obs_pixel.copy()
    pixel[mine[pick]] = moved[pick] + rng.normal(0, 0.3, (len(pick), 2))
    return sb, dataclasses.replace(b, obs_pixel=pixel), len(pick) / len(mine)


def test_frame_check_refuses_a_frame_that_rejects_its_own_tie_points(turned):
    sb, blk, share = turned
    assert share > 0.7, share  # the scene: most of the frame's ties fit the wrong orientation
    res = adjust_block(blk, BundleOptions())
    true = dict(zip(sb.block.frames, sb.true_eo))
    err = {n: float(np.linalg.norm(e.centre - true[n].centre)) for n, e in zip(res.frames, res.eo)}
    assert {n for n, d in err.items() if d > 20.0} == {"s3_01"}, err  # it went the wrong way, and only it
    assert max(d for n, d in err.items() if n != "s3_01") < 8.0, err
    q = frame_quality(res, blk)
    j = blk.frames.index("s3_01")
    # what makes the check necessary: the wrong frame passes points, spread and precision
    assert q.points[j] >= 6 and q.spread[j] > 0.05 and q.angle_sigma[j] < 0.5, q
    bad = undetermined_frames(q)
    assert set(bad) == {"s3_01"}, (err, bad)  # refused, and no right frame with it
    assert "rejected as blunders" in bad["s3_01"], bad
    # ... and it is the blunder share that refuses it: without that limit the frame passes
    assert "s3_01" not in undetermined_frames(q, max_blunder_share=1.0)
