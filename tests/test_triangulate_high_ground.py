"""Tie points of a rendered block over high ground (issue 20): the overlaps a block is flown for must hold at the
ground, or no tie-point step can find points in three frames of a strip.

The rendered 100-frame block of ``benchmarks/triangulate_block_bench.py`` lost its 3-ray tracks strip by strip
(391 in strip 2, 10 in strip 10) and strips 7–10 came out undetermined. The matching was not the cause: its
terrain (hills of ``relief`` 40 m) rises from 40 to 267 m across the block, every frame was flown 1000 m above
the datum, so the 60/30 % overlaps shrank to 46/7 % at the ground of the last strips — no ground point in three
frames of a strip, and even the simulation's own blunder-free tie points (25 m grid) left frame s10_07 36 m
wrong. Flown 1000 m above each strip's terrain (``simulate_block(above_terrain=True)``), every strip keeps its
overlaps. Here a 3 x 5 block whose first strip lies about 140 m above the datum (seed 10, ``relief`` 80).
"""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.orientation.bundle_quality import frame_quality, undetermined_frames
from fotogeo.tools.triangulate.match import block_tie_points
from fotogeo.tools.triangulate.pairs import MIN_PAIR_INLIERS, epipolar_kept
from rendered_block_ties import with_ties, write_frames

CAMERA = FrameCamera(6.0, (6.0, 4.0), (600, 400))
STRIPS, PER_STRIP = 3, 5


def high_ground_block(above_terrain: bool):
    return simulate_block(seed=10, strips=STRIPS, frames_per_strip=PER_STRIP, camera=CAMERA, relief=80.0,
                          point_spacing=80.0, blunder_fraction=0.0, margin=5.0, n_control=9, n_check=20,
                          above_terrain=above_terrain)


def strip_tracks_of_three(frame, track) -> list:
    """Per strip: tracks seen in at least three of its frames (the points that carry a strip's scale)."""
    out = []
    for s in range(STRIPS):
        mine = frame // PER_STRIP == s
        counts = np.bincount(track[mine], minlength=int(track.max()) + 1)
        out.append(int((counts >= 3).sum()))
    return out


def test_a_strip_over_high_ground_keeps_its_overlap_when_flown_above_its_terrain():
    datum, terrain = high_ground_block(False), high_ground_block(True)
    flown = strip_tracks_of_three(datum.block.obs_frame, datum.block.obs_point)
    planned = strip_tracks_of_three(terrain.block.obs_frame, terrain.block.obs_point)
    # the simulation's own ground points in three frames of a strip: measured [3, 24, 32] -> [40, 42, 54]
    assert min(flown) < 0.3 * min(planned), (flown, planned)  # the block this test is about
    assert max(planned) < 1.5 * min(planned), planned  # every strip flown for the same overlap
    rise = np.array([e.Z for e in terrain.true_eo]) - np.array([e.Z for e in datum.true_eo])
    assert np.ptp(rise) > 50.0  # strips at different heights, each 1000 m above its own ground (54–140 m up)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    sb = high_ground_block(True)
    images, _ = render_block(sb, seed=10)
    paths = write_frames(tmp_path_factory.mktemp("frames"), sb, images)
    ties = block_tie_points(paths, CAMERA, sb.block.eo, float(np.nanmean(sb.block.point_xyz[:, 2])))
    return sb, ties


def test_matched_tracks_of_three_rays_in_every_strip_and_every_frame_determined(rendered):
    sb, (frame, track, pixel, sigma, rep) = rendered
    tracks = strip_tracks_of_three(frame, track)
    # measured [29, 44, 65]; the same block flown 1000 m above the datum: [0, 22, 27] (and still determined:
    # 9 GCPs on 15 frames hold it)
    assert min(tracks) >= 20, tracks
    blk = with_ties(sb, frame, track, pixel, sigma, 0.3)
    res = adjust_block(blk, BundleOptions())
    assert undetermined_frames(frame_quality(res, blk)) == {}
    true = dict(zip(sb.block.frames, sb.true_eo))
    err = [float(np.linalg.norm(e.centre - true[n].centre)) for n, e in zip(res.frames, res.eo)]
    assert max(err) < 5.0, err  # 3 GSD at 1000 m; measured 1.74 m


def test_a_pair_of_chance_matches_gives_no_tie_points():
    """RANSAC finds a fundamental matrix for 8–11 of a pair's random matches; fewer than
    MIN_PAIR_INLIERS make no pair."""
    rng = np.random.default_rng(0)
    xy_i, xy_j = rng.uniform(0, 600, (25, 2)), rng.uniform(0, 400, (25, 2))
    n, kept_i, kept_j = epipolar_kept(xy_i, xy_j, None, 2.0)
    assert n == 25 and len(kept_i) == len(kept_j) == 0
    n, kept_i, _ = epipolar_kept(xy_i, xy_j, None, 2.0, min_inliers=0)
    assert len(kept_i) < MIN_PAIR_INLIERS  # what the pair brought before (9 measured): all of it chance
