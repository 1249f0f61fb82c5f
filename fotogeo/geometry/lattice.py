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
  on a 2-D lattice and with the DEM's heights kept per cell;
* :func:`piecewise_on_lattice` — values smooth but for kinks along known lines (a frame's positions over a DEM,
  which kinks at its cells' boundaries): a lattice with a node on every kink, interpolated in float32 and checked
  against a threshold (``ortho --error-threshold``), exact where a check fails.
"""
from __future__ import annotations

import numpy as np

#: lattice step (cells) of the ground → image positions, and its error bound (image pixels)
MODEL_STEP, MODEL_TOL_PX = 16, 1e-3
#: :func:`piecewise_on_lattice` interpolates only where its exact lattice is at most this fraction's inverse of the
#: window's cells: denser, interpolating and checking cost about what computing every cell costs
SPARSE = 12
#: share of the threshold a check of :func:`piecewise_on_lattice` may use: between two nodes the error of a smooth
#: piece is ``x (L − x) (a + b x)``, largest at the middle when ``b = 0``, and off it by 2.6 % of that at most while
#: ``|b| L <= |a|`` (the quadratic term dominates); the middle cell may also be half a cell off the middle
CHECK_MARGIN = 0.95


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
    return along(along(np.asarray(values, float), cols, np.arange(w), 2), rows, np.arange(h), 1)


def along(v, nodes, at, axis: int) -> np.ndarray:
    """``v`` given at the lattice ``nodes`` along ``axis`` interpolated linearly to the indices ``at`` (the half of
    :func:`bilinear` along one axis; each index's value depends only on it, so a subset of the indices gets the
    values the whole range would: :meth:`~fotogeo.geometry.dem.DemSampler.heights_grid` takes a block of rows at a
    time)."""
    at = np.asarray(at)
    if len(nodes) == 1:
        return np.repeat(v, len(at), axis=axis)
    i = np.clip(np.searchsorted(nodes, at, side="right") - 1, 0, len(nodes) - 2)
    f = (at - nodes[i]) / (nodes[i + 1] - nodes[i])
    shape = [1] * v.ndim
    shape[axis] = len(at)
    out = np.take(np.diff(v, axis=axis), i, axis=axis)
    out *= f.reshape(shape)
    out += np.take(v, i, axis=axis)
    return out


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


def break_nodes(breaks, n: int, step: int) -> np.ndarray:
    """Lattice nodes (fractional indices) along an axis of ``n`` cells whose values may have a kink at ``breaks``
    (fractional indices): the first and last cell, every break between them, and evenly spaced nodes splitting each
    longer interval into parts at most ``step`` cells long — so that no interval crosses a kink.

    >>> break_nodes([4.5], 17, 8).tolist()
    [0.0, 4.5, 10.25, 16.0]
    """
    b = np.asarray(breaks, float)
    b = np.unique(np.r_[0.0, b[(b > 0) & (b < n - 1)], float(n - 1)])
    span = np.diff(b)
    k = np.maximum(1, np.ceil(span / step)).astype(int)  # parts of each interval
    run = np.repeat(np.arange(len(span)), k)
    j = np.arange(len(run)) - np.repeat(np.cumsum(k) - k, k)  # 0..k-1 within each interval
    return np.r_[b[:-1][run] + j * (span / k)[run], b[-1]]


def _midpoints(nodes) -> np.ndarray:
    """The cell nearest the middle of each lattice interval, -1 where no cell lies strictly between its nodes."""
    a, b = nodes[:-1], nodes[1:]
    m = np.round(0.5 * (a + b))
    return np.where((m > a) & (m < b), m, -1.0)


def _fractions(nodes, n: int):
    """The lattice interval of each index of ``range(n)`` (the last node's is the last interval) and the index's
    fraction of the way along it."""
    i = np.clip(np.searchsorted(nodes, np.arange(n), side="right") - 1, 0, len(nodes) - 2)
    return i, (np.arange(n) - nodes[i]) / (nodes[i + 1] - nodes[i])


def bilinear32(values, rows, cols, h: int, w: int) -> np.ndarray:
    """:func:`bilinear` of two planes ``(2, len(rows), len(cols))`` into float32 planes ``(2, h, w)``: along the
    columns in float64 at the lattice rows, then along the rows in float32, each lattice interval of rows at once
    (the full-size planes are what costs: float32 halves them). Each value is within two float32 spacings of the
    float64 interpolation."""
    i, f = _fractions(cols, w)
    v = np.asarray(values, np.float64)
    top = np.take(np.diff(v, axis=2), i, axis=2)
    top *= f
    top += np.take(v, i, axis=2)  # (2, len(rows), w)
    step, top = np.diff(top, axis=1).astype(np.float32), top.astype(np.float32)  # the rows' pass in float32
    out = np.empty((2, h, w), np.float32)
    k, g = _fractions(rows, h)
    g = g.astype(np.float32)
    bounds = np.r_[0, np.flatnonzero(np.diff(k)) + 1, h]
    for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist()):
        for p in range(2):
            np.multiply(g[a:b, None], step[p, k[a]], out=out[p, a:b])
            out[p, a:b] += top[p, k[a]]
    return out


def piecewise_on_lattice(exact, row_breaks, col_breaks, h: int, w: int, *, tol: float, step: int = MODEL_STEP):
    """Positions ``(2, h, w)`` of a window whose exact values ``exact(rows, cols) -> (2, len(rows), len(cols))``
    (fractional row and column indices, the separable sub-grid) are smooth but for kinks along the rows
    ``row_breaks`` and the columns ``col_breaks`` (fractional indices: a DEM's cell boundaries, inside which its
    heights are bilinear, and its edges).

    The lattice (:func:`break_nodes`) has a node on every break, so each of its rectangles lies inside one smooth
    piece; ``exact`` at the nodes is interpolated bilinearly into float32 (:func:`bilinear32`) and checked against
    ``exact`` at the middle of every lattice edge and at the cell nearest every rectangle's centre: where bilinear
    interpolation of a smooth function errs most (for a quadratic, exactly there). A rectangle where one of its
    checks is more than :data:`CHECK_MARGIN` ``· tol`` away (Euclidean; less two float32 spacings of the largest
    position, which the cells' own rounding may add) or not finite, or with a corner without a value, takes ``exact``
    at every cell; so does the whole window (float64) when that is more than a quarter of the rectangles or when the
    lattice with its check points holds more than 1/:data:`SPARSE` of the window's cells (pieces of a few cells).
    The idea of GDAL's approximate transformer (``gdalwarp -et``, checked at the middle of each interpolated line),
    on a 2-D lattice that follows the surface's cells."""
    rows, cols = break_nodes(row_breaks, h, step), break_nodes(col_breaks, w, step)
    rm, cm = _midpoints(rows), _midpoints(cols)
    vr, hc = np.flatnonzero(rm >= 0), np.flatnonzero(cm >= 0)
    R, C = np.union1d(rows, rm[vr]), np.union1d(cols, cm[hc])  # nodes and check points: one call
    if tol <= 0 or min(len(rows), len(cols)) < 2 or len(R) * len(C) * SPARSE > h * w:
        return exact(np.arange(h), np.arange(w))
    E = exact(R, C)

    def at(r, c):
        return E[:, np.searchsorted(R, r)[:, None], np.searchsorted(C, c)[None, :]]

    v = at(rows, cols)
    fin = np.isfinite(v).all(axis=0)
    px = bilinear32(np.where(fin, v, 0.0), rows, cols, h, w)
    bad = ~(fin[:-1, :-1] & fin[1:, :-1] & fin[:-1, 1:] & fin[1:, 1:])
    # the checks leave room for what the cells between them may add: a largest error off the middle (CHECK_MARGIN)
    # and their own float32 rounding (two spacings at the largest position)
    bound = CHECK_MARGIN * tol - 2 * float(np.spacing(np.float32(np.abs(v[:, fin]).max()))) if fin.any() else 0.0

    def far(d):
        with np.errstate(invalid="ignore"):
            return ~(np.hypot(d[0], d[1]) <= bound)

    if hc.size:  # the middles of the lattice's horizontal edges (the interpolation along the node rows)
        f = (cm[hc] - cols[hc]) / (cols[hc + 1] - cols[hc])
        f = far(at(rows, cm[hc]) - (v[:, :, hc] + f * (v[:, :, hc + 1] - v[:, :, hc])))
        bad[:, hc] |= f[:-1] | f[1:]  # both rectangles beside the edge
    if vr.size:  # of its vertical edges
        f = ((rm[vr] - rows[vr]) / (rows[vr + 1] - rows[vr]))[:, None]
        f = far(at(rm[vr], cols) - (v[:, vr] + f * (v[:, vr + 1] - v[:, vr])))
        bad[vr, :] |= f[:, :-1] | f[:, 1:]
    if vr.size and hc.size:  # the cells at the rectangles' centres
        r, c = rm[vr].astype(int), cm[hc].astype(int)
        bad[np.ix_(vr, hc)] |= far(at(rm[vr], cm[hc]) - px[:, r[:, None], c[None, :]])
    if bad.mean() > 0.25:
        return exact(np.arange(h), np.arange(w))
    for i in np.flatnonzero(bad.any(axis=1)):  # the cells of the failed rectangles of each lattice row: one call
        r = np.arange(int(np.ceil(rows[i])), int(np.floor(rows[i + 1])) + 1)
        c = np.unique(np.concatenate([np.arange(int(np.ceil(cols[j])), int(np.floor(cols[j + 1])) + 1)
                                      for j in np.flatnonzero(bad[i])]))
        if r.size and c.size:
            px[:, r[:, None], c[None, :]] = exact(r, c)
    return px
