"""fotogeo dsm on frames: each strip searches the disparities of the heights of the sparse matches around it (a
local range), not the pair's whole range — fewer disparities searched, the same surface."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.stereo.rectify import rectify
from fotogeo.tools.dsm import frames, local as local_ranges
from fotogeo.tools.dsm.plan import disparity_bounds

from dsm_scenes import compare, make_scene
from test_dsm_tiles import _views


def test_local_range_follows_the_matches_near_the_strip(monkeypatch):
    """Matches at 10 m near the strip and at 80 m far from it: the strip's range is that of 10 m padded by
    ``LOCAL_PAD_M`` (and ``PAD_PX``), inside the pair's; too few matches near it: the pair's range."""
    monkeypatch.setattr(local_ranges, "LOCAL_NEAR", 20)
    rp = rectify(*_views())
    w, h = rp.size
    lo, hi = disparity_bounds(rp, -50.0, 150.0)
    box = (0, 0, w, 40)
    near = np.array([(u, v, 10.0) for u in np.linspace(0, w, 5) for v in (5.0, 30.0)]
                    + [(u, h - 5.0, 80.0) for u in np.linspace(0, w, 5)])
    a, b, local = local_ranges.local_range(rp, near, box, lo, hi)
    pad = local_ranges.LOCAL_PAD_M
    assert local
    assert np.allclose((a, b), disparity_bounds(rp, 10.0 - pad, 10.0 + pad, box, n=5))
    assert lo < a < b < hi and b - a < 0.3 * (hi - lo)
    assert local_ranges.local_range(rp, near[:local_ranges.LOCAL_MIN - 1], box, lo, hi) == (lo, hi, False)
    assert local_ranges.local_range(rp, None, box, lo, hi) == (lo, hi, False)
    # matches spanning 10 to 30 m near the strip: padded by half their span too, and never beyond the pair's range
    near[1::2, 2] = 30.0
    a2, b2, _ = local_ranges.local_range(rp, near, box, lo, hi)
    assert np.allclose((a2, b2), disparity_bounds(rp, 10.0 - 10.0 - pad, 30.0 + 10.0 + pad, box, n=5))
    assert local_ranges.local_range(rp, near, box, a + 1.0, a + 3.0)[:2] == (a + 1.0, a + 3.0)


def _run(sc, out, report):
    from fotogeo.tools.dsm import dsm
    rep = dsm(sc["images"][:2], out, camera=sc["camera"], eo=sc["eo"], crs=sc["crs"], report=report)
    return rep, compare(out, sc["surface"])


def test_rendered_pair_searches_local_ranges_with_the_same_accuracy(tmp_path, monkeypatch):
    """Two frames of the held-out block (±60 m of relief) in strips of 48 rows: most strips search a local range,
    fewer disparities on average than the pair's range, and the surface is as accurate as with the pair's range
    everywhere (the same run with too few matches for any local range)."""
    sc = make_scene("held_out", tmp_path / "scene")
    monkeypatch.setattr(frames, "STRIP", 48)
    monkeypatch.setattr(local_ranges, "LOCAL_NEAR", 24)
    rep, local = _run(sc, tmp_path / "local.tif", tmp_path / "local.json")
    pair = next(p for p in rep["pairs"] if p["kept"])
    used, strips = (int(x) for x in pair["local_range_strips"].split(" of "))
    lo, hi = pair["disparity_range_px"]
    assert strips >= 5 and used >= 0.8 * strips, pair["local_range_strips"]
    monkeypatch.setattr(local_ranges, "LOCAL_MIN", 10 ** 9)
    rep_g, whole = _run(sc, tmp_path / "pair.tif", tmp_path / "pair.json")
    pair_g = next(p for p in rep_g["pairs"] if p["kept"])
    assert pair_g["local_range_strips"] == f"0 of {strips}"
    assert pair_g["disparities_searched"] >= hi - lo
    assert pair["disparities_searched"] <= 0.85 * pair_g["disparities_searched"], (pair, pair_g)
    assert local["rmse"] <= max(1.05 * whole["rmse"], whole["rmse"] + 0.1 * sc["gsd"]), (local, whole)
    assert local["rmse"] <= sc["gsd"]
    assert rep["completeness"] >= rep_g["completeness"] - 0.01
    assert local["n"] == pytest.approx(whole["n"], rel=0.02)
