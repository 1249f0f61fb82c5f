"""Tie points of a block by matching its overlapping frames (the tool layer of ``fotogeo triangulate``).

The steps of digital aerial triangulation's tie-point measurement (Yastıklı; Büyüksalih):

* **Topology**: each frame's footprint is its outline (:func:`fotogeo.pixels.outline`) projected
  with the approximate orientation onto the plane of the mean terrain height; two frames
  overlap when their footprints share more than ``min_overlap`` of the smaller one — along and
  across strips.
* **Detection on a pyramid level**: every overlapping pair goes through
  :func:`fotogeo.tools.register.match.find_tie_points` (PCA, SURF, ratio test and mutual check, as the
  registration; Dihkan 2019; a weak match of frames in other band sets matched again as there,
  :func:`fotogeo.tools.register.bands.rematch`) on the frames reduced to pyramid level ``level`` (averaged by
  ``2**level``: ``max_match_pixels`` = w·h / 4**level), the keypoints scaled back to full
  resolution; a RANSAC fundamental matrix (Fischler & Bolles 1981) with ``epipolar_px · 2**level``
  keeps the pairs that fit the two-view geometry. The RANSAC sees the measured pixels, distortion
  included: a fundamental matrix holds for a pinhole camera only, but removing the distortion first
  (``distortion=``, :func:`ideal_pixels`: the ray of :func:`fotogeo.orientation.bundle_jacobian.undistort_rays`
  put back through the pinhole, ``x_ideal = f·scale·(u, v) + pp``) gained nothing measurable and is off in
  the tool (measured: docs/benchmarks/triangulation.md, "Distortion before the epipolar RANSAC"). Each frame is
  read, fused and detected once (:class:`fotogeo.tools.register.match.FeatureCache`; a frame in a 60/30 block is in
  6–8 pairs); its
  keypoints are dropped after its last pair, so at most the frames of the pairs still to come
  whose first pair has run are held (keypoints and descriptors only, never the images). For large
  blocks the pairs run as Dask tasks instead (``--scheduler`` / ``--workers``, as ``register-batch``;
  :mod:`fotogeo.tools.triangulate.pairs`): one detection task per frame, one matching task per pair,
  joined in pair order — the same tie points.
* **Converging views** (obliques looking different ways): pairs whose optical axes differ by more than 20°, or
  with few inliers, are matched on the ground plane too (:mod:`fotogeo.tools.triangulate.guided`).
* **Tracks**: a keypoint is the same in every pair of its frame (the detector is deterministic),
  so matches are joined into multi-ray tracks by union–find on (frame, keypoint position); a
  track that holds two different keypoints of one frame is inconsistent and dropped.
* **Gruber positions**: every frame is cut into ``cells x cells`` regions (3 x 3: Gruber's nine
  positions) and tracks are kept, most rays first, while any of their observations falls in a
  region holding fewer than ``per_region`` kept tracks (:func:`thin_to_budget`; 25–30 per
  region in the classical rule).
* **Followed down to full resolution by least-squares matching** (Gruen 1985,
  :func:`fotogeo.matching.lsm_many`): in each track the observation in the lowest-numbered frame is
  the anchor; the window around it is matched into every other frame of the track, starting
  from the keypoint position and the local affinity ``∂x_j/∂x_anchor`` of the approximate
  orientations through the plane at the mean height (rotation between strips flown in opposite
  directions, scale); an observation whose LSM does not converge is dropped, and with it a
  track left with fewer than two. A pair of frames in other band sets (a NIR-only frame against RGB) is also
  matched on the multi-band frame's bands combined to look like the other's grey, in wider windows, and keeps that
  when more windows converge (:func:`fotogeo.tools.triangulate.pairs.lsm_pair`). Each refined observation gets
  the LSM's a-posteriori precision ``σ = sqrt((σx² + σy²) / 2)``, floored at ``min_sigma`` = 0.1 px: a
  Gauss–Markov σ of LSM does not see interpolation error (:mod:`fotogeo.matching.lsm`) — on rendered frames (21²
  windows, grey noise 2) most LSM σ were below 0.05 px while the true transfer errors had a median of 0.11 px,
  and on the NGI pair a 0.05 px floor let data snooping cull tie observations with 0.08 px residuals.
  The anchor, which defines the point, gets the RMS σ of its track's transfers.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...errors import MatchingError
from ...geometry.camera import OrientedFrame
from ...io.block import frame_key
from ...io.raster import open_raster
from ...options import RegisterOptions
from ...pixels import outline
from ...progress import as_progress
from ..register.match import FeatureCache, find_tie_points
from .pairs import dask_client, dask_pair_results, epipolar_kept, ideal_pixels, refine_tracks


def overlapping_pairs(camera, eos, height: float, min_overlap: float = 0.05, *, round_footprints: bool = False) -> list:
    """``[(i, j), ...]`` (i < j) of frames whose footprints at ``height`` overlap (module docstring).

    ``round_footprints``: κ is not known yet (:mod:`fotogeo.tools.triangulate.start`), so each footprint is
    the circle through its corners around the image centre's ground point, whatever the frame's heading."""
    from shapely.geometry import Point, Polygon
    w, h = camera.image_size
    rim = outline(w, h, 8)
    polys = []
    for eo in eos:
        g = OrientedFrame(camera, eo).pixel_to_world_at(rim, height)
        if not np.isfinite(g).all():
            polys.append(None)
        elif round_footprints:
            c = OrientedFrame(camera, eo).pixel_to_world_at(np.array([camera.principal_point]), height)[0]
            polys.append(Point(c[:2]).buffer(float(np.max(np.hypot(*(g[:, :2] - c[:2]).T)))))
        else:
            polys.append(Polygon(g[:, :2]))
    pairs = []
    for i in range(len(polys)):
        for j in range(i + 1, len(polys)):
            a, b = polys[i], polys[j]
            if a is not None and b is not None and a.intersects(b):
                if a.intersection(b).area > min_overlap * min(a.area, b.area):
                    pairs.append((i, j))
    return pairs


class _UnionFind:
    def __init__(self):
        self.parent = {}

    def find(self, x):
        self.parent.setdefault(x, x)
        root = x
        while self.parent[root] != root:
            root = self.parent[root]
        while self.parent[x] != root:
            self.parent[x], x = root, self.parent[x]
        return root

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[rb] = ra


def thin_to_budget(point, frame, region, score, budget: int) -> np.ndarray:
    """Points to keep (sorted unique ids of ``point``) so that each (frame, region) gets up to ``budget``.

    ``point``, ``frame``, ``region`` (n,) describe the measurements; ``score`` (n,) orders the
    points (a point's smallest score counts; lower first). Greedy: a point is kept while any of
    its measurements falls in a (frame, region) that holds fewer than ``budget`` kept points.

    >>> thin_to_budget(np.array([0, 1, 2, 2]), np.array([0, 0, 0, 1]), np.zeros(4, int),
    ...                np.array([0.0, 1.0, 2.0, 2.0]), 1).tolist()
    [0, 2]
    """
    ids, inv = np.unique(point, return_inverse=True)
    best = np.full(len(ids), np.inf)
    np.minimum.at(best, inv, score)
    cell = frame.astype(np.int64) * (int(region.max()) + 1 if len(region) else 1) + region
    count: dict = {}
    members = [[] for _ in ids]
    for m, i in enumerate(inv):
        members[i].append(cell[m])
    keep = []
    for i in np.argsort(best, kind="stable"):
        if any(count.get(c, 0) < budget for c in members[i]):
            keep.append(ids[i])
            for c in members[i]:
                count[c] = count.get(c, 0) + 1
    return np.sort(np.array(keep, dtype=ids.dtype))


def image_regions(px, camera, cells: int = 3) -> np.ndarray:
    """Index ``row * cells + col`` of the ``cells x cells`` region of the frame each pixel falls in."""
    w, h = camera.image_size
    col = np.clip((px[:, 0] / w * cells).astype(int), 0, cells - 1)
    row = np.clip((px[:, 1] / h * cells).astype(int), 0, cells - 1)
    return row * cells + col


def _detection_options(opts, info, level: int):
    """The options with ``max_match_pixels`` set to reach pyramid level ``level`` (never above the user's)."""
    target = max(10_000, int(info.width * info.height / 4 ** level))
    return dataclasses.replace(opts, max_match_pixels=min(opts.max_match_pixels, target))


def _pair_matches(infos, pairs, opts, level, epipolar_px, prog, camera=None, distortion=None, client=None, guide=None):
    """Union–find over the epipolar inliers of every pair; ``(uf, positions, per-pair report, inliers, height)``
    (:func:`_pair_results`, then :func:`_joined`)."""
    found, per_pair, measured = _pair_results(infos, pairs, opts, level, epipolar_px, prog, camera, distortion,
                                              client, guide)
    uf, pos, inliers = _joined(pairs, found)
    return uf, pos, per_pair, inliers, measured


def _pair_results(infos, pairs, opts, level, epipolar_px, prog, camera=None, distortion=None, client=None,
                  guide=None):
    """``(found, per-pair report, height)``: each pair's epipolar inliers ``(matches, xy_i, xy_j)`` (full-resolution
    pixels as measured; None where none), the RANSAC seeing them through :func:`ideal_pixels` of ``camera`` and
    ``distortion``. With a Dask ``client`` the pairs are its tasks
    (:func:`fotogeo.tools.triangulate.pairs.dask_pair_results`), else they run in this process. ``guide`` ``(eos,
    height[, known])``: pairs with few inliers are matched on the ground plane too, those of two frames with a known
    attitude (``known``, one bool per frame; absent or None: all)
    (:func:`fotogeo.tools.triangulate.guided.guided_results`; ``height``: the terrain height it measured, else None)."""
    det = _detection_options(opts, infos[0], level)
    threshold = epipolar_px * 2 ** level
    if client is None:
        found = _local_pair_results(infos, pairs, det, threshold, ideal_pixels(camera, distortion),
                                    prog.stage(0.0, 0.6, "matching"))
    else:
        found = dask_pair_results(client, [info.path for info in infos], pairs, det, threshold, camera, distortion,
                                  prog.stage(0.0, 0.6, "matching"))
    found, rematched = (list(x) for x in zip(*found)) if pairs else ([], [])
    plain = [None if r is None else (r[0], len(r[1])) for r in found]
    guided, measured = {}, None
    if guide is not None:
        from .guided import guided_results, tile_pixels
        found, tried, measured = guided_results(infos, pairs, found, camera, distortion, *guide[:2], det, threshold,
                                                ideal_pixels(camera, distortion), tile_pixels(det, infos[0]),
                                                prog.stage(0.6, 1.0, "matching on the ground plane"),
                                                known=guide[2] if len(guide) > 2 else None)
        guided = {tuple(g.pop("pair")): g for g in tried}
    per_pair = [{"pair": [i, j], "matches": 0 if first is None else first[0],
                 "inliers": 0 if first is None else first[1], **({"bands_rematched": again} if again else {})}
                for (i, j), first, again in zip(pairs, plain, rematched)]
    return found, _with_guided(per_pair, guided), measured


def _with_guided(per_pair, guided) -> list:
    """The per-pair report rows with ``guided`` (``{(i, j): ground-plane row}``) put in: ``matches``, ``inliers``
    those the pair's ties came from, the plain matching's counts beside (``plain``, kept from a first pass)."""
    out = []
    for row in per_pair:
        g = guided.get(tuple(row["pair"]))
        if g is not None:
            plain = row.get("plain") or {"matches": row["matches"], "inliers": row["inliers"]}
            row = {**row, "matches": plain["matches"], "inliers": plain["inliers"], "plain": plain, "guided": g}
            row.update({"matches": g["matches"], "inliers": g["inliers"]} if g["used"] else {})
        out.append(row)
    return out


def _level_pass(infos, pairs, found, per_pair, camera, distortion, eos, height, known, opts, level, epipolar_px,
                prog, terrain=None):
    """``(found, per_pair, eos, measured)`` of :func:`fotogeo.tools.triangulate.guided.level_pass`: the frames left
    level get their attitude from their ties and their pairs a ground-plane pass; ``measured`` one bool per frame."""
    from .guided import level_pass, tile_pixels
    det = _detection_options(opts, infos[0], level)
    found, tried, eos, measured = level_pass(infos, pairs, found, camera, distortion, eos, height, known, det,
                                             epipolar_px * 2 ** level, ideal_pixels(camera, distortion),
                                             tile_pixels(det, infos[0]), prog, terrain)
    return found, _with_guided(per_pair, {tuple(g.pop("pair")): g for g in tried}), eos, measured


def _joined(pairs, found):
    """``(uf, positions, inliers)``: union–find over the inliers ``found`` of ``pairs``, joined in pair order (the
    same tracks whichever way the pairs ran); ``inliers`` ``[(i, j, xy_i, xy_j), ...]``."""
    uf, pos, inliers = _UnionFind(), {}, []
    for (i, j), result in zip(pairs, found):
        if result is None:
            continue
        n_matches, xy_i, xy_j = result
        inliers.append((i, j, xy_i, xy_j))
        for a, b in zip(xy_i, xy_j):
            na, nb = (i, round(a[0], 3), round(a[1], 3)), (j, round(b[0], 3), round(b[1], 3))
            pos[na], pos[nb] = a, b
            uf.union(na, nb)
    return uf, pos, inliers


def _local_pair_results(infos, pairs, det, threshold, ideal, prog):
    """``(kept, rematched)`` of each pair in turn: :func:`~fotogeo.tools.triangulate.pairs.epipolar_kept` (None
    where the descriptors do not match) and the pair's ``bands_rematched`` report (None when no re-match was
    tried), each frame detected once (:class:`FeatureCache`, dropped after its last pair)."""
    cache, last_pair = FeatureCache(), {f: k for k, pair in enumerate(pairs) for f in pair}
    for k, (i, j) in enumerate(pairs):
        try:
            stage = prog.stage(k / len(pairs), (k + 1) / len(pairs), f"matching pair {k + 1}/{len(pairs)}")
            xy_j, xy_i, counts = find_tie_points(infos[i], infos[j], det, stage, cache=cache)
        except MatchingError:
            yield None, None
            continue
        finally:
            for f in (i, j):
                if last_pair[f] == k:
                    cache.forget(infos[f])
        yield epipolar_kept(xy_i, xy_j, ideal, threshold), counts.get("bands_rematched")


def _tracks(uf, pos, n_frames):
    """``(frame, track, pixel, inconsistent tracks dropped)`` from the union–find of :func:`_pair_matches`."""
    nodes = list(pos)
    ids = {}
    track = np.array([ids.setdefault(uf.find(n), len(ids)) for n in nodes], dtype=np.intp)
    frame = np.array([n[0] for n in nodes], dtype=np.intp)
    pixel = np.array([pos[n] for n in nodes]).reshape(-1, 2)
    _, inv, cnt = np.unique(track * (n_frames + 1) + frame, return_inverse=True, return_counts=True)
    dup_tracks = np.unique(track[cnt[inv.ravel()] > 1])  # two keypoints of one frame in a track: inconsistent
    ok = ~np.isin(track, dup_tracks)
    _, track = np.unique(track[ok], return_inverse=True)
    return frame[ok], track.ravel(), pixel[ok], int(len(dup_tracks))


def detection_level(camera) -> int:
    """The pyramid level of detection for frames of this size: 1 (the measured default), or the level that
    brings a frame to at most 4 Mpx."""
    w, h = camera.image_size
    return max(1, int(np.ceil(np.log(w * h / 4e6) / np.log(4))))


def block_tie_points(frames, camera, eos, height: float, *, epipolar_px: float = 1.0, level: int | None = 1,
                     cells: int = 3, per_region: int | None = 25, lsm: bool = True, half_window: int = 10,
                     options=None, distortion=None, start=None, client=None, scheduler=None, workers=None,
                     advice: str = "check the approximate orientation", guided: bool = True, progress=None):
    """``(frame (n,), track (n,), pixel (n, 2), sigma (n,) px or None, report)`` of the tie points of the
    block (module docstring): detection on pyramid ``level`` (None: :func:`detection_level`), epipolar
    RANSAC, tracks, thinning to ``per_region`` tracks in each of ``cells x cells`` regions per frame (None:
    no thinning), LSM at full resolution (``lsm``; σ None without it). ``distortion``: the camera's Brown
    terms ``(k1, k2, k3, p1, p2)``, removed before the epipolar RANSAC (:func:`ideal_pixels`). ``client``
    (a ``dask.distributed.Client``), ``scheduler`` (its address) or ``workers`` (> 0: a local cluster of so
    many processes): the pairs are matched and the tracks followed by LSM as Dask tasks
    (:mod:`fotogeo.tools.triangulate.pairs`; the same tie points), else in this process.

    ``start(eos, pair_inliers) -> (eos, height, report)`` (:mod:`fotogeo.tools.triangulate.start`) measures
    what the approximate orientation lacks on the matched pairs before LSM needs it; the orientations and
    height used are then ``report["start"]["eos"]`` and ``["height"]`` (pairs chosen on round footprints).
    ``advice``: what to check, in the caller's words, when a frame overlaps no other. ``guided``: pairs with few
    inliers are matched again on the ground plane (:mod:`fotogeo.tools.triangulate.guided`), those whose two frames
    have a known attitude (``start.level``, one bool per frame: True where the frame starts level, its κ measured)."""
    with dask_client(client, scheduler, workers) as client:
        return _block_tie_points(frames, camera, eos, height, epipolar_px, level, cells, per_region, lsm, half_window,
                                 options, distortion, start, client, progress, advice, guided)


def _block_tie_points(frames, camera, eos, height, epipolar_px, level, cells, per_region, lsm, half_window, options,
                      distortion, start, client, progress, advice="check the approximate orientation", guided=True):
    """:func:`block_tie_points` on the Dask ``client`` (None: in this process)."""
    prog = as_progress(progress)
    opts = options or RegisterOptions()
    level = detection_level(camera) if level is None else int(level)
    given = height is not None
    if height is None:
        from .start import provisional_height
        height = provisional_height(eos, camera)
    pairs = overlapping_pairs(camera, eos, height, round_footprints=start is not None)
    alone = sorted(set(range(len(frames))) - {i for p in pairs for i in p})
    if alone:
        raise MatchingError(f"frame(s) {', '.join(repr(str(frames[i])) for i in alone[:10])} overlap no other frame "
                            f"with the approximate orientation (footprints at height {height:.1f}); {advice}, or "
                            f"remove them", frames=[frame_key(frames[i]) for i in alone])
    infos = [open_raster(f, "frame") for f in frames]
    unknown = getattr(start, "level", None)  # the frames that start level: the ground plane needs the attitude
    known = None if unknown is None else [not u for u in unknown]

    def matched(pairs, height, part):
        return _pair_results(infos, pairs, opts, level, epipolar_px, prog.stage(*part, "matching"), camera,
                             distortion, client, guide=(eos, height, known) if guided else None)
    found, per_pair, measured = matched(pairs, height, (0.0, 0.6))
    if measured is not None and not given:  # the ground plane's height measured on the frames: the pairs it adds
        more = sorted(set(overlapping_pairs(camera, eos, measured, round_footprints=start is not None)) - set(pairs))
        if more:
            found2, per_pair2, _ = matched(more, measured, (0.6, 0.7))
            order = sorted(range(len(pairs) + len(more)), key=lambda k: (pairs + more)[k])
            pairs, found, per_pair = ([x[k] for k in order] for x in (pairs + more, found + found2,
                                                                      per_pair + per_pair2))
    uf, pos, inliers = _joined(pairs, found)
    frame, track, pixel, dropped = _tracks(uf, pos, len(frames))
    report = {"pairs": per_pair, "detection_level": int(level), "tracks_matched": int(len(np.unique(track))),
              "dropped_inconsistent_tracks": dropped}
    if measured is not None and not given:
        height = report["ground_plane_height"] = measured
    if start is not None:
        eos, new_height, report["start"] = start(eos, inliers)
        height = height if new_height is None or (measured is not None and not given) else new_height
        if guided and known is not None and not all(known):  # the level frames' attitude, then their ground plane
            found, report["pairs"], eos, took = _level_pass(infos, pairs, found, per_pair, camera, distortion, eos,
                                                            height, known, opts, level, epipolar_px,
                                                            prog.stage(0.6, 0.7, "the level frames' pairs"),
                                                            getattr(start, "terrain", None))
            report["start"]["attitude_from_ties_deg"] = [[round(float(a), 2) for a in (e.omega, e.phi, e.kappa)]
                                                         if t else None for e, t in zip(eos, took)]
            uf, pos, _ = _joined(pairs, found)
            frame, track, pixel, report["dropped_inconsistent_tracks"] = _tracks(uf, pos, len(frames))
            report["tracks_matched"] = int(len(np.unique(track)))
        report["start"].update(eos=tuple(eos), height=float(height))
    if per_region is not None and len(track):
        rays = np.bincount(track)[track].astype(float)
        kept = thin_to_budget(track, frame, image_regions(pixel, camera, cells), -rays, int(per_region))
        keep = np.isin(track, kept)
        report["thinning"] = {"cells": int(cells), "per_region": int(per_region), "tracks_kept": int(len(kept))}
        frame, track, pixel = frame[keep], np.unique(track[keep], return_inverse=True)[1].ravel(), pixel[keep]
    sigma = None
    if lsm and len(track):
        ok, pixel, sigma, report["lsm"] = refine_tracks(infos, frame, track, pixel, camera, eos, height,
                                                        max_shift=2.0 ** level + 1.5, half_window=half_window,
                                                        client=client,
                                                        prog=prog.stage(0.7, 1.0, "least-squares matching"))
        frame, pixel, sigma = frame[ok], pixel[ok], sigma[ok]
        track = np.unique(track[ok], return_inverse=True)[1].ravel()
    report["tracks"] = int(len(np.unique(track)))
    report["rays_per_track"] = {str(k): int(v) for k, v in zip(*np.unique(np.bincount(track), return_counts=True))}
    return frame, track, pixel, sigma, report


def matched_observations(frames, names, camera, eos, height: float, **kwargs):
    """``(ImageObservations, report)``: :func:`block_tie_points` as the table the bundle adjustment reads
    (frame keys ``names``, point ids ``tie<track>``, each observation's LSM σ)."""
    from ...io.block import ImageObservations
    frame, track, pixel, sigma, report = block_tie_points(frames, camera, eos, height, **kwargs)
    for p in report["pairs"]:
        p["frames"] = [str(names[i]) for i in p["pair"]]
    obs = ImageObservations(np.array([names[f] for f in frame], dtype=object),
                            np.array([f"tie{t}" for t in track], dtype=object), pixel, sigma)
    return obs, report
