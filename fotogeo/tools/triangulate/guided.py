"""Tie points between frames seen from very different directions, matched on the ground plane (the tool layer of
``fotogeo triangulate``).

Converging obliques — a camera 30–45° off nadir looking east, south, west and north at one place — see the
same ground turned by up to 180°, scaled by up to 2–3× and sheared: a detector's rotation and scale invariance
covers the first two only in part, and the descriptors of one patch seen from two sides differ too much for the
ratio test. Guided matching removes the viewpoint with the approximate orientation before matching, as
orthorectification does: every frame that needs it is resampled **once** onto one ground grid of the block and
detected there (:mod:`fotogeo.tools.triangulate.ground`), so that the cost grows with the frames, not the pairs;
then, per pair:

* **which pairs** (:func:`choose_pairs`): those whose plain matching kept fewer than :data:`GUIDED_BELOW`
  epipolar inliers, or whose optical axes differ by more than :data:`CONVERGING_DEG` (converging views: the plain
  matches there are fewer and more of them wrong) — nadir pairs with good plain ties are never re-matched — and of
  these only those whose footprints on the plane (:func:`fotogeo.tools.triangulate.ground.footprint`) share at
  least :data:`MIN_GROUND_OVERLAP` of the smaller one; each row of the report says why the pair was tried or
  skipped;
* **matching** (:func:`ground_pair`): the keypoints of each frame that fall on the other's footprint (grown by a
  tenth of its size, the orientation error) matched with the options' ratio test and mutual check
  (:func:`fotogeo.features.match.match_descriptors`); each match's grid position goes back to each frame's pixels
  exactly (:func:`fotogeo.tools.triangulate.ground.grid_to_pixels`) and the pair's **one RANSAC**, the epipolar
  test of the plain pairs (:func:`fotogeo.tools.triangulate.pairs.epipolar_kept`), keeps those that fit the
  two-view geometry on the frames' own pixels — a wrong approximate orientation makes fewer matches, never wrong
  ones. A pair keeps whichever of its plain and ground-plane results kept more inliers.

**Frames whose attitude is unknown** (``known``: the level start of :mod:`fotogeo.tools.triangulate.start`, κ measured
on the images after matching) have no orientation to resample with: in the first pass a pair holding one is matched
plainly only (its row says so), and its rays and axis measure no plane; the pairs of frames with a known attitude
(tags, registration, ``--eo``) are guided as ever. Before, one level frame switched the ground plane off for the whole block: on the
rendered 12-frame oblique block of seed 0 without tags, its reference zeroed under one frame (4 frames left level),
the tie inliers were 4,503 that way and are 6,877 per pair (docs/howto/triangulate.md, *Frames left level*).

**A second pass for the level frames** (:func:`level_pass`, after the start has measured κ): a level frame's whole
attitude is measured on its plain ties with the frames of known attitude (:func:`measured_attitudes`: those frames'
rays through the DEM when the run has one, else the plane, give the ground points, and the rotation that best turns
the level frame's rays onto the directions to them — Wahba's problem (1965), solved by SVD as Kabsch (1976) — is its
attitude), in rounds: a frame whose ties are all with level frames is measured once they are (a reference blanked
under several frames leaves whole neighbourhoods level); its pairs then go through the same ground-plane matching as
the others. Left level, a frame of an oblique block starts 30° off: its pairs with converging views keep few plain
ties, least-squares matching, started from its level affinity, loses most of them, and the bundle dropped it ("3 points
(needs 6)": the 12-frame block of seed 0, the reference zeroed under DJI_303).

**The plane's height.** The median height of the plain pairs' inliers (pairs with at least
:data:`fotogeo.tools.triangulate.pairs.MIN_PAIR_INLIERS` inliers and axes within :data:`CONVERGING_DEG`: the
midpoints of their rays' shortest segments through the approximate orientations, :func:`ray_heights`), else the
caller's ``height`` (a DEM's, the control's, or the provisional height of the pair selection,
:func:`fotogeo.tools.triangulate.start.provisional_height`, often tens of metres off for a drone). The ground-plane
pairs' inliers measure it again; when that is more than a tenth of the cameras' height above the plane away, the
frames are resampled and matched once more on the measured plane (each pair keeping its better run).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import FotogeoError
from ...geometry.brown import coefficients
from ...geometry.camera import OrientedFrame, angles_patb, nearest_rotation
from ...geometry.dem import below
from ...progress import as_progress
from .ground import block_grid, footprint, grid_to_pixels, ground_features
from .pairs import MIN_PAIR_INLIERS, epipolar_kept, grey

#: pairs whose plain matching kept fewer epipolar inliers than this are matched on the ground plane too
GUIDED_BELOW = 12
#: pairs whose optical axes differ by more than this (degrees) are matched on the ground plane whatever the plain
#: matching found
CONVERGING_DEG = 20.0
#: pairs whose footprints on the plane share less than this fraction of the smaller one are not matched there
MIN_GROUND_OVERLAP = 0.15


#: the rotation of a level frame is measured on at least this many of its ties with frames of known attitude
MIN_ATTITUDE_TIES = MIN_PAIR_INLIERS
#: ... keeping those within this many times the median angle between the turned ray and the ground point's direction
TRIM_FACTOR = 3.0


#: a frame's tile on the ground holds about this many times the pixels the plain matching detects the frame on
TILE_FACTOR = 1.5


#: ... and at least this many cells (small frames: the cost is small, and a coarse tile loses the finest scale)
TILE_MIN = 2 ** 16


def tile_pixels(det, info) -> int:
    """The valid cells of a frame's tile on the ground grid: :data:`TILE_FACTOR` × the pixels of the frame at the
    plain matching's pyramid level (``det.max_match_pixels``), at least :data:`TILE_MIN`, at most the frame's own
    pixels."""
    frame = info.width * info.height
    return int(min(max(TILE_FACTOR * min(det.max_match_pixels, frame), TILE_MIN), frame))


def choose_pairs(pairs, found, eos, footprints, known=None) -> tuple:
    """``(todo, rows)``: the indices of the pairs to match on the ground plane (module docstring), the largest
    ground overlap first; ``rows`` ``{k: report row}`` for every pair considered, tried or skipped, with
    ``why`` (what made it a candidate), ``ground_overlap`` and, when skipped, ``skipped`` (why not). ``known``: one
    bool per frame, False where its attitude is unknown (a pair holding such a frame is skipped; None: all known)."""
    todo, rows = [], {}
    known = _known(known, eos)
    for k, (i, j) in enumerate(pairs):
        plain = 0 if found[k] is None else len(found[k][1])
        angle = axes_angle(eos[i], eos[j])
        if angle > CONVERGING_DEG:
            why = f"optical axes {angle:.0f}° apart (> {CONVERGING_DEG:.0f}°)"
        elif plain < GUIDED_BELOW:
            why = f"{plain} plain inliers (< {GUIDED_BELOW})"
        else:
            continue
        a, b = footprints[i], footprints[j]
        share = 0.0 if a is None or b is None else a.intersection(b).area / min(a.area, b.area)
        rows[k] = {"pair": [i, j], "why": why, "ground_overlap": round(float(share), 3), "matches": 0, "inliers": 0,
                   "used": False, "height_m": None}
        if not (known[i] and known[j]):
            rows[k]["skipped"] = "attitude unknown (level start, κ from the images): frame " + \
                ", ".join(str(f) for f in (i, j) if not known[f])
        elif share < MIN_GROUND_OVERLAP:
            rows[k]["skipped"] = f"footprints on the ground share {share:.0%} (< {MIN_GROUND_OVERLAP:.0%})"
        else:
            todo.append(k)
    return sorted(todo, key=lambda k: -rows[k]["ground_overlap"]), rows


def _known(known, eos) -> list:
    """One bool per frame of ``eos``: its attitude is known (``known`` None: every frame's)."""
    return [True] * len(eos) if known is None else [bool(k) for k in known]


def _on(features, fp, grid, grow: float):
    """Indices of ``features``' keypoints whose ground point lies on the footprint ``fp`` grown by ``grow`` m."""
    import shapely
    x0, y0, cell = grid
    X, Y = x0 + features.xy[:, 0] * cell, y0 - features.xy[:, 1] * cell
    return np.flatnonzero(shapely.contains_xy(fp.buffer(grow), X, Y))


def ground_pair(feats, fps, camera, distortion, eos, height: float, grid, opts, threshold: float, ideal,
                near: bool = True):
    """``(matches, xy_i, xy_j)`` of one pair matched on the ground grid (module docstring; ``feats``, ``fps``,
    ``eos``: the two frames' :class:`~fotogeo.tools.triangulate.ground.GroundFeatures`, footprints and
    orientations), the epipolar inliers in frame pixels. ``near``: only the keypoints on the other frame's
    footprint (a plane nobody measured can put the common ground far from where both footprints meet)."""
    from ...features.match import match_descriptors
    grow = 0.1 * math.sqrt(min(fp.area for fp in fps))
    sel = ([_on(feats[0], fps[1], grid, grow), _on(feats[1], fps[0], grid, grow)] if near else
           [np.arange(len(feats[0].xy)), np.arange(len(feats[1].xy))])
    if min(len(s) for s in sel) < 2:
        return 0, np.zeros((0, 2)), np.zeros((0, 2))
    lap = [None if f.laplacian is None else f.laplacian[s] for f, s in zip(feats, sel)]
    m = match_descriptors(feats[0].descriptors[sel[0]], feats[1].descriptors[sel[1]], ratio=opts.ratio,
                          mutual=opts.mutual, laplacian1=lap[0], laplacian2=lap[1])
    xy_i = grid_to_pixels(camera, distortion, eos[0], height, grid, feats[0].xy[sel[0][m.pairs[:, 0]]])
    xy_j = grid_to_pixels(camera, distortion, eos[1], height, grid, feats[1].xy[sel[1][m.pairs[:, 1]]])
    ok = np.isfinite(xy_i).all(axis=1) & np.isfinite(xy_j).all(axis=1)
    return epipolar_kept(xy_i[ok], xy_j[ok], ideal, threshold)


def _frame_features(infos, frames, camera, dist, eos, height, grid, fps, opts, prog) -> dict:
    """``{frame: GroundFeatures or None}``: each of ``frames`` read, resampled and detected once."""
    out = {}
    for n, f in enumerate(frames):
        prog(n / max(len(frames), 1), f"frame {n + 1}/{len(frames)} on the ground plane")
        try:
            out[f] = ground_features(grey(infos[f]), camera, dist, eos[f], height, grid, fps[f], opts)
        except FotogeoError:
            out[f] = None
    return out


def _on_plane(infos, pairs, found, camera, dist, eos, height, opts, threshold, ideal, max_pixels, prog, near, known):
    """``(rows, results)`` of one pass on the plane ``height``: :func:`choose_pairs`' rows and ``{k: result}`` of
    the pairs matched (:func:`ground_pair`, ``near``: the plane was measured; ``known``: :func:`choose_pairs`)."""
    fps = [footprint(camera, eo, height) for eo in eos]
    todo, rows = choose_pairs(pairs, found, eos, fps, known)
    frames = sorted({f for k in todo for f in pairs[k]})
    grid = block_grid(camera, [eos[f] for f in frames], [fps[f] for f in frames], height, max_pixels)
    feats = _frame_features(infos, frames, camera, dist, eos, height, grid, fps, opts,
                            prog.stage(0.0, 0.8, "frames on the ground plane"))
    results = {}
    for n, k in enumerate(todo):
        i, j = pairs[k]
        prog(0.8 + 0.2 * n / len(todo), f"matching pair {k + 1} on the ground plane")
        if feats[i] is None or feats[j] is None:
            rows[k]["skipped"] = "a frame's footprint holds too few of its pixels"
        else:
            results[k] = ground_pair((feats[i], feats[j]), (fps[i], fps[j]), camera, dist, (eos[i], eos[j]), height,
                                     grid, opts, threshold, ideal, near)
    return rows, results


def guided_results(infos, pairs, found, camera, distortion, eos, height: float, opts, threshold: float, ideal,
                   max_pixels: int, progress=None, known=None):
    """``(found, guided, height)``: ``found`` (the plain pairs' ``(matches, xy_i, xy_j)`` or None, in pair
    order) with the result of the ground-plane matching in place of a pair's where it kept more inliers;
    ``guided`` one dict per pair considered (``{"pair", "why", "ground_overlap", "matches", "inliers", "used",
    "height_m"}``, ``"skipped"`` when not matched); ``height`` the plane's height measured on the ground-plane ties
    (None when none did: the block's height is then left as it was). Module docstring: which pairs, which plane,
    the second pass. ``known``: one bool per frame, False where its attitude is unknown (module docstring; None:
    every frame's is known)."""
    prog = as_progress(progress)
    found, dist, known = list(found), _distortion_terms(distortion), _known(known, eos)
    sure = [k for k, (i, j) in enumerate(pairs) if known[i] and known[j]]  # the pairs whose rays measure a height
    plane = _plain_height(camera, eos, [pairs[k] for k in sure], [found[k] for k in sure])
    axes = axes_height([eo for eo, k in zip(eos, known) if k])
    tries = ([(plane, True)] if plane is not None else
             [(z, False) for z in (axes, height) if z is not None] or [(height, False)])
    for n, (plane, near) in enumerate(tries):  # an unmeasured plane: where the axes meet, else the caller's height
        rows, results = _on_plane(infos, pairs, found, camera, dist, eos, plane, opts, threshold, ideal, max_pixels,
                                  prog.stage(n / len(tries) / 2, (n + 1) / len(tries) / 2, "matching on the ground "
                                             "plane"), near, known)
        z = _pairs_height(camera, eos, pairs, results)
        if z is not None:
            break
    above = float(np.median([e.Z for e in eos])) - plane
    if z is not None and abs(z - plane) > 0.1 * max(above, 1e-6):
        rows2, again = _on_plane(infos, pairs, found, camera, dist, eos, z, opts, threshold, ideal, max_pixels,
                                 prog.stage(0.5, 1.0, "matching on the measured ground plane"), True, known)
        better = {k: r for k, r in again.items() if k not in results or len(r[1]) > len(results[k][1])}
        results.update(better)
        rows.update({k: rows2[k] for k in better})
        plane, z = z, _pairs_height(camera, eos, pairs, results)
    for k, got in results.items():
        _take(found, k, got, rows[k], _median_height(camera, (eos[pairs[k][0]], eos[pairs[k][1]]), got))
    return found, [rows[k] for k in sorted(rows)], z  # a height the ground-plane ties measured, else None


def _plain_height(camera, eos, pairs, found):
    """The median over the plain pairs with at least ``MIN_PAIR_INLIERS`` inliers of their inliers' median ray
    height; None when there is none."""
    z = [_median_height(camera, (eos[i], eos[j]), r) for (i, j), r in zip(pairs, found)]
    z = [v for v in z if v is not None]
    return float(np.median(z)) if z else None


def axes_height(eos):
    """The height of the point nearest to every frame's optical axis (least squares: ``Σ (I − d dᵀ)(p − C) = 0``
    over the centres ``C`` and axes ``d``), where converging views aim; None when the axes are near parallel (the
    smallest eigenvalue of ``Σ (I − d dᵀ) / n`` below 0.05, about 13° of spread) or the point is not below every
    camera (or fewer than two frames are given)."""
    if len(eos) < 2:
        return None
    A, b = np.zeros((3, 3)), np.zeros(3)
    for eo in eos:
        d = eo.rotation[:, 2] / np.linalg.norm(eo.rotation[:, 2])
        M = np.eye(3) - np.outer(d, d)
        A, b = A + M, b + M @ np.asarray(eo.centre, float)
    if np.linalg.eigvalsh(A / len(eos))[0] < 0.05:
        return None
    p = np.linalg.solve(A, b)
    return float(p[2]) if p[2] < min(e.Z for e in eos) else None


def _pairs_height(camera, eos, pairs, results):
    """The median over the ground-plane pairs of their inliers' median ray height; None when none has one."""
    z = [_median_height(camera, (eos[pairs[k][0]], eos[pairs[k][1]]), r) for k, r in results.items()]
    z = [v for v in z if v is not None]
    return float(np.median(z)) if z else None


def axes_angle(eo_i, eo_j) -> float:
    """The angle (degrees) between two frames' optical axes."""
    a, b = eo_i.rotation[:, 2], eo_j.rotation[:, 2]
    return math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b)))))


