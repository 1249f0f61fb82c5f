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


#: signed distance standing for "no region at all" (an orthophoto every other one hides): weight 0 everywhere
FAR_OUTSIDE = -1e9


def signed_distance(labels, i: int, window, cell: float) -> np.ndarray:
    """Signed distance (map units) of every cell of ``window`` (of the label grid) to the boundary of label
    ``i``'s region, which lies inside the window (the window of orthophoto ``i``: it has data nowhere else)."""
    r0, r1, c0, c1 = window
    region = np.pad(labels[r0:r1, c0:c1] == i, 1)  # the region ends at the window's edge: a border of "outside"
    if not region.any():
        return np.full((r1 - r0, c1 - c0), FAR_OUTSIDE, np.float32)
    inside = ndimage.distance_transform_edt(region)
    outside = ndimage.distance_transform_edt(~region)
    return (np.where(region, inside - 0.5, -(outside - 0.5)) * cell).astype(np.float32)[1:-1, 1:-1]


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


def overlap_statistics(patches, pairs, band: int, min_cells: int = 50):
    """Per pair of :class:`~fotogeo.mosaic.patches.Patch` ``(i, j, cells, m_i, m_j, σ_i, σ_j)`` of one band over
    their common valid cells (each pair read over the intersection of the two windows only)."""
    from .patches import intersection
    stats = []
    for i, j in pairs:
        win = intersection(patches[i].window, patches[j].window)
        if win is None:
            continue
        vi, vj = patches[i].crop(win), patches[j].crop(win)
        both = np.isfinite(vi).all(axis=0) & np.isfinite(vj).all(axis=0)
        k = int(both.sum())
        if k >= min_cells:
            a, b = vi[band][both].astype(float), vj[band][both].astype(float)
            stats.append((i, j, k, a.mean(), b.mean(), a.std(), b.std()))
    return stats


def _gauged_least_squares(stats, n: int, rhs) -> np.ndarray:
    """``x`` (n,) minimising ``Σ k (x_i − x_j − rhs(i, j))²`` over the pairs, with ``Σ x = 0`` (sparse: one row
    per overlap, so the size follows the overlaps, not ``n²``)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import lsqr
    m = len(stats)
    w = np.sqrt([k for _, _, k, *_ in stats])
    rows = np.concatenate([np.repeat(np.arange(m), 2), np.full(n, m)])
    cols = np.concatenate([np.array([(i, j) for i, j, *_ in stats]).ravel(), np.arange(n)])
    vals = np.concatenate([np.column_stack([w, -w]).ravel(), np.ones(n)])  # last row: the gauge Σ x = 0
    y = np.append(w * np.array([rhs(*s) for s in stats]), 0.0)
    A = coo_matrix((vals, (rows, cols)), shape=(m + 1, n)).tocsr()
    return lsqr(A, y, atol=1e-14, btol=1e-14, iter_lim=20 * n + 100)[0]


def balance(stats, n: int):
    """``(gains (n,), offsets (n,))`` of one band from its :func:`overlap_statistics` (module docstring); 1 and 0
    without overlaps."""
    if not stats:
        return np.ones(n), np.zeros(n)
    g = np.exp(_gauged_least_squares(stats, n, lambda i, j, k, mi, mj, si, sj:
                                     np.log(max(sj, 1e-6)) - np.log(max(si, 1e-6))))
    o = _gauged_least_squares(stats, n, lambda i, j, k, mi, mj, si, sj: g[j] * mj - g[i] * mi)
    return g, o
