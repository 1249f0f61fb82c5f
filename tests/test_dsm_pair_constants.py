"""What a frame pair of fotogeo dsm fixes once for all its strips: SGBM's contrast-scaled penalties (not one per
strip), and its sparse matches without their mismatches — one filter for the pair's height range and for the
strips' local ranges; the range's high end capped once, below the cameras."""
from __future__ import annotations

import cv2
import numpy as np

from fotogeo.orientation.block_render import texture
from fotogeo.stereo import dense
from fotogeo.stereo.rectify import rectify
from fotogeo.tools.dsm import frames, local
from fotogeo.tools.dsm.plan import disparity_bounds, matched_heights, plausible_heights, supported_span

from rendered_pair import CRS, render
from test_dsm_tiles import _views


def test_one_penalty_factor_whatever_the_piece(monkeypatch):
    """Pieces of sharp and of smooth texture: the pair's factor is one number measured over both, and a piece
    matched with it builds its SGBM with that factor, not with its own contrast's."""
    rng = np.random.default_rng(8)
    sharp = texture(rng, (96, 160)).astype(np.float32)
    smooth = cv2.GaussianBlur(texture(rng, (96, 160)).astype(np.float32), (0, 0), 2.0)
    ok = np.ones(sharp.shape, bool)
    alone = dense.penalty_scale([sharp], [ok])
    assert alone > 1.0 and dense.penalty_scale([smooth], [ok]) == 1.0  # OpenCV's penalties at the least
    both = dense.penalty_scale([sharp, smooth], [ok, ok])
    assert 1.0 <= both < alone
    used = []
    real = dense._matcher
    monkeypatch.setattr(dense, "_matcher", lambda *a: used.append(a[-1]) or real(*a))
    shifted = np.roll(smooth, -3, axis=1)
    dense.disparity(smooth, shifted, ok, ok, 0.0, 8.0, penalty=alone)
    dense.disparity(smooth, shifted, ok, ok, 0.0, 8.0)
    assert used == [alone, 1.0]  # given: the pair's; not given: the piece's own (smooth: 1)


def test_every_strip_of_a_pair_matches_with_the_pairs_penalties(tmp_path, monkeypatch):
    from fotogeo.tools.dsm import dsm
    sc = render(tmp_path, 400, seed=4)
    monkeypatch.setattr(frames, "STRIP", 48)  # many strips of different contents
    seen = []
    real = frames.disparity
    monkeypatch.setattr(frames, "disparity", lambda *a, **kw: seen.append(kw["penalty"]) or real(*a, **kw))
    rep = dsm(sc["images"], tmp_path / "d.tif", camera=sc["camera"], eo=sc["eo"], crs=CRS)
    pair = next(p for p in rep["pairs"] if p["kept"])
    assert len(seen) >= 5 and len(set(seen)) == 1 and seen[0] is not None
    assert pair["penalty_scale"] == round(seen[0], 4) >= 1.0


def test_guides_drop_the_mismatches_the_pair_range_drops():
    """A planted ray meeting 400 m below the ground among matches at 100 ± 2 m: dropped from the strips' guides as
    from the pair's range, so the strip near it searches the ground's heights, not down to the mismatch."""
    rp = rectify(*_views())
    w, h = rp.size
    rng = np.random.default_rng(9)
    uv = np.column_stack([rng.uniform(0, w, 300), rng.uniform(0, h, 300)])
    z = rng.normal(100.0, 2.0, 300)
    z[7] = -300.0
    sp = {"uv": uv, "points": np.column_stack([uv, z])}
    near = local.guides(sp, ceiling=300.0)  # the cameras 300 m up
    assert len(near) == 299 and near[:, 2].min() > 90.0
    assert np.array_equal(plausible_heights(z, 300.0), z > 0)
    lo, hi = disparity_bounds(rp, -400.0, 250.0)
    u, v = uv[7]
    box = (max(0, int(u) - 20), max(0, int(v) - 20), min(w, int(u) + 20), min(h, int(v) + 20))
    clean = np.column_stack([uv, z])[z > 0]
    assert local.local_range(rp, near, box, lo, hi) == local.local_range(rp, clean, box, lo, hi)
    ground = disparity_bounds(rp, 95.0, 105.0, box, n=5)
    a, b, _ = local.local_range(rp, near, box, lo, hi)
    assert a <= ground[0] and ground[1] <= b
    # the raw heights: the range widened by the mismatch reaches above the cameras, where no height has a
    # disparity, and the strip would search only the depths below the ground
    a_raw, b_raw, _ = local.local_range(rp, np.column_stack([uv, z]), box, lo, hi)
    assert b_raw < ground[0]


def test_the_widened_range_is_capped_once_below_the_cameras():
    rng = np.random.default_rng(10)
    P = np.column_stack([rng.uniform(0.0, 500.0, (500, 2)), rng.normal(150.0, 1.0, 500)])
    z0, z1 = supported_span(P[:, :2], P[:, 2])
    p1, p99 = np.percentile(P[:, 2], [1, 99])
    grow = 0.5 * (p99 - p1) + 10.0
    want = (min(z0, p1) - grow, max(z1, p99) + grow)
    assert np.allclose(matched_heights(P, 400.0, widen=0.5, pad=10.0), want)  # far below: as is
    z = np.concatenate([np.full(60, 100.0), np.linspace(100.0, 180.0, 40)])  # relief reaching towards the cameras
    low, high = matched_heights(np.column_stack([np.arange(100.0), np.zeros(100), z]), 200.0, widen=0.5, pad=10.0)
    assert high == 100.0 + 0.75 * 100.0 < 200.0 and low < 100.0
