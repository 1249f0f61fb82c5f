"""Which images to match: stereo pairs from footprints, overlap and the base-to-height ratio.

For two images with projection centres (or, for RPC images, points far along their lines of sight) ``C1``,
``C2`` and ground footprints ``F1``, ``F2`` (the outlines on the terrain's mean height):

* **overlap** = area(F1 ∩ F2) / min(area F1, area F2);
* **base-to-height ratio** ``B/H = |C1 − C2| / ½(|C1 − G| + |C2 − G|)`` with ``G`` the centroid of the overlap
  (reported, not used to choose);
* **convergence angle** ``γ`` — the angle between the two lines of sight to a ground point, the mean over ``G``
  and the points halfway from ``G`` to the overlap's corners; from it the **base across the lines of sight**
  ``b⊥/H = 2 tan(γ/2)``: the part of the base perpendicular to the mean line of sight over the distance. It is
  what decides the height precision, ``σ_depth ≈ σ_px · GSD · H/b⊥`` (Kraus 2007): for obliques flown along
  the way they look, most of the base lies along the lines of sight and ``B/H`` overstates the pair (−55° strip,
  frames 20 m apart: ``B/H`` 0.13, ``γ`` 5.8°, ``b⊥/H`` 0.10); for nadir frames the two agree;
* **view angle** — the angle between the two optical axes (obliques looking different ways cannot be matched).

A candidate pair is kept when its overlap, ``b⊥/H`` and view angle pass the limits; then each image keeps at most
``per_image`` partners, the best by ``overlap · min(1, (B/H) / 0.4) · (1 − view angle / rank_view_angle)`` first
(the whole base: ranking by ``b⊥/H`` changed only the parallel set's pairs of the eight of
``tests/dsm_oblique_sets.py`` in their runs, RMSE 0.593 → 0.606 GSD, 98.0 → 97.7 % complete: not taken). A pair
over that cap is kept all the same when part of its overlap is covered by no kept pair (ground only those two
images see would otherwise get no height). The ranking's reference angle ``rank_view_angle`` (45°) is not the
admission limit ``max_view_angle``: pairs whose views differ by more than it (admitted when the limit is higher)
rank after all the others, by the same product with the limit's term, and each image keeps at most
``per_image_wide`` of them, so that a higher limit leaves the choice among the narrower pairs as it was and only
adds partners (with the term moving with the limit, at 70°, other pairs won the cap on the rendered oblique block:
24 → 20 pairs, RMSE 0.0521 → 0.0578 m; the −45° set kept 16 pairs instead of 3, CPU 6x). Matched alone, a pair's
heights stayed within 1 GSD from views 22° to 75° apart and its completeness fell by up to a fifth
(``benchmarks/dsm_bench.py --cases oblique_sets --view-angle-sweep``); the limit stays 45° though the sweep would
allow 70°: at 70° with the ranking at 45° every measured set's RMSE fell, the rendered oblique block kept its
pairs, but the completeness fell by 1.2 and 3.9 points on two sets and CPU rose 1.7–2.7x on four
(docs/benchmarks/dsm.md, "The ranking apart from the limit").
Pairs the caller rules out beyond these limits (``leave_out``: the frame tool's forward motion, the epipole in
the image) are left out before the cap, so they take no image's place and cover no ground of the readmission (left
out after it, they had: a forward-looking set's frame kept no pair while its cross-strip pairs were "capped").
Pairs whose epipole lies near the images (the caller's ``stretch``: the rectified images' pixels over the frames',
:func:`fotogeo.tools.dsm.plan.rectified_stretch`) rank after the others, in the order of the product over their
stretch, once it exceeds :data:`NEAR_STRETCH`: the base lies mostly along the lines of sight, so the whole ``B/H``
in the product overstates them, their overlap is smaller, and rectification stretches the frames along the base
(matching cost grows with it). Ranked by the product alone, such pairs of frames flown the way they look took the
per-image cap from cross-strip pairs of larger overlap, leaving ground that one pair saw; ranked last, they fill an
image's places only where the others leave some (a capped one is readmitted for ground on the readmission's terms,
which a base along the lines of sight does not meet). A pair's reason says when it was ranked last, and how much
its rectified images are stretched.
Every pair left out carries its reason. Pairs the user gives (``dsm --pairs``) are all matched when they pass the
overlap and ``b⊥/H`` limits: the view-angle limit is a default for the automatic choice (whether views further apart
still match depends on the scene), so a given pair above it is kept and its reason says so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np


@dataclass(frozen=True)
class Limits:
    """The pair limits of the module docstring."""
    min_overlap: float = 0.2
    min_base_height: float = 0.08
    max_base_height: float = 2.0
    max_view_angle: float = 45.0
    per_image: int = 3
    #: the ranking's reference angle: the score's ``1 − view angle / rank_view_angle`` (module docstring)
    rank_view_angle: float = 45.0
    #: partners per image whose views differ by more than ``rank_view_angle`` (admitted up to ``max_view_angle``)
    per_image_wide: int = 1


@dataclass
class PairChoice:
    """One candidate pair: the image indices, the measures, kept or not and why."""
    i: int
    j: int
    overlap: float
    base_height: float
    convergence: float
    view_angle: float
    centroid: tuple = ()
    kept: bool = False
    reason: str = ""
    extra: dict = field(default_factory=dict)

    def as_dict(self, names) -> dict:
        return {"images": [names[self.i], names[self.j]], "kept": self.kept, "reason": self.reason,
                "overlap": round(self.overlap, 4), "base_to_height": round(self.base_height, 4),
                "convergence_deg": round(self.convergence, 3),
                "base_to_height_across": round(base_across(self), 4), "view_angle_deg": round(self.view_angle, 3),
                **{k: v for k, v in self.extra.items() if k != "distance"}}


def _area(poly) -> float:
    p = np.asarray(poly, float).reshape(-1, 2)
    return float(abs(cv2.contourArea(np.ascontiguousarray(p - p.mean(axis=0), np.float32)))) if len(p) >= 3 else 0.0


def _hull_area(outline) -> float:
    p = np.asarray(outline, float)[:, :2]
    return _area(cv2.convexHull(np.ascontiguousarray(p - p.mean(axis=0), np.float32)))


def overlap_polygon(fi, fj) -> np.ndarray:
    """The intersection ``(K, 2)`` of the convex hulls of two outlines ``(N, 2+)`` (empty when they are apart)."""
    fi, fj = np.asarray(fi, float)[:, :2], np.asarray(fj, float)[:, :2]
    ref = np.vstack([fi, fj]).mean(axis=0)
    a = cv2.convexHull(np.ascontiguousarray(fi - ref, np.float32))
    b = cv2.convexHull(np.ascontiguousarray(fj - ref, np.float32))
    area, poly = cv2.intersectConvexConvex(a, b)
    if poly is None or area <= 0:
        return np.zeros((0, 2))
    return poly.reshape(-1, 2).astype(float) + ref


def overlap_share(fi, fj) -> float:
    """The overlap of two outlines ``(N, 2+)``: area(F1 ∩ F2) / min(area F1, area F2) (0 when either is empty)."""
    if len(fi) < 3 or len(fj) < 3:
        return 0.0
    poly = overlap_polygon(fi, fj)
    small = min(_hull_area(f) for f in (fi, fj))
    return _area(poly) / small if small > 0 and len(poly) >= 3 else 0.0


def measure(i, j, centres, axes, footprints, local=None) -> PairChoice:
    """The measures of pair ``(i, j)`` (module docstring); footprints ``(N, 3)`` outlines ``(X, Y, Z)`` on the
    ground. ``local(points)``: the ground points ``(N, 3)`` in the Cartesian frame (metres) the centres and axes
    are given in, when that is not the footprints' map CRS (:func:`fotogeo.crs.geocentric`), so that the base,
    the distance and the angles are not measured in a map projection's units; the overlap stays the map's."""
    overlap = overlap_share(footprints[i], footprints[j])
    if overlap <= 0:
        return PairChoice(i, j, 0.0, 0.0, 0.0, 0.0, extra={"overlap_polygon": np.zeros((0, 2))})
    poly = overlap_polygon(footprints[i], footprints[j])
    g = poly.mean(axis=0)
    ci, cj = np.asarray(centres[i], float), np.asarray(centres[j], float)
    z = footprints_height(footprints, i, j)
    ground = np.column_stack([np.vstack([g, 0.5 * (poly + g)]), np.full(len(poly) + 1, z)])
    if local is not None:
        ground = np.asarray(local(ground), float)
    G = ground[0]
    h = 0.5 * (np.linalg.norm(ci - G) + np.linalg.norm(cj - G))
    conv = float(np.mean(_convergence(ci, cj, ground)))
    view = math.degrees(math.acos(np.clip(np.dot(axes[i], axes[j]) / (np.linalg.norm(axes[i]) *
                                                                      np.linalg.norm(axes[j])), -1, 1)))
    return PairChoice(i, j, overlap, float(np.linalg.norm(ci - cj) / h), conv, view, (float(g[0]), float(g[1])),
                      extra={"distance": float(h), "overlap_polygon": poly})


def _convergence(ci, cj, ground) -> np.ndarray:
    """The angles (degrees) between the rays from ``ci`` and from ``cj`` to each point of ``ground`` ``(N, 3)``."""
    ri, rj = ci - ground, cj - ground
    cos = np.sum(ri * rj, axis=1) / (np.linalg.norm(ri, axis=1) * np.linalg.norm(rj, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def base_across(p: PairChoice) -> float:
    """The base across the lines of sight over the distance, ``2 tan(γ/2)`` for the convergence angle ``γ``: the
    ratio that sets the height precision (module docstring)."""
    return 2.0 * math.tan(math.radians(p.convergence) / 2.0)


def footprints_height(footprints, i, j) -> float:
    """The height the footprints were drawn on (their third column when given, else 0)."""
    f = np.vstack([footprints[i], footprints[j]])
    return float(np.nanmean(f[:, 2])) if f.shape[1] > 2 else 0.0


def _reason(p: PairChoice, lim: Limits, given: bool = False) -> str:
    if p.overlap < lim.min_overlap:
        return f"overlap {shown(100 * p.overlap, 100 * lim.min_overlap)} % below {100 * lim.min_overlap:g} %"
    bh = base_across(p)
    if bh < lim.min_base_height:
        return (f"base-to-height ratio {shown(bh, lim.min_base_height, 3)} across the lines of sight (the rays "
                f"meet at {p.convergence:.1f} degrees), below {lim.min_base_height:g}: heights would be too noisy "
                f"(about {1 / max(bh, 1e-3):.0f} x the matching error)")
    if bh > lim.max_base_height:
        return (f"base-to-height ratio {shown(bh, lim.max_base_height, 2)} across the lines of sight (the rays "
                f"meet at {p.convergence:.0f} degrees), above {lim.max_base_height:g}: the views differ too much")
    if p.view_angle > lim.max_view_angle and not given:
        return f"the views differ by {shown(p.view_angle, lim.max_view_angle)} degrees (above {lim.max_view_angle:g})"
    return ""


def shown(value: float, limit: float, decimals: int = 0) -> str:
    """``value`` with ``decimals`` decimals, or as many more (up to 6) as it takes not to read as the ``limit`` it
    is compared with: an overlap of 19.6 % is refused as "19.6 % below 20 %", not "20 % below 20 %".

    >>> shown(19.6, 20.0), shown(12.4, 20.0), shown(0.0799, 0.08, 3), shown(45.04, 45.0)
    ('19.6', '12', '0.0799', '45.04')
    """
    text = f"{value:.{decimals}f}"
    while float(text) == limit and decimals < 6 and value != limit:
        decimals += 1
        text = f"{value:.{decimals}f}"
    return text


def _wide(p: PairChoice, lim: Limits) -> bool:
    """Whether the pair's views differ by more than the ranking's reference angle (module docstring; never with
    the admission limit at or below it)."""
    return p.view_angle > min(lim.rank_view_angle, lim.max_view_angle)


def _stretched(p: PairChoice) -> bool:
    """Whether the pair's rectified images exceed :data:`NEAR_STRETCH` times the frames' pixels (its epipole near
    the image; module docstring)."""
    return p.extra.get("rectified_stretch", 1.0) > NEAR_STRETCH


def _score(p: PairChoice, lim: Limits) -> tuple:
    """The order in which pairs get an image's partners (module docstring), best first when sorted: the pairs
    within ``rank_view_angle`` by ``overlap · min(1, (B/H) / 0.4) · (1 − view angle / rank_view_angle)``, then the
    wider ones (admitted up to ``max_view_angle``) by the same product with ``max_view_angle``'s term. The
    reference angle does not move with the admission limit: with it the narrow pairs' order changed and other
    pairs won the per-image cap. Within each, the pairs whose rectified images are stretched beyond
    :data:`NEAR_STRETCH` times the frames' pixels come last, by the product over the stretch."""
    wide, near = _wide(p, lim), _stretched(p)
    ref = lim.max_view_angle if wide else min(lim.rank_view_angle, lim.max_view_angle)
    product = p.overlap * min(1.0, p.base_height / 0.4) * (1.0 - p.view_angle / ref)
    return (not wide, not near, product / p.extra["rectified_stretch"] if near else product)