def _take(found, k, got, row, z) -> None:
    """Pair ``k``'s ground-plane result ``got`` into its report ``row``, and into ``found[k]`` when it kept more
    inliers than the plain matching."""
    plain = 0 if found[k] is None else len(found[k][1])
    used = len(got[1]) > plain
    if used:
        found[k] = got
    row.update(matches=int(got[0]), inliers=int(len(got[1])), used=bool(used),
               height_m=None if z is None else round(float(z), 2))


def _median_height(camera, eos, result):
    """The median ray height of a pair's inliers; None with fewer than ``MIN_PAIR_INLIERS`` of them."""
    if result is None or len(result[1]) < MIN_PAIR_INLIERS:
        return None
    z = ray_heights(camera, eos, result[1], result[2])
    z = z[np.isfinite(z)]
    return float(np.median(z)) if len(z) else None


def _distortion_terms(distortion) -> tuple:
    """``(k1, k2, k3, p1, p2)`` of a Block's tuple or a camera file's dict (:func:`fotogeo.geometry.brown.coefficients`;
    zeros when absent from a dict, ``()`` when None)."""
    return coefficients(distortion if isinstance(distortion, dict) else tuple(distortion or ())[:5])


def ray_heights(camera, eos, xy_i, xy_j) -> np.ndarray:
    """Heights of the midpoints of the shortest segments between the rays of ``xy_i`` in frame i and ``xy_j``
    in frame j (approximate orientations ``eos``); NaN where the rays are parallel or meet behind a camera."""
    a, b = OrientedFrame(camera, eos[0]), OrientedFrame(camera, eos[1])
    ca, da = a._rays(xy_i)
    cb, db = b._rays(xy_j)
    w = ca - cb
    aa, bb, cc = np.sum(da * da, 1), np.sum(da * db, 1), np.sum(db * db, 1)
    dd, ee = np.sum(da * w, 1), np.sum(db * w, 1)
    den = aa * cc - bb * bb
    with np.errstate(divide="ignore", invalid="ignore"):
        s, t = (bb * ee - cc * dd) / den, (aa * ee - bb * dd) / den
    z = 0.5 * ((ca[2] + s * da[:, 2]) + (cb[2] + t * db[:, 2]))
    z[~((s > 0) & (t > 0) & (np.abs(den) > 1e-12 * aa * cc))] = np.nan
    return z


