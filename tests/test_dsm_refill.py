"""fotogeo dsm: a pair refused when set up gives its images their next candidate (:mod:`fotogeo.tools.dsm.refill`).
Before, the pair choice was not revisited: the refused pair kept the per-image cap's slot it took, and its images
lost that partner with nothing in its place."""
from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from fotogeo.stereo.pairs import PairChoice
from fotogeo.tools.dsm import dsm, matching

from dsm_scenes import make_scene, turned_eo


class _Stop(Exception):
    pass


def test_a_pair_refused_when_set_up_gives_its_partner_the_next_candidate(tmp_path, monkeypatch):
    """The 2 x 4 nadir block with s1_02's κ turned by 1°: its pairs pass the choice and are refused by the sparse
    check (rows 2–4 px apart after rectification). s1_02–s2_03 had taken one of s2_03's three slots; s2_01–s2_03,
    capped in the first choice ("both images already have 3 better partners"), is now chosen, set up and matched,
    and says which refusal it replaces. Pairs set up once are not set up again."""
    sc = make_scene("nadir", tmp_path / "scene")
    eo = turned_eo(Path(sc["eo"]), "s1_02", 1.0, tmp_path / "eo.txt")
    got, calls = {}, []

    def capture(grid, matches, *a, **k):
        got.update(matches=matches)
        raise _Stop

    from fotogeo.tools.dsm import frames
    check = frames.sparse_check

    def counted(rp, views, *a, **k):
        calls.append(tuple(v.name for v in views))
        return check(rp, views, *a, **k)

    monkeypatch.setattr(matching, "match_tiles", capture)
    monkeypatch.setattr(frames, "sparse_check", counted)
    with warnings.catch_warnings(record=True) as w, pytest.raises(_Stop):
        warnings.simplefilter("always")
        dsm(sc["images"], tmp_path / "dsm.tif", camera=sc["camera"], eo=eo, crs=sc["crs"])
    left = [str(x.message) for x in w if "left out" in str(x.message)]
    assert any("s1_02-s2_03 left out" in s and "epipolar lines" in s for s in left), left
    matched = {m.name: m for m in got["matches"]}
    assert not any("s1_02" in n for n in matched if n != "s1_01-s1_02"), sorted(matched)
    assert "s2_01-s2_03" in matched, sorted(matched)
    p = matched["s2_01-s2_03"].pair
    assert p.kept and p.extra["replaces"] == ["s1_02-s2_03"]
    assert "chosen after s1_02-s2_03 was refused" in p.reason
    assert sum("s2_03" in n for n in matched) == 3
    assert len(calls[1:]) == len(set(calls[1:])), calls  # after the heights' pair, each pair's check ran once


def _pair(i, j, kept=True, reason="kept"):
    return PairChoice(i, j, 0.5, 0.5, 20.0, 0.0, kept=kept, reason=reason)


def test_the_refill_keeps_pairs_set_up_and_stops_after_its_rounds():
    """A redone choice that drops a pair already set up keeps it (its set-up is used); an image whose every next
    candidate is refused costs at most ``rounds`` more choices."""
    from fotogeo.tools.dsm import refill
    chosen = []

    def choose(refused):
        chosen.append(dict(refused))
        n = len(chosen)
        # (0, 1) works; (0, k) for k >= 2 is refused; each new choice drops (0, 1) and offers the next (0, k)
        return [_pair(0, 1, kept=n == 1, reason="kept" if n == 1 else "capped"), _pair(0, n + 1)]

    def set_up(p):
        return "row differences" if p.j >= 2 else ("set up", p.i, p.j)

    choices, setups, tried = refill.settle(choose, set_up, [f"im{k}" for k in range(9)], rounds=3)
    assert len(chosen) == 4 and list(setups) == [(0, 1)]
    assert [(p.i, p.j) for p in tried] == [(0, 1), (0, 2), (0, 3), (0, 4), (0, 5)]
    assert choices[0].kept and choices[0].reason == "kept"
    assert [p.extra["replaces"] for p in tried[2:]] == [["im0-im2"], ["im0-im3"], ["im0-im4"]]
    assert not any(p.kept for p in tried[1:])


def _refill_run(tmp_path, monkeypatch, refuse=(), limit=None):
    """The nadir block with s1_02's κ turned by 1° up to the matching: ``(grids, matched, warnings)``, ``grids`` the
    pairs each output grid was computed over; ``refuse``: pairs also refused when set up; ``limit``: a grid over a
    pair the first one was not is refused as too large (as ``check_output_grid`` does) when set."""
    from fotogeo.errors import OutputError
    from fotogeo.tools.dsm import tool
    sc = make_scene("nadir", tmp_path / "scene")
    eo = turned_eo(Path(sc["eo"]), "s1_02", 1.0, tmp_path / "eo.txt")
    grids, got = [], {}
    grid, setup = tool._grid, tool._pair_setup

    def capture(g, matches, *a, **k):
        got.update(matches=matches)
        raise _Stop

    def spied_grid(kept, *a):
        grids.append([(p.i, p.j, p.kept) for p in kept])
        if limit and {(p.i, p.j) for p in kept} - {(i, j) for i, j, _ in grids[0]}:
            raise OutputError("the DSM would be too large")
        return grid(kept, *a)

    def spied_setup(p, views, *a):
        if f"{views[p.i].name}-{views[p.j].name}" in refuse:
            return None, None, None, "refused by the test", None, None
        return setup(p, views, *a)

    monkeypatch.setattr(matching, "match_tiles", capture)
    monkeypatch.setattr(tool, "_grid", spied_grid)
    monkeypatch.setattr(tool, "_pair_setup", spied_setup)
    with warnings.catch_warnings(record=True) as w, pytest.raises(_Stop):
        warnings.simplefilter("always")
        dsm(sc["images"], tmp_path / "dsm.tif", camera=sc["camera"], eo=eo, crs=sc["crs"])
    return grids, {m.name: m for m in got["matches"]}, [str(x.message) for x in w]


def test_a_pair_the_refill_adds_and_that_is_refused_itself_does_not_widen_the_grid(tmp_path, monkeypatch):
    """s2_01-s2_03, chosen after s1_02-s2_03 was refused, is refused when set up as well: the output grid is over
    the first choice's pairs and the added pairs kept, not over its overlap too."""
    grids, matched, _ = _refill_run(tmp_path, monkeypatch, refuse=("s2_01-s2_03",))
    assert "s2_01-s2_03" not in matched
    first = {(i, j) for i, j, _ in grids[0]}
    assert all(kept for g in grids[1:] for i, j, kept in g if (i, j) not in first), grids


def test_a_pair_the_refill_adds_is_left_out_when_its_overlap_would_make_the_grid_too_large(tmp_path, monkeypatch):
    """With a grid over more pairs than the first choice's refused as too large, s2_01-s2_03 (chosen after
    s1_02-s2_03 was refused) is left out, saying why, instead of the whole run being refused."""
    grids, matched, said = _refill_run(tmp_path, monkeypatch, limit=True)
    assert "s2_01-s2_03" not in matched and "s1_01-s1_02" in matched, sorted(matched)
    assert any("s2_01-s2_03 left out" in s and "widen the output grid" in s for s in said), said
