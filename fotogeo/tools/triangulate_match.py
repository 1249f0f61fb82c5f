"""Tie points of a block by matching its overlapping frames (the tool layer of ``fotogeo triangulate``).

* **Topology**: each frame's footprint is its outline (:func:`fotogeo.pixels.outline`) projected
  with the approximate orientation onto the plane of the mean terrain height; two frames
  overlap when their footprints share more than ``min_overlap`` of the smaller one — along and
  across strips.
* **Matching**: every overlapping pair goes through :func:`fotogeo.tools.match.find_tie_points`
  (PCA, SURF, ratio test and mutual check, as the registration; Dihkan 2019), then a RANSAC
  fundamental matrix (Fischler & Bolles 1981) with ``epipolar_px`` keeps the pairs that fit the
  two-view geometry.
* **Tracks**: a keypoint is the same in every pair of its frame (the detector is deterministic),
  so matches are joined into multi-ray tracks by union–find on (frame, keypoint position); a
  track that holds two different keypoints of one frame is inconsistent and dropped.
"""
from __future__ import annotations

import numpy as np

from ..errors import MatchingError
from ..geometry.camera import OrientedFrame
from ..io.raster import open_raster
from ..options import RegisterOptions
from ..pixels import outline
from .match import find_tie_points


def overlapping_pairs(camera, eos, height: float, min_overlap: float = 0.05) -> list:
    """``[(i, j), ...]`` (i < j) of frames whose footprints at ``height`` overlap (module docstring)."""
    from shapely.geometry import Polygon
    w, h = camera.image_size
    rim = outline(w, h, 8)
    polys = []
    for eo in eos:
        g = OrientedFrame(camera, eo).pixel_to_world_at(rim, height)
        polys.append(Polygon(g[:, :2]) if np.isfinite(g).all() else None)
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


def _epipolar_inliers(xy1, xy2, threshold):
    import cv2
    if len(xy1) < 8:
        return np.zeros(len(xy1), bool)
    _, mask = cv2.findFundamentalMat(xy1.astype(np.float64), xy2.astype(np.float64), cv2.FM_RANSAC, threshold,
                                     0.999)
    return np.zeros(len(xy1), bool) if mask is None else mask.ravel().astype(bool)


def match_block(frames, camera, eos, height: float, *, epipolar_px: float = 1.0, options=None, progress=None):
    """``(frame index (n,), track id (n,), pixel (n, 2), report)`` of the tie points of the block."""
    from ..progress import as_progress
    prog = as_progress(progress)
    opts = options or RegisterOptions()
    pairs = overlapping_pairs(camera, eos, height)
    alone = sorted(set(range(len(frames))) - {i for p in pairs for i in p})
    if alone:
        raise MatchingError(f"frame(s) {', '.join(repr(str(frames[i])) for i in alone[:10])} overlap no other frame "
                            f"with the approximate orientation (footprints at height {height:.1f}); check the "
                            f"orientation file or remove them")
    infos = [open_raster(f, "frame") for f in frames]
    uf, pos, per_pair = _UnionFind(), {}, []
    for k, (i, j) in enumerate(pairs):
        try:
            xy_j, xy_i, _ = find_tie_points(infos[i], infos[j], opts, prog.stage(k / len(pairs), (k + 1) / len(pairs),
                                                                                   f"matching pair {k + 1}/{len(pairs)}"))
        except MatchingError:
            per_pair.append({"pair": [i, j], "matches": 0, "inliers": 0})
            continue
        keep = _epipolar_inliers(xy_i, xy_j, epipolar_px)
        per_pair.append({"pair": [i, j], "matches": int(len(keep)), "inliers": int(keep.sum())})
        for a, b in zip(xy_i[keep], xy_j[keep]):
            na, nb = (i, round(a[0], 3), round(a[1], 3)), (j, round(b[0], 3), round(b[1], 3))
            pos[na], pos[nb] = a, b
            uf.union(na, nb)
    nodes = list(pos)
    ids = {}
    track = np.array([ids.setdefault(uf.find(n), len(ids)) for n in nodes], dtype=np.intp)
    frame = np.array([n[0] for n in nodes], dtype=np.intp)
    _, inv, cnt = np.unique(track * (len(frames) + 1) + frame, return_inverse=True, return_counts=True)
    dup_tracks = np.unique(track[cnt[inv] > 1])  # two keypoints of one frame in a track: inconsistent
    ok = ~np.isin(track, dup_tracks)
    pixel = np.array([pos[n] for n in nodes]).reshape(-1, 2)
    report = {"pairs": per_pair, "tracks": int(len(np.unique(track[ok]))),
              "dropped_inconsistent_tracks": int(len(dup_tracks))}
    return frame[ok], track[ok], pixel[ok], report
