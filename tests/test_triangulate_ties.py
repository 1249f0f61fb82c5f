"""Tie points of a rendered block (issue 13): pyramid detection, Gruber thinning, LSM at full resolution.

The frames are rendered through their true cameras (fotogeo.orientation.block_render), so every
tie point has a true position in every frame: the anchor pixel's ray meets the rendered
terrain, and that ground point projects into the other frames.
"""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.geometry.camera import FrameCamera, OrientedFrame
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.tools.triangulate.match import block_tie_points, image_regions, matched_observations, refine_tracks
from rendered_block_ties import with_ties, write_frames


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    cam = FrameCamera(6.0, (4.0, 6.0), (400, 600))
    sb = simulate_block(seed=1, strips=2, frames_per_strip=4, camera=cam, point_spacing=80.0, blunder_fraction=0.0,
                        margin=5.0)
    images, dem = render_block(sb)
    paths = write_frames(tmp_path_factory.mktemp("frames"), sb, images)
    height = float(np.nanmean(sb.block.point_xyz[:, 2]))
    frame, track, pixel, sigma, rep = block_tie_points(paths, cam, sb.block.eo, height, lsm=False)
    return sb, dem, paths, height, frame, track, pixel, rep


def true_transfer_error(sb, dem, frame, track, pixel):
    """px error of every non-anchor observation against the true transfer of its track's anchor."""
    err = []
    for t in np.unique(track):
        m = np.flatnonzero(track == t)
        a, others = m[np.argmin(frame[m])], m[frame[m] != frame[m].min()]
        g = OrientedFrame(sb.true_camera, sb.true_eo[frame[a]]).pixel_to_world(pixel[a:a + 1], dem)
        for o in others:
            err.append(OrientedFrame(sb.true_camera, sb.true_eo[frame[o]]).world_to_pixel(g)[0] - pixel[o])
    e = np.array(err)
    return np.hypot(*e[np.isfinite(e).all(axis=1)].T)