def level_pass(infos, pairs, found, camera, distortion, eos, height: float, known, opts, threshold: float, ideal,
               max_pixels: int, progress=None, terrain=None):
    """``(found, guided, eos, measured)``: the second pass for the frames whose attitude is unknown (module
    docstring): ``eos`` with the attitude of each such frame measured on its ties (:func:`measured_attitudes`;
    ``measured`` one bool per frame), and ``found`` and ``guided`` (:func:`guided_results`' rows) with the pairs that
    hold a measured frame, and no frame still unknown, matched on the ground plane too. ``terrain``: the DEM the
    attitudes are measured on (:func:`measured_attitudes`)."""
    known = _known(known, eos)
    eos, measured = measured_attitudes(camera, ideal, eos, pairs, found, known, height, terrain)
    now = [k or m for k, m in zip(known, measured)]
    redo = [k for k, (i, j) in enumerate(pairs) if (measured[i] or measured[j]) and now[i] and now[j]]
    if not redo:
        return list(found), [], eos, measured
    again, tried, _ = guided_results(infos, [pairs[k] for k in redo], [found[k] for k in redo], camera, distortion,
                                     eos, height, opts, threshold, ideal, max_pixels, progress, known=now)
    found = list(found)
    for k, got in zip(redo, again):
        found[k] = got
    return found, tried, eos, measured


