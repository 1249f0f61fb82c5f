"""Least-squares refinement of dense disparities (Gruen 1985; Förstner 1982): the right image warped by the
current disparities is fitted to the left one over a window around each pixel.

With ``R_w(x, y) = R(x − d(x, y), y)`` and its row gradient ``g = ∂R/∂x`` at the same places, each pixel's
window ``W`` (``window x window`` pixels) gives the Gauss–Markov model of least-squares matching restricted to
what epipolar images leave free — a shift ``δ`` along the row and a radiometric offset ``a0`` and gain
``1 + a1``::

    L − R_w = −g·δ + a0 + a1·R_w + v

(all pixels of ``W`` weighted alike); the normal equations are box sums of the products of ``(−g, 1, R_w)`` and
``L − R_w``, solved per pixel. As every pixel of ``W`` was warped by its own disparity, ``δ`` corrects their
``g²``-weighted mean, so the centre's disparity becomes that mean plus ``δ``; iterated ``iterations`` times on the
re-warped image. An update is
kept only where the shift is determined — its cofactor ``(N⁻¹)₀₀`` below ``1 / (window² · min_gradient²)``, as
for a window whose row gradients average ``min_gradient`` grey levels per pixel — and the whole correction stays
under ``max_shift`` px; elsewhere the disparity stays as it was. Disparities follow :mod:`fotogeo.stereo.rectify` (``d = u_left − u_right``, NaN
where none).
"""
from __future__ import annotations

import cv2
import numpy as np


def _box(a, window: int) -> np.ndarray:
    return cv2.boxFilter(a, cv2.CV_64F, (window, window), normalize=False, borderType=cv2.BORDER_REFLECT)


def refine(left, right, d, *, window: int = 11, iterations: int = 3, max_shift: float = 1.0,
           min_gradient: float = 1.0) -> np.ndarray:
    """Refined disparities of the rectified ``left`` against ``right`` (float grey images, same shape), starting
    from ``d`` (module docstring); NaN stays NaN."""
    L = np.asarray(left, np.float64)
    R = np.asarray(right, np.float32)
    gR = cv2.Sobel(R, cv2.CV_32F, 1, 0, ksize=1) * 0.5  # central difference (R[x+1] − R[x−1]) / 2
    rows, cols = d.shape
    ok = np.isfinite(d)
    d0 = np.where(ok, d, 0.0).astype(np.float64)
    cur = d0.copy()
    xs, ys = np.meshgrid(np.arange(cols, dtype=np.float32), np.arange(rows, dtype=np.float32))
    for _ in range(iterations):
        mx = (xs - cur).astype(np.float32)
        Rw = cv2.remap(R, mx, ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE).astype(np.float64)
        g = -cv2.remap(gR, mx, ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE).astype(np.float64)
        r = L - Rw
        w = ok.astype(np.float64)  # pixels without a disparity carry no observation
        J = (g * w, w, Rw * w)
        N = {(i, j): _box(J[i] * J[j], window) for i in range(3) for j in range(i, 3)}
        b0, b1, b2 = (_box(J[i] * r, window) for i in range(3))
        # the 3 x 3 symmetric solve in closed form (cofactors of the first row; δ and (N⁻¹)₀₀ are all it needs)
        c0 = N[1, 1] * N[2, 2] - N[1, 2] ** 2
        c1 = N[0, 2] * N[1, 2] - N[0, 1] * N[2, 2]
        c2 = N[0, 1] * N[1, 2] - N[0, 2] * N[1, 1]
        det = N[0, 0] * c0 + N[0, 1] * c1 + N[0, 2] * c2
        with np.errstate(divide="ignore", invalid="ignore"):
            delta = (c0 * b0 + c1 * b1 + c2 * b2) / det
            q00 = c0 / det
        # the shift's cofactor (N⁻¹)₀₀: its precision needs texture along the row over the window
        good = ok & (det > 0) & (q00 > 0) & (q00 * window * window < 1.0 / min_gradient ** 2) & np.isfinite(delta)
        # the window's residuals measure the mean error of its disparities (weighted by g²), not the centre's:
        # the centre's disparity is that weighted mean plus the shift
        g2 = J[0] * J[0]
        mean = _box(g2 * cur, window) / np.maximum(_box(g2, window), 1e-12)
        cur = np.where(good, mean + delta, cur)
    keep = ok & (np.abs(cur - d0) < max_shift)
    out = np.where(keep, cur, d0).astype(np.float32)
    out[~ok] = np.nan
    return out
