"""Descriptor matching: SSD nearest neighbour with the ratio test and an optional mutual check.

For each descriptor ``a_i`` of the first set, its nearest and second-nearest neighbours
``b_j``, ``b_k`` in the second set by the sum of squared differences (SSD) are found; the
pair ``(i, j)`` is kept when ``‖a_i − b_j‖ < ratio · ‖a_i − b_k‖`` (Lowe's ratio on the
Euclidean distance, i.e. ``SSD_1 < ratio² · SSD_2``). With ``mutual`` the pair must also
be the nearest from ``b_j`` back to ``a_i``. When Laplacian signs are given (SURF), only
keypoints of the same sign are compared.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class Matches:
    """Index pairs ``pairs[:, 0]`` into the first set, ``pairs[:, 1]`` into the second."""

    pairs: np.ndarray  # (M, 2) int64
    distance: np.ndarray  # (M,) Euclidean descriptor distance
    ratio: np.ndarray  # (M,) nearest / second-nearest distance

    def __len__(self) -> int:
        return len(self.pairs)


def _nn2(q: np.ndarray, t: np.ndarray):
    """Indices and distances of the two nearest neighbours in ``t`` of each row of ``q``."""
    if len(t) < 2 or len(q) == 0:
        n = len(q)
        return np.zeros((n, 2), np.int64), np.full((n, 2), np.inf)
    knn = cv2.BFMatcher(cv2.NORM_L2).knnMatch(q, t, k=2)
    idx = np.array([[m[0].trainIdx, m[1].trainIdx] for m in knn], np.int64)
    dist = np.array([[m[0].distance, m[1].distance] for m in knn], np.float64)
    return idx, dist


def _match_group(a, b, ratio, mutual):
    idx, dist = _nn2(a, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(dist[:, 1] > 0, dist[:, 0] / dist[:, 1], 1.0)
    keep = r < ratio
    i = np.flatnonzero(keep)
    j = idx[keep, 0]
    if mutual and len(i):
        back, _ = _nn2(b[j], a) if len(a) >= 2 else (np.zeros((len(j), 2), np.int64), None)
        ok = back[:, 0] == i
        i, j = i[ok], j[ok]
    return i, j, dist[i, 0], r[i]


def match_descriptors(desc1, desc2, *, ratio: float = 0.8, mutual: bool = True,
                      laplacian1=None, laplacian2=None) -> Matches:
    """Match two descriptor sets (see the module docstring); deterministic."""
    a = np.ascontiguousarray(desc1, dtype=np.float32)
    b = np.ascontiguousarray(desc2, dtype=np.float32)
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[1]:
        raise InputError(f"descriptors must be (N, D) arrays of equal D; got {a.shape} and {b.shape}")
    if not 0 < ratio <= 1:
        raise InputError(f"ratio must be in (0, 1]; got {ratio}")
    if laplacian1 is None or laplacian2 is None:
        groups = [(np.arange(len(a)), np.arange(len(b)))]
    else:
        l1, l2 = np.asarray(laplacian1), np.asarray(laplacian2)
        groups = [(np.flatnonzero(l1 == s), np.flatnonzero(l2 == s)) for s in np.union1d(l1, l2)]
    out_i, out_j, out_d, out_r = [], [], [], []
    for ia, ib in groups:
        if len(ia) == 0 or len(ib) < 2:
            continue
        i, j, d, r = _match_group(a[ia], b[ib], ratio, mutual)
        out_i.append(ia[i]); out_j.append(ib[j]); out_d.append(d); out_r.append(r)
    if not out_i:
        return Matches(np.zeros((0, 2), np.int64), np.zeros(0), np.zeros(0))
    pairs = np.column_stack([np.concatenate(out_i), np.concatenate(out_j)]).astype(np.int64)
    order = np.argsort(pairs[:, 0], kind="stable")
    return Matches(pairs[order], np.concatenate(out_d)[order], np.concatenate(out_r)[order])
