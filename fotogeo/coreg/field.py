"""The smooth displacement field: a global model plus a thin-plate spline of the window residuals.

The corrected target is ``corrected(p) = target(p + D(p))`` for every pixel ``p`` of the
target's grid (corner convention), with

    D(p) = M(p) − p + s(p),

``M`` the global model (:mod:`fotogeo.coreg.filter`) and ``s`` the smoothing thin-plate spline
(Duchon 1977; Wahba 1990) of the reliable windows' residuals ``e_i = q_i − M(p_i)``: among
all functions it minimises

    Σ_i (e_i − s(p_i))² / σ_i²  +  λ · ∫∫ (s_xx² + 2 s_xy² + s_yy²) dx dy,

in coordinates measured in grid spacings (so ``smoothing`` = λ does not depend on the pixel
size); ``λ = 0`` interpolates every window exactly, larger values are stiffer. The weights
``1/σ_i² = w_i / mean(w)``, ``w_i`` the window's reliability times its Tukey weight against
the spline through the others (:func:`robust_weights`: 0 rejects it). Solved by
``scipy.interpolate.RBFInterpolator(kernel="thin_plate_spline", smoothing=λ σ_i²)``; above
``TILE_POINTS`` windows the domain is cut into tiles, each fitted on its windows and those
within a margin of ``TILE_MARGIN`` spacings, blended by weights falling from 1 at the tile's
edge to 0 half-way through the margin (memory and time stay bounded: the dense solve grows
with the cube of the windows).

Far from any reliable window the spline is faded to zero (the global model alone): by the
factor ``exp(−((r − 2h)/2h)²)`` for a distance ``r > 2h`` to the nearest reliable window,
``h`` the grid spacing.

The field is kept on a coarse grid of ``step`` px, node ``(i, j)`` at target pixel
``((j − 2 + ½)·step, (i − 2 + ½)·step)`` (two nodes beyond each edge), and upsampled to
pixels by separable Keys cubic convolution (which reproduces linear fields exactly), block
by block: memory is bounded by the block, never by the image.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse
from scipy.interpolate import RBFInterpolator
from scipy.spatial import cKDTree

from ..matching.interpolation import _cubic_weights

#: largest number of windows fitted by one spline
TILE_POINTS = 2500
#: tile margin, in grid spacings
TILE_MARGIN = 6
#: extra coarse nodes beyond each edge of the image
GHOST = 2
#: Tukey's biweight constant (95 % efficiency for normal errors)
TUKEY_C = 4.685
#: the smallest robust σ (px) of the windows about the spline: below it windows are not told apart
MIN_SIGMA = 0.03


def cubic_matrix(n_nodes: int, positions: np.ndarray) -> scipy.sparse.csr_matrix:
    """Sparse (len(positions), n_nodes) Keys-cubic interpolation matrix; ``positions`` in node
    index units (node k at k), clamped to the nodes."""
    t = np.clip(np.asarray(positions, dtype=np.float64), 0, n_nodes - 1)
    k = np.floor(t).astype(int)
    w = _cubic_weights(t - k)
    rows = np.repeat(np.arange(len(t)), 4)
    cols = np.clip(k[:, None] + np.arange(-1, 3)[None, :], 0, n_nodes - 1).ravel()
    return scipy.sparse.csr_matrix((np.stack(w, axis=1).ravel(), (rows, cols)), shape=(len(t), n_nodes))


@dataclass(frozen=True)
class DisplacementField:
    """``D`` (2, rows, cols) float64 displacement ``(dx, dy)`` in target px at the coarse
    nodes (see the module docstring); ``step`` px; ``width``, ``height`` the target grid;
    ``model`` the global model (for the report)."""

    D: np.ndarray
    step: int
    width: int
    height: int
    model: object

    def _node(self, p):
        return np.asarray(p, dtype=np.float64) / self.step - 0.5 + GHOST

    def block(self, row0: int, col0: int, rows: int, cols: int):
        """``(dx, dy)`` float32 (rows, cols) at the centres of a block of target pixels."""
        Wy = cubic_matrix(self.D.shape[1], self._node(row0 + 0.5 + np.arange(rows)))
        Wx = cubic_matrix(self.D.shape[2], self._node(col0 + 0.5 + np.arange(cols)))
        return tuple((Wy @ (Wx @ self.D[k].T).T).astype(np.float32) for k in range(2))

    def at(self, xy) -> np.ndarray:
        """``D`` at points ``xy`` (N, 2), corner convention: (N, 2)."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        ny, nx = self.D.shape[1:]
        u = np.clip(self._node(xy[:, 0]), 0, nx - 1)
        v = np.clip(self._node(xy[:, 1]), 0, ny - 1)
        iu, iv = np.floor(u).astype(int), np.floor(v).astype(int)
        wu, wv = _cubic_weights(u - iu), _cubic_weights(v - iv)
        out = np.zeros((len(xy), 2))
        for a in range(4):
            rows = np.clip(iv + a - 1, 0, ny - 1)
            for b in range(4):
                cols = np.clip(iu + b - 1, 0, nx - 1)
                out += (wv[a] * wu[b])[:, None] * self.D[:, rows, cols].T
        return out

    def inside(self) -> np.ndarray:
        """The nodes within the image (without the ghost nodes): (2, ceil(H/step), ceil(W/step))."""
        return self.D[:, GHOST:-GHOST, GHOST:-GHOST]


