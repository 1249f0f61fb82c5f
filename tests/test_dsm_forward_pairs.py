"""Pair choice of ``fotogeo dsm`` on frames flown the way they look: pairs whose base line points into an image
(forward motion, the epipole in the frame: no rectification keeps it whole) are left out *before* the per-image cap
and the capped pairs' readmission. Left out after them (main before this test), they had taken the partners'
places and covered the readmission's ground, then were dropped: on two parallel strips looking forward 38° below
the horizon the cross-strip pairs were capped ("both images already have 3 better partners") while an image kept
no pair at all."""
from __future__ import annotations

import math
from collections import Counter

from fotogeo.stereo.pairs import NEAR_STRETCH, Limits
from fotogeo.stereo.rectify import epipole_angle
from fotogeo.tools.dsm import frames, plan, tool
from fotogeo.tools.ortho.inputs import image_models

from dsm_oblique_sets import CRS, GROUND, make_set

#: two parallel strips 20 m apart, 4 frames 30 m apart each, the gimbal 38° below the horizon along the flight
#: (the base 34–42° from the view; the epipole ~13° above the image, so left out here only under a wider margin, as
#: the rule based on the half diagonal field of view + 5°, 43°, left it out before s23); rendered small (the geometry
#: only matters here; the same set at 640 x 480 is the benchmark's, docs/benchmarks/dsm.md)
FORWARD_SET = dict(strips=[(0, -38.0, 4), (0, -38.0, 4)], base=30.0, side=10.0, seed=41, size=(320, 240))


def _diagonal_rule(p, views) -> str:
    """The forward-motion rule before s23: the base within the half diagonal field of view + 5° of an axis."""
    a = min(epipole_angle(views[p.i], views[p.j]), epipole_angle(views[p.j], views[p.i]))
    half = math.degrees(math.atan(0.5 * math.hypot(*views[p.i].size) / views[p.i].focal))
    return "forward motion" if a < half + 5.0 else ""


def test_forward_pairs_take_no_partner_place_and_cover_no_ground(tmp_path, monkeypatch):
    # the strip pairs' epipoles lie ~13° above these frames (their border 25° from the axis, the base 38°): left out
    # under the rule before s23 (the rule's order is tested here, not its bound: tests/test_dsm_strip_pairs.py)
    monkeypatch.setattr(plan, "forward_reason", _diagonal_rule)
    sc = make_set(FORWARD_SET, tmp_path)
    ims = image_models([str(p) for p in sc["images"]], CRS, camera=str(sc["camera"]), eo=str(sc["eo"]))
    views = [frames.frame_view(im) for im in ims]
    out = tool._choose(ims, views, [im.name for im in ims], GROUND, None)
    kept = [p for p in out if p.kept]
    partners = Counter([p.i for p in kept] + [p.j for p in kept])
    assert sum("forward motion" in p.reason for p in out) >= 8 and not any("forward" in p.reason for p in kept)
    # every frame has a partner: main kept 4 pairs and none for S1_04, its cross-strip pairs capped
    assert all(partners[k] >= 1 for k in range(len(ims))), partners
    cap = Limits().per_image
    for p in out:  # a pair said to be capped is: both its images kept that many others
        if p.reason.startswith("both images already have"):
            assert partners[p.i] >= cap and partners[p.j] >= cap, (p.i, p.j, partners)
    assert len(kept) >= 8


def test_pairs_whose_rectified_images_are_stretched_take_no_cap_from_cross_strip_pairs(tmp_path):
    # under the epipole rule the strip pairs (their epipole 9–15° above the frames, rectified to 14–75 x the
    # frames' pixels) are admitted; ranked by the product alone (whole B/H) they took the cap from six cross-strip
    # pairs (S1_02–S2_01, S1_02–S2_02, …): ground two pairs saw came to one (docs/benchmarks/dsm.md)
    sc = make_set(FORWARD_SET, tmp_path)
    ims = image_models([str(p) for p in sc["images"]], CRS, camera=str(sc["camera"]), eo=str(sc["eo"]))
    views = [frames.frame_view(im) for im in ims]
    names = [im.name for im in ims]
    out = tool._choose(ims, views, names, GROUND, None)
    admitted = [p for p in out if p.kept or p.reason.startswith("both images already have")]
    neighbours = [p for p in admitted if names[p.i][1] != names[p.j][1]
                  and abs(int(names[p.i][3:]) - int(names[p.j][3:])) <= 1]
    assert len(neighbours) >= 8 and all(p.kept for p in neighbours), [
        (names[p.i], names[p.j], p.reason) for p in neighbours if not p.kept]
    for p in admitted:  # every pair ranked last for its stretch says so
        stretch = plan.rectified_stretch(p, views)
        assert ("rectify to" in p.reason) == (stretch > NEAR_STRETCH), (p.reason, stretch)