def measured_attitudes(camera, ideal, eos, pairs, found, known, height: float, terrain=None) -> tuple:
    """``(eos, measured)``: each frame whose attitude is unknown (``known`` False) with at least
    :data:`MIN_ATTITUDE_TIES` ties in its pairs ``found`` with frames of known attitude, turned to the attitude those
    ties measure (its centre kept); in rounds, the frames measured in one round counting as known in the next, until
    a round measures none: the ties' ground points are the known frames' rays through the ``terrain`` (a DEM,
    :meth:`~fotogeo.geometry.camera.OrientedFrame.pixel_to_world`; None: the plane ``height``), and the rotation
    ``R`` minimising ``Σ |R d − u|²`` over the frame's unit rays ``d`` (camera axes) and the unit directions ``u``
    from its centre to the ground points is its attitude (:func:`_rotation_to`). ``ideal``: the
    measured pixels → distortion-free ones (:func:`fotogeo.tools.triangulate.pairs.ideal_pixels`; None: already)."""
    undistort = ideal or (lambda xy: np.asarray(xy, dtype=np.float64))
    out, measured = list(eos), [False] * len(eos)
    while True:  # rounds: a frame measured in one serves its level neighbours in the next
        now = [k or m for k, m in zip(known, measured)]
        took = {}
        for f in (f for f in range(len(eos)) if not now[f]):
            R = _rotation_to(*_rays_and_directions(camera, undistort, out, pairs, found, now, f, height, terrain))
            if R is not None:
                omega, phi, kappa = angles_patb(R @ np.diag([1.0, -1.0, -1.0]))  # OpenCV camera axes -> PATB
                took[f] = replace(eos[f], omega=omega, phi=phi, kappa=kappa)
        if not took:
            return out, measured
        for f, eo in took.items():
            out[f], measured[f] = eo, True


