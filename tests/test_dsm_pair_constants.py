"""What a frame pair of fotogeo dsm fixes once for all its strips: SGBM's contrast-scaled penalties (not one per
strip)."""
from __future__ import annotations

import cv2
import numpy as np

from fotogeo.orientation.block_render import texture
from fotogeo.stereo import dense
from fotogeo.tools.dsm import frames

from rendered_pair import CRS, render


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