def region_overlap(sb, height: float, step: int = 10) -> np.ndarray:
    """``(frames, 9)`` share of each Gruber region of each frame that another frame sees (true orientations,
    the plane at ``height``): where a tie point can be at all."""
    cam = sb.true_camera
    w, h = cam.image_size
    yy, xx = np.mgrid[step // 2:h:step, step // 2:w:step]
    px = np.column_stack([xx.ravel(), yy.ravel()]).astype(float)
    region = image_regions(px, cam)
    out = []
    for f, eo in enumerate(sb.true_eo):
        ground = OrientedFrame(cam, eo).pixel_to_world_at(px, height)
        seen = np.zeros(len(px), bool)
        for o in set(range(len(sb.true_eo))) - {f}:
            q = OrientedFrame(cam, sb.true_eo[o]).world_to_pixel(ground)
            seen |= (q[:, 0] > 0) & (q[:, 0] < w) & (q[:, 1] > 0) & (q[:, 1] < h)
        out.append(np.bincount(region, weights=seen, minlength=9) / np.bincount(region, minlength=9))
    return np.array(out)


def test_detection_on_level_one_is_thinned_to_gruber_positions(rendered):
    sb, _, _, height, frame, track, pixel, rep = rendered
    assert rep["detection_level"] == 1 and rep["tracks"] < rep["tracks_matched"]
    cam = sb.block.camera
    region = image_regions(pixel, cam)
    overlap = region_overlap(sb, height)
    for f in range(len(sb.block.frames)):
        counts = np.bincount(region[frame == f], minlength=9)
        # every region another frame sees holds tie points; the first and last frames of a strip have a third
        # or two of a row of regions that no frame sees (s2_01's lower left: 0 % and 14 %), where none can be
        # (measured: 17 or more with the box filters, 18 with the Gaussian layers, in each region at least half seen)
        assert (counts[overlap[f] >= 0.5] >= 10).all(), (f, counts, overlap[f].round(2))
        assert (overlap[f] >= 0.5).sum() >= 6, overlap[f]  # the block's layout: the test sees most regions
        # a track kept for one frame's region also counts in the others: bounded, not exact
        assert counts.max() <= 3 * 25, (f, counts)
    assert max(int(k) for k in rep["rays_per_track"]) >= 3  # multi-ray tracks where the overlaps allow


def test_lsm_follows_the_level_one_keypoints_down_to_full_resolution(rendered):
    sb, dem, paths, height, frame, track, pixel, _ = rendered
    from fotogeo.io.raster import open_raster
    infos = [open_raster(p) for p in paths]
    ok, refined, sigma, summary = refine_tracks(infos, frame, track, pixel, sb.block.camera, sb.block.eo, height,
                                                max_shift=3.5)
    before = true_transfer_error(sb, dem, frame, track, pixel)
    after = true_transfer_error(sb, dem, frame[ok], track[ok], refined[ok])
    assert summary["converged"] > 0.8 * summary["transfers"]
    # keypoints at level 1 are ±1 px at full resolution; LSM (21² windows, grey noise 2) brings them to
    # a tenth of a pixel: measured median 0.40 -> 0.11 px, 90 % 0.23 px
    assert np.median(before) > 0.3 and np.median(after) < 0.15, (np.median(before), np.median(after))
    assert np.percentile(after, 90) < 0.3
    assert 0.1 <= np.median(sigma[ok]) < 0.2  # LSM's σ, floored at 0.1 px (it is optimistic)


def test_refined_block_reaches_a_fraction_of_a_pixel(rendered):
    sb, _, paths, height, *_ = rendered
    obs, rep = matched_observations(paths, list(sb.block.frames), sb.block.camera, sb.block.eo, height)
    assert rep["lsm"]["converged"] > 0.8 * rep["lsm"]["transfers"]
    index = {n: k for k, n in enumerate(sb.block.frames)}
    frame = np.array([index[f] for f in obs.frame])
    track = np.array([int(p[3:]) for p in obs.point])
    res = adjust_block(with_ties(sb, frame, track, obs.pixel, obs.sigma, 0.3), BundleOptions())
    chk = res.stats["check"]
    # measured on this block: 0.28 / 0.55 GSD (0.62 / 1.22 with full-resolution SURF and no LSM)
    assert chk["rmse_planimetric_m"] < 0.45 * sb.gsd and chk["rmse_z_m"] < 0.9 * sb.gsd, chk
    assert res.stats["image_rms_px"] < 0.12


def test_a_frame_that_overlaps_no_other_is_still_named(rendered):
    import dataclasses

    from fotogeo.errors import MatchingError
    sb, _, paths, height, *_ = rendered
    eos = list(sb.block.eo)
    eos[2] = dataclasses.replace(eos[2], X=eos[2].X + 50000.0)
    with pytest.raises(MatchingError, match=f"{sb.block.frames[2]}.tif.*overlap no other frame"):
        block_tie_points(paths, sb.block.camera, eos, height)


def test_each_frame_is_detected_once_and_the_tie_points_stay_the_same(rendered, monkeypatch):
    """The keypoint cache (fotogeo.tools.register.match.FeatureCache) changes the number of detections only:
    matching every pair with fresh detections of both frames gives the same tracks and observations."""
    import fotogeo.tools.register.match as match
    import fotogeo.tools.triangulate.match as triangulate_match
    sb, _, paths, height, *_ = rendered
    detections = []
    detect = match.detect
    monkeypatch.setattr(match, "detect", lambda *a, **k: detections.append(1) or detect(*a, **k))
    cached = block_tie_points(paths, sb.block.camera, sb.block.eo, height, lsm=False)
    n_cached = len(detections)
    find = triangulate_match.find_tie_points
    monkeypatch.setattr(triangulate_match, "find_tie_points", lambda *a, cache=None, **k: find(*a, **k))
    detections.clear()
    fresh = block_tie_points(paths, sb.block.camera, sb.block.eo, height, lsm=False)
    n_pairs = len(fresh[4]["pairs"])
    assert n_cached == len(paths) and len(detections) == 2 * n_pairs and n_pairs > len(paths)
    for a, b in zip(cached[:3], fresh[:3]):  # frame, track, pixel
        np.testing.assert_array_equal(a, b)
    assert cached[4] == fresh[4]


def test_epipolar_ransac_sees_the_pixels_of_the_distortion_free_camera():
    """ideal_pixels: a pixel measured through Brown's distortion (the adjustment's projection) maps to the pixel
    of the same ground point in the pinhole camera; no distortion: no mapping (the RANSAC sees the pixels)."""
    from fotogeo.geometry.camera import ExteriorOrientation
    from fotogeo.tools.triangulate.match import ideal_pixels
    from fotogeo.orientation.adjusted_frame import AdjustedFrame
    cam = FrameCamera(520.0, (640.0, 480.0), (640, 480), (321.5, 238.0))
    eo = ExteriorOrientation(0.0, 0.0, 80.0, 10.0, -5.0, 30.0)
    k = (-0.06, 0.02, 0.0, 0.0004, -0.0003)  # k1, k2, k3, p1, p2: ~14 px at the corners
    ground = np.column_stack([np.random.default_rng(0).uniform(-40, 40, (200, 2)), np.zeros(200)])
    measured = AdjustedFrame(cam, eo, dict(zip(("k1", "k2", "k3", "p1", "p2"), k))).forward(ground)
    pinhole = OrientedFrame(cam, eo).world_to_pixel(ground)
    inside = ((measured >= 0) & (measured < [640, 480])).all(axis=1)
    assert inside.sum() > 50 and np.abs(measured - pinhole)[inside].max() > 3.0
    np.testing.assert_allclose(ideal_pixels(cam, k)(measured[inside]), pinhole[inside], atol=1e-6)
    assert ideal_pixels(cam, dict(zip(("k1", "k2"), k))) is not None
    assert ideal_pixels(cam, (0.0,) * 5) is None and ideal_pixels(cam, None) is None


def _on_a_thread_cluster(run):
    """``run(client)`` on a one-worker Dask cluster in this process's threads (a monkeypatch reaches its tasks);
    the threads its tasks pin in this process are restored afterwards."""
    distributed = pytest.importorskip("distributed")
    import os

    import cv2

    from fotogeo.tools.register.batch import SINGLE_THREAD_ENV
    env, threads = {k: os.environ.get(k) for k in SINGLE_THREAD_ENV}, cv2.getNumThreads()
    try:
        with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                      dashboard_address=None) as cluster, distributed.Client(cluster) as client:
            return run(client)
    finally:
        cv2.setNumThreads(threads)
        for k, v in env.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def test_pairs_as_dask_tasks_give_the_same_tie_points(rendered):
    """--scheduler / --workers (fotogeo.tools.triangulate.pairs): one detection task per frame, one matching
    task per pair, one LSM task per frame pair, gathered in order — the tracks, pixels, σ and report of the
    in-process path, to the bit."""
    sb, _, paths, height, *_ = rendered
    local = block_tie_points(paths, sb.block.camera, sb.block.eo, height)
    tasks = _on_a_thread_cluster(lambda client: block_tie_points(paths, sb.block.camera, sb.block.eo, height,
                                                                 client=client))
    assert tasks[4]["pairs"] == local[4]["pairs"] and sum(p["inliers"] for p in local[4]["pairs"]) > 0
    for a, b in zip(local[:4], tasks[:4]):  # frame, track, pixel, sigma
        np.testing.assert_array_equal(a, b)
    assert tasks[4] == local[4]


