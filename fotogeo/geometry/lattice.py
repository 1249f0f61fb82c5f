"""Values that vary smoothly over a window of grid cells: computed exactly on a lattice of every ``step``-th
cell and interpolated between.

* :func:`lattice` and :func:`bilinear` — the lattice of a window (every ``step``-th index and the last, so the
  window's edges are exact) and the bilinear interpolation of values given there to every cell (separable: along
  the columns, then along the rows);
* :func:`ground_to_image_on_lattice` — a ground → image model ``m(X, Y, Z)`` over a window of map cells whose
  heights ``Z`` vary from cell to cell (a DEM): ``m`` is smooth in ``(X, Y, Z)`` but the DEM is not (it has a
  kink at each of its cells), so the heights are never interpolated. ``m`` is evaluated at the lattice nodes on
  three height levels ``z_0, z_1, z_2`` spanning the window's heights (its lowest, middle and highest), written as
  the quadratic in ``t = (Z − z_0) / (z_2 − z_0)`` through them, ``A + t (B + t C)`` with ``A = m_0``,
  ``B = −3 m_0 + 4 m_1 − m_2``, ``C = 2 m_0 − 4 m_1 + 2 m_2`` (Lagrange, Newton form); ``A, B, C`` are interpolated
  bilinearly to each cell and evaluated at the cell's own height. **Error bound**: the exact model at the centre
  cell of every lattice interval (where bilinear interpolation errs most), at that cell's height, is compared
  with the interpolated position; above ``tol`` pixels (or a node without a position, e.g. behind a camera) the
  lattice is refined (``step / 4``) and then given up for the exact model at every cell. This is the idea of
  GDAL's approximate transformer (``gdalwarp -et``: interpolation along each output line, checked at its middle),
  on a 2-D lattice and with the DEM's heights kept per cell.
"""
from __future__ import annotations

import numpy as np

#: lattice step (cells) of the ground → image positions, and its error bound (image pixels)
MODEL_STEP, MODEL_TOL_PX = 16, 1e-3


def lattice(n: int, step: int) -> np.ndarray:
    """Every ``step``-th index of ``range(n)`` and the last one.

    >>> lattice(10, 4).tolist(), lattice(1, 4).tolist()
    ([0, 4, 8, 9], [0])
    """
    return np.unique(np.r_[np.arange(0, n, step), n - 1])


def bilinear(values, rows, cols, h: int, w: int) -> np.ndarray:
    """``values`` ``(k, len(rows), len(cols))`` (``k`` planes) given at the lattice ``rows`` x ``cols``
    (increasing indices from 0 to ``h - 1`` / ``w - 1``) interpolated bilinearly to every index of the ``h x w``
    window → ``(k, h, w)``: ``v_i + f (v_{i+1} − v_i)`` along the columns, then along the rows (each plane
    contiguous: whole rows are gathered)."""
    def along(v, nodes, n, axis):
        if len(nodes) == 1:
            return np.repeat(v, n, axis=axis)
        i = np.clip(np.searchsorted(nodes, np.arange(n), side="right") - 1, 0, len(nodes) - 2)
        f = (np.arange(n) - nodes[i]) / (nodes[i + 1] - nodes[i])
        shape = [1] * v.ndim
        shape[axis] = n
        out = np.take(np.diff(v, axis=axis), i, axis=axis)
        out *= f.reshape(shape)
        out += np.take(v, i, axis=axis)
        return out
    return along(along(np.asarray(values, float), cols, w, 2), rows, h, 1)


def ground_to_image_on_lattice(forward, X, Y, Z, *, step: int = MODEL_STEP, tol: float = MODEL_TOL_PX):
    """Image positions ``(h·w, 2)`` (row by row) of the cells ``(X[col], Y[row], Z[row, col])`` through
    ``forward((N, 3) XYZ) -> (N, 2)`` (module docstring); NaN where ``Z`` is. The positions stay within ``tol``
    pixels of ``forward``'s at every check point, else they are ``forward``'s own."""
    X, Y, Z = np.asarray(X, float), np.asarray(Y, float), np.asarray(Z, float)
    h, w = Z.shape
    finite = np.isfinite(Z)
    if not finite.any():
        return np.full((h * w, 2), np.nan)
    while step >= 2 and h * w > 4 * step * step:
        px = _interpolated(forward, X, Y, Z, finite, step, tol)
        if px is not None:
            return px
        step //= 4
    XX, YY = np.meshgrid(X, Y)
    return forward(np.column_stack([XX.ravel(), YY.ravel(), Z.ravel()]))


def _interpolated(forward, X, Y, Z, finite, step: int, tol: float):
    """The positions on the lattice of ``step``, or None when a check point is off by more than ``tol``."""
    h, w = Z.shape
    rows, cols = lattice(h, step), lattice(w, step)
    z0, z2 = float(Z[finite].min()), float(Z[finite].max())
    levels = np.array([z0, 0.5 * (z0 + z2), z2])
    XX, YY, ZZ = np.meshgrid(X[cols], Y[rows], levels)  # (rows, cols, levels)
    m = forward(np.column_stack([XX.ravel(), YY.ravel(), ZZ.ravel()])).reshape(len(rows), len(cols), 3, 2)
    if not np.isfinite(m).all():
        return None
    m0, m1, m2 = (np.moveaxis(m[:, :, k], 2, 0) for k in range(3))  # (2, rows, cols) each
    A, B, C = bilinear(np.concatenate([m0, -3 * m0 + 4 * m1 - m2, 2 * (m0 - 2 * m1 + m2)]), rows, cols, h, w
                       ).reshape(3, 2, h, w)
    t = (Z - z0) / (z2 - z0) if z2 > z0 else np.zeros_like(Z)
    px = C
    px *= t
    px += B
    px *= t
    px += A  # (2, h, w)
    cr, cc = (rows[:-1] + rows[1:]) // 2, (cols[:-1] + cols[1:]) // 2
    if len(cr) and len(cc):
        Zc = Z[np.ix_(cr, cc)]
        ok = np.isfinite(Zc)
        Xc, Yc = np.meshgrid(X[cc], Y[cr])
        exact = forward(np.column_stack([Xc[ok], Yc[ok], Zc[ok]]))
        if not np.all(np.abs(exact - px[:, cr][:, :, cc][:, ok].T) <= tol):
            return None
    out = np.empty((h * w, 2))
    out[:, 0], out[:, 1] = px[0].ravel(), px[1].ravel()
    return out