def _rays_and_directions(camera, undistort, eos, pairs, found, known, f, height, terrain=None) -> tuple:
    """``(d, u)`` of frame ``f`` (:func:`measured_attitudes`): its rays (camera axes) to its ties with the frames
    ``known``, and the directions from its centre to their ground points (on ``terrain``, else on the plane
    ``height``; NaN where a ray misses the DEM); empty arrays when it has none."""
    d, u = [np.zeros((0, 3))], [np.zeros((0, 3))]
    for (i, j), got in zip(pairs, found):
        g = j if i == f else i if j == f else None
        if got is None or g is None or not known[g]:
            continue
        xy_f, xy_g = (got[1], got[2]) if i == f else (got[2], got[1])
        d.append(camera.rays(undistort(xy_f)))
        other = OrientedFrame(camera, eos[g])
        ground = (other.pixel_to_world_at(undistort(xy_g), height) if terrain is None else
                  other.pixel_to_world(undistort(xy_g), below(terrain, eos[g].Z)))
        u.append(ground - eos[f].centre)
    return np.vstack(d), np.vstack(u)


def _rotation_to(d, u, rounds: int = 2):
    """The rotation ``R`` (camera axes → world) minimising ``Σ |R d̂ − û|²`` (Wahba 1965): the rotation nearest
    ``B = Σ û d̂ᵀ`` (:func:`~fotogeo.geometry.camera.nearest_rotation`, Kabsch 1976); refitted ``rounds`` times on
    the pairs within :data:`TRIM_FACTOR` × the median angle (at least 0.5°) of the fit before (wrong ties, relief
    off the plane).
    None with fewer than :data:`MIN_ATTITUDE_TIES` finite pairs kept."""
    ok = np.isfinite(u).all(axis=1)
    d = d[ok] / np.linalg.norm(d[ok], axis=1, keepdims=True)
    u = u[ok] / np.linalg.norm(u[ok], axis=1, keepdims=True)
    keep, R = np.ones(len(d), dtype=bool), None
    for _ in range(rounds + 1):
        if np.count_nonzero(keep) < MIN_ATTITUDE_TIES:
            return None
        R = nearest_rotation(u[keep].T @ d[keep])
        angle = np.arccos(np.clip(np.sum((d @ R.T) * u, axis=1), -1.0, 1.0))
        keep = angle <= max(TRIM_FACTOR * float(np.median(angle[keep])), math.radians(0.5))
    return R