def choose_pairs(centres, axes, footprints, limits: Limits = Limits(), given=None, leave_out=None,
                 stretch=None, local=None) -> list:
    """Every candidate :class:`PairChoice` of the images (all pairs, or only ``given`` index pairs), kept or
    left out with a reason (module docstring). ``leave_out(p)``: the caller's reason ("" for none) to leave out a
    pair that passes the limits, asked before the per-image cap and the readmission, so that such a pair takes no
    image's place and covers no ground (a frame tool's forward motion: the epipole in the image). ``stretch(p)``:
    the rectified images' pixels over the frames' of a pair left in (``extra["rectified_stretch"]``; none: 1),
    which ranks the pairs beyond :data:`NEAR_STRETCH` last (module docstring). ``local``: the Cartesian frame of
    the centres and axes (:func:`measure`)."""
    n = len(centres)
    cand = given if given is not None else [(i, j) for i in range(n) for j in range(i + 1, n)]
    out = [measure(i, j, centres, axes, footprints, local) for i, j in cand]
    for p in out:
        p.reason = _reason(p, limits, given is not None)
        if not p.reason and leave_out is not None:
            p.reason = leave_out(p)
        if not p.reason and stretch is not None:
            p.extra["rectified_stretch"] = float(stretch(p))
    ok = sorted((p for p in out if not p.reason), key=lambda p: _score(p, limits), reverse=True)
    used, wide = np.zeros(n, int), np.zeros(n, int)
    for p in ok:
        if given is None and used[p.i] >= limits.per_image and used[p.j] >= limits.per_image:
            p.reason = f"both images already have {limits.per_image} better partners" + _ranked_last(p)
            continue
        if given is None and _wide(p, limits) and max(wide[p.i], wide[p.j]) >= limits.per_image_wide:
            p.reason = (f"an image already has {limits.per_image_wide} partner(s) whose views differ by more than "
                        f"{limits.rank_view_angle:g} degrees (these {shown(p.view_angle, limits.rank_view_angle)})")
            continue
        p.kept, p.reason = True, "kept" + ("" if given is not None else _ranked_last(p))
        if p.view_angle > limits.max_view_angle:  # only a given pair: the user's choice over the view limit
            p.reason = (f"kept as given (the views differ by {shown(p.view_angle, limits.max_view_angle)} degrees, "
                        f"above {limits.max_view_angle:g})")
        used[p.i] += 1
        used[p.j] += 1
        wide[p.i] += int(_wide(p, limits))
        wide[p.j] += int(_wide(p, limits))
    _readmit_uncovered(out, footprints, limits)
    return out


