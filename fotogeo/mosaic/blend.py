"""Feathering across seams and radiometric balancing (arrays in, arrays out).

**Feathering** (:func:`feather_weights`): with ``s_i`` the signed distance (map units) of a cell to the boundary
of orthophoto ``i``'s region of the label image (positive inside, negative outside), the blending weight is

    w_i = clip(½ + s_i / F, 0, 1) · valid_i,      value = Σ w_i (g_i·v_i + o_i) / Σ w_i

so each orthophoto fades out over ``F`` map units centred on the seam (``F`` = the feather width), and the
mosaic equals one orthophoto away from the seams. Signed distances are computed on the seam grid and
interpolated bilinearly to each output window.

**Balancing** (:func:`balance`): one gain ``g_i`` and offset ``o_i`` per orthophoto and band from the overlaps.
In the overlap of ``i`` and ``j`` the means ``m`` and standard deviations ``σ`` of both are measured; the gains
solve ``log g_i + log σ_ij ≈ log g_j + log σ_ji`` and the offsets ``g_i m_ij + o_i ≈ g_j m_ji + o_j`` in the
least-squares sense, each pair weighted by the square root of its overlap's cell count, with the mean log gain and
the mean offset held at 0 (a gauge: the mosaic keeps the block's overall brightness) — the global gain/offset
adjustment of e.g. Canty & Nielsen's relative normalisation reduced to means and spreads.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage


def signed_distances(labels, n: int, cell: float) -> np.ndarray:
    """``(n, rows, cols)`` signed distance (map units) of every cell to the boundary of each label's region."""
    out = np.empty((n, *labels.shape), np.float32)
    for i in range(n):
        region = labels == i
        inside = ndimage.distance_transform_edt(region)
        outside = ndimage.distance_transform_edt(~region)
        out[i] = (np.where(region, inside - 0.5, -(outside - 0.5)) * cell).astype(np.float32)
    return out


def feather_weights(signed, valid, width: float) -> np.ndarray:
    """Blending weights ``(n, rows, cols)`` (module docstring), each cell's weights summing to 1 where any is
    valid; a hard seam for ``width`` 0."""
    if width <= 0:
        w = (signed >= 0).astype(np.float32)
    else:
        w = np.clip(0.5 + signed / width, 0.0, 1.0).astype(np.float32)
    w *= valid
    total = w.sum(axis=0)
    fallback = (total == 0) & valid.any(axis=0)  # covered but outside every region's feather: any valid one
    if fallback.any():
        w[:, fallback] = valid[:, fallback]
        total = w.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, w / total, 0.0).astype(np.float32)


def overlap_statistics(values, valid, min_cells: int = 50):
    """Per pair ``(i, j, cells, m_i, m_j, σ_i, σ_j)`` over their common valid cells (``values``: ``(n, rows, cols)``
    of one band)."""
    stats = []
    n = len(values)
    for i in range(n):
        for j in range(i + 1, n):
            both = valid[i] & valid[j]
            k = int(both.sum())
            if k >= min_cells:
                a, b = values[i][both].astype(float), values[j][both].astype(float)
                stats.append((i, j, k, a.mean(), b.mean(), a.std(), b.std()))
    return stats


def balance(values, valid):
    """``(gains (n,), offsets (n,))`` of one band (module docstring); 1 and 0 without overlaps."""
    n = len(values)
    stats = overlap_statistics(values, valid)
    if not stats:
        return np.ones(n), np.zeros(n)
    A = np.zeros((len(stats) + 1, n))
    y = np.zeros(len(stats) + 1)
    for r, (i, j, k, mi, mj, si, sj) in enumerate(stats):
        w = np.sqrt(k)
        A[r, i], A[r, j] = w, -w
        y[r] = w * (np.log(max(sj, 1e-6)) - np.log(max(si, 1e-6)))
    A[-1] = 1.0  # gauge: Σ log g = 0
    log_g = np.linalg.lstsq(A, y, rcond=None)[0]
    g = np.exp(log_g)
    B = np.zeros_like(A)
    z = np.zeros_like(y)
    for r, (i, j, k, mi, mj, si, sj) in enumerate(stats):
        w = np.sqrt(k)
        B[r, i], B[r, j] = w, -w
        z[r] = w * (g[j] * mj - g[i] * mi)
    B[-1] = 1.0  # gauge: Σ o = 0
    o = np.linalg.lstsq(B, z, rcond=None)[0]
    return g, o