def _nodes(width: int, height: int, step: int):
    nx = int(np.ceil(width / step)) + 2 * GHOST
    ny = int(np.ceil(height / step)) + 2 * GHOST
    x = (np.arange(nx) - GHOST + 0.5) * step
    y = (np.arange(ny) - GHOST + 0.5) * step
    return np.meshgrid(x, y)


def _fit_tile(P, E, lam, Q):
    if len(P) < 3:
        return np.zeros((len(Q), 2))
    rbf = RBFInterpolator(P, E, kernel="thin_plate_spline", smoothing=lam, degree=1)
    return rbf(Q)


def _spline(P, E, lam, Q):
    """The smoothing spline at ``Q``; tiled above ``TILE_POINTS`` (units: grid spacings)."""
    if len(P) <= TILE_POINTS:
        return _fit_tile(P, E, lam, Q)
    lo, hi = P.min(axis=0), P.max(axis=0)
    ntile = int(np.ceil(np.sqrt(len(P) / (0.5 * TILE_POINTS))))
    edges = [np.linspace(lo[k], hi[k] + 1e-9, ntile + 1) for k in range(2)]
    size = (hi - lo) / ntile
    half = np.maximum(0.5 * size, 1.0)
    acc, wsum = np.zeros((len(Q), 2)), np.zeros(len(Q))
    for i in range(ntile):
        for j in range(ntile):
            c = np.array([(edges[0][j] + edges[0][j + 1]) / 2, (edges[1][i] + edges[1][i + 1]) / 2])
            inp = np.all(np.abs(P - c) <= half + TILE_MARGIN, axis=1)
            t = _tent(Q, c, half, np.array([j == 0, i == 0]), np.array([j == ntile - 1, i == ntile - 1]))
            q = t > 0
            if q.any():
                acc[q] += t[q, None] * _fit_tile(P[inp], E[inp], lam[inp], Q[q])
                wsum[q] += t[q]
    return acc / np.maximum(wsum, 1e-12)[:, None]


def _tent(Q, c, half, first, last):
    """Blending weight of a tile centred on ``c``: 1 over the tile, falling to 0 at
    ``TILE_MARGIN / 2`` spacings beyond it (inside the margin its spline was fitted on), and 1
    all the way out beyond the outer edges of the outer tiles."""
    d = np.abs(Q - c) - half
    below = Q < c
    d = np.where((below & first) | (~below & last), 0.0, d)
    return np.clip(1.0 - np.maximum(d, 0.0) / (0.5 * TILE_MARGIN), 0.0, 1.0).prod(axis=1)


def robust_weights(P, E, w, smoothing: float, *, rounds: int = 3, min_sigma: float = MIN_SIGMA) -> np.ndarray:
    """Weights of the windows for the spline after ``rounds`` of Tukey reweighting: ``w``
    times ``(1 − (r / cσ)²)²`` for ``r < cσ``, else 0, with ``r`` the distance of a window's
    residual from the spline through all, ``σ = max(1.4826 · median r, min_sigma)``, ``c = 4.685``
    (a smoothing spline is not robust by itself: one wrong window bends it)."""
    wt = np.asarray(w, dtype=np.float64).copy()
    for _ in range(rounds):
        use = wt > 0
        if use.sum() < 4:
            break
        lam = smoothing * wt[use].mean() / wt[use]
        r = np.hypot(*(E - _spline(P[use], E[use], lam, P)).T)
        sigma = max(1.4826 * float(np.median(r[use])), min_sigma)
        u = r / (TUKEY_C * sigma)
        new = np.where(u < 1, w * (1 - u ** 2) ** 2, 0.0)
        if np.array_equal(new > 0, use) and np.allclose(new, wt, rtol=1e-3, atol=1e-9):
            wt = new
            break
        wt = new
    return wt


def fit_field(model, xy, shift, reliability, *, width: int, height: int, spacing: float, smoothing: float = 1.0,
              step: int = 16, robust: bool = True):
    """The field of the module docstring from the windows ``xy`` (N, 2) with measured ``shift``
    (N, 2) and ``reliability`` (N,) > 0, and the global ``model`` (p → q).

    Returns ``(DisplacementField, weights (N,))``: with ``robust``, windows whose residual
    disagrees with the spline through the others get weight 0 (:func:`robust_weights`)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    E = xy + np.asarray(shift, dtype=np.float64).reshape(-1, 2) - model.forward(xy)
    w = np.asarray(reliability, dtype=np.float64)
    P = xy / spacing
    if robust and len(xy) >= 4:
        w = robust_weights(P, E, w, float(smoothing))
    use = w > 0
    lam = float(smoothing) * w[use].mean() / w[use] if use.any() else w[use]
    X, Y = _nodes(width, height, step)
    Q = np.stack([X.ravel(), Y.ravel()], axis=1)
    s = _spline(P[use], E[use], lam, Q / spacing) if use.any() else np.zeros((len(Q), 2))
    dist, _ = cKDTree(xy[use]).query(Q) if use.any() else (np.full(len(Q), np.inf), None)
    r = np.maximum(dist / spacing - 2.0, 0.0) / 2.0
    s *= np.exp(-r ** 2)[:, None]
    D = model.forward(Q) - Q + s
    return DisplacementField(D.T.reshape(2, *X.shape), int(step), int(width), int(height), model), w