def test_a_pairs_band_rematch_is_reported_by_both_paths(rendered, monkeypatch):
    """A pair's band re-match (``bands_rematched``, fotogeo.tools.register.bands.rematch) is in the per-pair
    report whether the pairs run in this process or as Dask tasks, alike; both dropped it before. The re-match
    itself is register's (test_register_band_sets.py, test_bands_cached_rematch.py): here find_tie_points
    reports one for the pairs whose reference is the first frame."""
    from pathlib import Path

    import fotogeo.tools.triangulate.match as tm
    import fotogeo.tools.triangulate.pairs as tp
    sb, _, paths, height, *_ = rendered
    again = {"combined": "target", "weights": [0.5, 0.5], "inliers_before": 9, "inliers_after": 41, "kept": True}

    def reporting(real):
        def find(ref, tgt, opts, *args, **kw):
            xy_t, xy_r, counts = real(ref, tgt, opts, *args, **kw)
            return xy_t, xy_r, {**counts, **({"bands_rematched": dict(again)}
                                             if Path(str(ref.path)).name == Path(paths[0]).name else {})}
        return find
    for mod in (tm, tp):
        monkeypatch.setattr(mod, "find_tie_points", reporting(mod.find_tie_points))
    local = block_tie_points(paths, sb.block.camera, sb.block.eo, height, lsm=False)[4]["pairs"]
    tasks = _on_a_thread_cluster(lambda client: block_tie_points(paths, sb.block.camera, sb.block.eo, height,
                                                                 lsm=False, client=client))[4]["pairs"]
    told = [r for r in local if "bands_rematched" in r]
    assert told and all(r["pair"][0] == 0 and r["bands_rematched"] == again for r in told)
    assert tasks == local
