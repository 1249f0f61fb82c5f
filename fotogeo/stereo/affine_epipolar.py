"""Locally epipolar geometry of two pushbroom (RPC) images, as s2p does it (de Franchis et al. 2014).

Over a small tile two RPC images behave like affine cameras, whose epipolar lines are parallel in each image.
From correspondences ``p1 ↔ p2`` of ground points of a 3-D grid (the tile's pixels at several heights, projected
through both models) the **affine fundamental matrix** is fitted (Hartley & Zisserman 2004, §14.2; total least
squares)::

    a·x2 + b·y2 + c·x1 + d·y1 + e = 0

and each image gets a rectifying similarity, rows ``v`` and columns ``u`` (``n = |(c, d)|``)::

    left:   u1 = ( d·x1 − c·y1) / n,       v1 = (c·x1 + d·y1) / n
    right:  u2 = σ(−b·x2 + a·y2) / n + t,  v2 = −(a·x2 + b·y2 + e) / n

so that ``v1 = v2`` for every correspondence; ``σ = ±1`` keeps both images the same handedness and ``t`` puts
the median disparity ``u1 − u2`` of the grid at 0. Both maps take and give corner-convention pixels.

The **relative pointing correction** (s2p's "pointing error correction"): tie points ``p2`` lie off the epipolar
curves ``q(h)`` of their ``p1`` (the right image's RPC misplaced relative to the left's); a translation ``τ`` of the
right image minimises ``Σ (n_i·(q_i + τ − p2_i))²`` (``n_i`` the curve's unit normal at its closest point ``q_i``),
robustly: the largest consensus of the tie points within ``threshold`` of one translation
(:func:`fotogeo.models.ransac.ransac`, Fischler & Bolles 1981, on samples of two tie points) starts a least-squares
refit that keeps the points within ``max(3 px, 3·1.4826·MAD)`` of it. ``threshold`` is in the tie points' own scale:
3 px for tie points found on the images whole, 3·k px for tie points found on overviews averaged over k x k blocks
and multiplied back (their scatter grows k times; :func:`fotogeo.tools.dsm.rpc_pairs.agreement_px`); the refit's
trimming follows the consensus's own scatter (the MAD) down to 3 px, not to ``threshold``: at k = 14 a 42 px floor
kept the false ties within 42 px of ``τ`` (simulated, 100 true ties of σ 8 px among 100 false: median error 1.24 px
with it, 0.60 px without). A least-squares start over all tie points is not enough: in a thin overlap most of the
SIFT matches lie where the other image does not reach, off by hundreds of pixels (the ventoux pair cut to a
47-column overlap: 53 of 88 agreeing on a τ of 4.77 px, a least-squares fit over all, trimmed, at 61.6 px). Along
the epipolar lines ``τ`` is not observable: there it would move heights, not rows; when the lines are nearly
parallel (a satellite pair) that component is left 0 (least squares truncated at a singular value ratio of 0.1).
"""
from __future__ import annotations

import numpy as np

from ..errors import MatchingError
from ..models.ransac import ransac

#: the least-squares refit of the pointing correction keeps tie points within 3·1.4826·MAD of it, and at least
#: those within this many pixels (or the consensus threshold, when smaller)
TRIM_FLOOR_PX = 3.0


def affine_fundamental(p1, p2) -> np.ndarray:
    """``(a, b, c, d, e)`` of the affine fundamental matrix (module docstring), normalised to ``|(a, b, c, d)|
    = 1``."""
    p1, p2 = np.asarray(p1, float), np.asarray(p2, float)
    m = np.column_stack([p2, p1])
    mean = m.mean(axis=0)
    _, _, vt = np.linalg.svd(m - mean, full_matrices=False)
    abcd = vt[-1]
    return np.array([*abcd, -abcd @ mean])


def rectifying_maps(p1, p2, same_height) -> tuple:
    """``(A1, A2)``: 2 x 3 affine maps ``[u, v] = A·[x, y, 1]`` of the left and right image (module docstring)
    from grid correspondences; ``same_height`` a boolean mask of the correspondences at one height (for the
    handedness)."""
    a, b, c, d, e = affine_fundamental(p1, p2)
    n = float(np.hypot(c, d))
    A1 = np.array([[d, -c, 0.0], [c, d, 0.0]]) / n
    A2 = np.array([[-b, a, 0.0], [-a, -b, -e]]) / n
    u1 = apply(A1, p1)[:, 0]
    u2 = apply(A2, p2)[:, 0]
    s = same_height
    if np.corrcoef(u1[s], u2[s])[0, 1] < 0:
        A2[0] *= -1
        u2 = -u2
    A2[0, 2] = float(np.median(u1 - u2))
    return A1, A2


def apply(A, p) -> np.ndarray:
    """``A·[x, y, 1]`` of points ``(N, 2)``."""
    p = np.asarray(p, float)
    return p @ A[:, :2].T + A[:, 2]


def invert(A) -> np.ndarray:
    """The inverse 2 x 3 affine map."""
    M = np.linalg.inv(A[:, :2])
    return np.column_stack([M, -M @ A[:, 2]])


def curve_offsets(p2, q_lo, q_hi) -> tuple:
    """``(normal offsets (N,), unit normals (N, 2), position along (N,))`` of points ``p2`` from the straight
    epipolar segments ``q_lo → q_hi`` (position 0 at ``q_lo``, 1 at ``q_hi``)."""
    v = np.asarray(q_hi, float) - np.asarray(q_lo, float)
    L = np.linalg.norm(v, axis=1)
    t = v / L[:, None]
    nrm = np.column_stack([-t[:, 1], t[:, 0]])
    w = np.asarray(p2, float) - q_lo
    return (w * nrm).sum(axis=1), nrm, (w * t).sum(axis=1) / L


class _Shift:
    """The translation ``τ`` of :func:`pointing_correction` in the interface :func:`fotogeo.models.ransac.ransac`
    asks: ``src`` the curves' unit normals ``n_i``, ``dst`` the offsets ``(off_i, 0)``, residual ``|off_i − n_i·τ|``
    (not a registered model: it maps nothing a user would pick)."""

    name, min_points = "pointing shift", 2

    def __init__(self, tau):
        self.tau = tau

    @classmethod
    def estimate(cls, nrm, off, weights=None):
        return cls(np.linalg.lstsq(nrm, off[:, 0], rcond=0.1)[0])  # along nearly parallel lines: not observed

    def residuals(self, nrm, off):
        return np.abs(off[:, 0] - nrm @ self.tau)


def pointing_correction(p2, q_lo, q_hi, threshold: float = 3.0) -> tuple:
    """``(τ (2,), inliers (N,) bool, residuals after (N,))`` (module docstring; ``threshold`` in the pixels of
    ``p2``, the tie points' scale); no inliers (and ``τ = 0``) with fewer than two tie points."""
    off, nrm, _ = curve_offsets(p2, q_lo, q_hi)
    try:
        keep = ransac(_Shift, nrm, np.column_stack([off, np.zeros_like(off)]), threshold, rng=0,
                      min_inliers=2).inliers
    except MatchingError:
        return np.zeros(2), np.zeros(len(off), bool), off
    tau = np.zeros(2)
    for _ in range(3):
        tau = _Shift.estimate(nrm[keep], off[keep, None]).tau
        res = off - nrm @ tau
        new = np.abs(res) <= max(min(threshold, TRIM_FLOOR_PX), 3.0 * 1.4826 * np.median(np.abs(res[keep])))
        if np.array_equal(new, keep) or new.sum() < 3:
            break
        keep = new
    return tau, keep, off - nrm @ tau