def _ranked_last(p: PairChoice) -> str:
    """The reason's note on a pair ranked after the others for its rectified stretch ("" for none)."""
    if not _stretched(p):
        return ""
    return (f" (ranked after the pairs below {NEAR_STRETCH:g} x: its epipole lies near the images, which rectify to "
            f"{shown(p.extra['rectified_stretch'], NEAR_STRETCH)} x the frames' pixels)")


def _inside(points, poly) -> np.ndarray:
    """Which ``points`` ``(N, 2)`` lie in the convex polygon ``poly`` ``(K, 2)`` (on its edge too)."""
    if len(poly) < 3:
        return np.zeros(len(points), bool)
    c = cv2.convexHull(np.ascontiguousarray(poly, np.float32)).reshape(-1, 2).astype(float)
    e = np.roll(c, -1, axis=0) - c  # hull edges, counter-clockwise or clockwise: one sign for every inside point
    cross = e[None, :, 0] * (points[:, None, 1] - c[None, :, 1]) - e[None, :, 1] * (points[:, None, 0] - c[None, :, 0])
    return (cross >= -1e-9).all(axis=1) | (cross <= 1e-9).all(axis=1)


def _readmit_uncovered(out: list, footprints, limits: Limits) -> None:
    """Keep again, best first, the pairs the per-image cap left out whose overlap holds ground that no kept pair
    covers (at least :data:`NEW_GROUND` of it, on a grid of ``COVER_SAMPLES``² points over the overlap): a block
    with long forward and short side overlap otherwise keeps each image's wide cross-strip partners and drops
    the consecutive frames of a strip, whose ground only they two see (a 3 x 3 block at 80 % / 30 %: 16 % of the
    ground two frames see got no height, and the report's completeness, over the kept pairs, did not show it).
    Only a pair whose base lies across its lines of sight (``b⊥/H`` at least :data:`READMIT_ACROSS` of ``B/H``)
    is kept for ground: obliques flown the way they look, their base mostly along the lines of sight, gave 2 GSD
    RMSE on the ground only they saw (the oblique set "parallel, 2 strips N, pitch -60": 0.59 → 1.10 GSD with
    them) where nadir strips' consecutive frames gave 0.87 GSD. Kept pairs whose bounding box misses the
    overlap are not tested (a 144-image block: 41 → 10 CPU s)."""
    capped = [p for p in out if p.reason.startswith("both images already have")
              and base_across(p) >= READMIT_ACROSS * p.base_height]
    kept = [p.extra["overlap_polygon"] for p in out if p.kept]
    kept = [(k, k.min(axis=0), k.max(axis=0)) for k in kept if len(k) >= 3]
    for p in capped:  # in the order of their score (choose_pairs sorted them)
        poly = p.extra["overlap_polygon"]
        if len(poly) < 3:
            continue
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        u, v = (np.linspace(a, b, COVER_SAMPLES) for a, b in zip(lo, hi))
        g = np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)
        g = g[_inside(g, poly)]
        if not len(g):
            continue
        covered = np.zeros(len(g), bool)
        for k, klo, khi in kept:
            if (klo <= hi).all() and (khi >= lo).all():
                covered |= _inside(g, k)
        new = 1.0 - covered.mean()
        if new >= NEW_GROUND:
            p.kept, kept = True, kept + [(poly, lo, hi)]
            p.reason = (f"kept over the {limits.per_image} partners per image: {100 * new:.0f} % of its overlap "
                        "is covered by no other kept pair")


#: a pair over the per-image cap is kept when at least this share of its overlap no kept pair covers
NEW_GROUND = 0.05
#: pairs whose rectified images exceed this many times the frames' pixels rank after the others
NEAR_STRETCH = 4.0
#: points per side of the grid its overlap is sampled on
COVER_SAMPLES = 24
#: a capped pair is kept for ground only when its base across the lines of sight is at least this share of its base
READMIT_ACROSS = 0.9
