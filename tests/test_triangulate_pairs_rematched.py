"""A pair's band re-match (``bands_rematched``, :func:`fotogeo.tools.register.bands.rematch`) is in triangulate's
per-pair report whether the pairs run in this process or as Dask tasks (``--workers``,
:mod:`fotogeo.tools.triangulate.pairs`): both paths give the same rows. The re-match itself is register's (tested in
test_register_band_sets.py, test_bands_cached_rematch.py); here :func:`find_tie_points` reports one for the pairs of
the first frame, on a rendered block, and the two reports must carry it alike."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import fotogeo.tools.triangulate.match as tm
import fotogeo.tools.triangulate.pairs as tp
from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import simulate_block
from rendered_block_ties import write_frames

AGAIN = {"combined": "target", "weights": [0.5, 0.5], "inliers_before": 9, "inliers_after": 41, "kept": True}


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    cam = FrameCamera(6.0, (4.0, 6.0), (400, 600))
    sb = simulate_block(seed=1, strips=1, frames_per_strip=3, camera=cam, point_spacing=80.0, blunder_fraction=0.0,
                        margin=5.0)
    images, _ = render_block(sb)
    paths = write_frames(tmp_path_factory.mktemp("frames"), sb, images)
    return sb, paths, float(np.nanmean(sb.block.point_xyz[:, 2]))


def _reporting(real, first):
    def find(ref, tgt, opts, *args, **kw):
        xy_t, xy_r, counts = real(ref, tgt, opts, *args, **kw)
        again = {"bands_rematched": dict(AGAIN)} if Path(str(ref.path)).name == first else {}
        return xy_t, xy_r, {**counts, **again}
    return find


def test_the_pairs_band_rematch_is_reported_by_both_paths(block, monkeypatch):
    distributed = pytest.importorskip("distributed")
    import cv2

    from fotogeo.tools.register.batch import SINGLE_THREAD_ENV
    sb, paths, height = block
    for mod in (tm, tp):
        monkeypatch.setattr(mod, "find_tie_points", _reporting(mod.find_tie_points, Path(paths[0]).name))
    local = tm.block_tie_points(paths, sb.block.camera, sb.block.eo, height, lsm=False)[4]["pairs"]
    env, threads = {k: os.environ.get(k) for k in SINGLE_THREAD_ENV}, cv2.getNumThreads()
    try:  # a worker thread of this process sees the patched function; the threads it pins are restored afterwards
        with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                      dashboard_address=None) as cluster, distributed.Client(cluster) as client:
            tasks = tm.block_tie_points(paths, sb.block.camera, sb.block.eo, height, lsm=False,
                                        client=client)[4]["pairs"]
    finally:
        cv2.setNumThreads(threads)
        for k, v in env.items():
            os.environ.pop(k, None) if v is None else os.environ.__setitem__(k, v)
    rematched = [r["pair"] for r in local if "bands_rematched" in r]
    assert rematched and all(0 in p for p in rematched) and all(r["bands_rematched"] == AGAIN for r in local
                                                                  if "bands_rematched" in r)
    assert tasks == local
