"""The steps of least-squares matching (:func:`fotogeo.matching.lsm_many`), one function each.

The model, its linearisation and the precision are stated in :mod:`fotogeo.matching.lsm`
(Gruen 1985): ``f(dx, dy) + v = r0 + r1 · g(a0 + a1·dx + a2·dy, b0 + b1·dx + b2·dy)``,
Gauss-Markov ``l + v = A·δ`` with ``P = I``, ``σ0² = vᵀPv / (n − u)``. The order:

1. :func:`prepare_windows` — templates of the reference and their pixel offsets;
2. :class:`LsmState` ``.start`` — start values from the approximations;
3. :func:`iterate`, until no point is left iterating or ``max_iterations``:
   :func:`_resample_search` → :func:`_window_and_gradients` → :func:`_start_radiometry`
   (first iteration) → :func:`_design` → :func:`_normal_equations` → :func:`_solve` →
   :func:`_damp` → :func:`_precision` → :func:`_correlation` → :func:`_iteration_status`;
4. :func:`final_status` — the converged points' correlation and σ checks.

Statuses are the words of :mod:`fotogeo.matching.status`; a point leaves the iteration
as soon as its status is set.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..pixels import from_centre, to_centre
from .interpolation import sample
from .status import (
    CONVERGED,
    DIVERGED,
    FLAT,
    LOW_CORRELATION,
    LOW_SIGNAL,
    MAX_ITERATIONS,
    NODATA,
    SHIFT_BEYOND_WINDOW,
    SINGULAR,
    WINDOW_OUTSIDE,
)

#: The eight parameters of the affine + radiometric model, in this order.
PARAMETERS = ("a0", "a1", "a2", "b0", "b1", "b2", "r0", "r1")
#: A window is flat when its grey-value σ is at most this times its largest |value| (at least 1).
_FLAT = 1e-6
#: Condition number of the diagonally scaled normal matrix from which it counts as singular.
_MAX_CONDITION = 1e12


@dataclass(frozen=True)
class TemplateWindows:
    """The reference side of a batch, fixed over the iterations.

    ``DX``, ``DY`` (N, m²): offsets from ``ref_xy`` of the centres of the ``m x m`` grid,
    ``m = 2h + 3`` (the window plus a one-pixel margin for central differences); ``dx``,
    ``dy`` (N, n): the same for the ``n = (2h+1)²`` window pixels only; ``f`` (N, n): the
    template grey values; ``fstd`` (N,): their standard deviation.
    """

    DX: np.ndarray
    DY: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    f: np.ndarray
    fstd: np.ndarray
    m: int


def prepare_windows(f_img: np.ndarray, P: np.ndarray, h: int, status: np.ndarray) -> TemplateWindows:
    """Templates of ``f_img`` around the points ``P`` (N, 2) and their pixel offsets.

    The template is the (2h+1)² pixels centred on the pixel containing ``ref_xy``, not
    resampled; (dx, dy) are their centres' offsets from ``ref_xy`` itself. Sets ``status``
    of points whose template leaves the image, holds nodata or is flat (σ ≤ 1e-6 · max|f|).
    """
    k = np.arange(-h - 1, h + 2)
    KX, KY = np.meshgrid(k, k)
    pix = np.floor(P).astype(np.int64)          # (col, row) of the pixel containing ref_xy
    frac = P - from_centre(pix)                 # ref_xy relative to that pixel's centre
    DX = KX.ravel()[None, :] - frac[:, :1]      # (N, m²) offsets incl. the margin
    DY = KY.ravel()[None, :] - frac[:, 1:]
    inner = np.zeros(KX.shape, bool)
    inner[1:-1, 1:-1] = True
    inner = inner.ravel()
    Hf, Wf = f_img.shape
    f_in = (pix[:, 0] - h >= 0) & (pix[:, 1] - h >= 0) & (pix[:, 0] + h < Wf) & (pix[:, 1] + h < Hf)
    status[~f_in] = WINDOW_OUTSIDE
    cols = np.clip(pix[:, :1] + KX[1:-1, 1:-1].ravel(), 0, Wf - 1)
    rows = np.clip(pix[:, 1:] + KY[1:-1, 1:-1].ravel(), 0, Hf - 1)
    f = f_img[rows, cols]
    status[(status == "") & np.isnan(f).any(axis=1)] = NODATA
    scale = np.maximum(np.nanmax(np.abs(f), axis=1, initial=0.0), 1.0)
    fstd = np.nanstd(f, axis=1)
    status[(status == "") & ~(fstd > _FLAT * scale)] = FLAT
    return TemplateWindows(DX, DY, DX[:, inner], DY[:, inner], f, fstd, len(k))


@dataclass
class LsmState:
    """What the iteration updates, one row per point: ``par`` (N, 8) in :data:`PARAMETERS`
    order, ``status`` ("" while iterating), ``iterations``, ``sigma0``, ``covariance`` of
    (a0, b0), ``rho`` (correlation), ``prev_delta`` (the last step, for damping)."""

    par: np.ndarray
    status: np.ndarray
    iterations: np.ndarray
    sigma0: np.ndarray
    covariance: np.ndarray
    rho: np.ndarray
    prev_delta: np.ndarray

    @classmethod
    def start(cls, Q: np.ndarray, J0: np.ndarray, status: np.ndarray) -> "LsmState":
        """Start values: shift at the approximations ``Q``, affine terms from ``J0``, the
        radiometry unknown (NaN) until the first resampled window (:func:`_start_radiometry`)."""
        n_pts = len(Q)
        par = np.zeros((n_pts, len(PARAMETERS)))
        par[:, 0], par[:, 3] = Q[:, 0], Q[:, 1]
        par[:, 1], par[:, 2], par[:, 4], par[:, 5] = J0[:, 0, 0], J0[:, 0, 1], J0[:, 1, 0], J0[:, 1, 1]
        par[:, 7] = np.nan
        return cls(par, status, np.zeros(n_pts, dtype=np.int64), np.full(n_pts, np.nan),
                   np.full((n_pts, 2, 2), np.nan), np.full(n_pts, np.nan), np.zeros_like(par))


@dataclass(frozen=True)
class LsmProblem:
    """The fixed inputs of the iteration (see :func:`fotogeo.matching.lsm_many`); ``free``: indices of the
    free parameters; ``ia``, ``ib``: positions of a0 and b0 among them; ``step_scale``:
    parameter → px at the window edge."""

    g_img: np.ndarray
    win: TemplateWindows
    Q: np.ndarray
    J0: np.ndarray
    free: np.ndarray
    ia: int
    ib: int
    n_obs: int
    step_scale: np.ndarray
    interpolation: str
    tolerance: float
    max_shift: float


def _resample_search(g_img, p, DX, DY, interpolation: str):
    """The search image resampled on the grids deformed by the affine parameters ``p``.

    ``x' = a0 + a1·dx + a2·dy``, ``y' = b0 + b1·dx + b2·dy`` at every offset of the
    margin grid. Returns ``(values (k, m²), outside (k,), nodata (k,))``: whether a grid
    leaves the image, or (inside) touches nodata.
    """
    xs = p[:, :1] + p[:, 1:2] * DX + p[:, 2:3] * DY
    ys = p[:, 3:4] + p[:, 4:5] * DX + p[:, 5:6] * DY
    sc = to_centre(np.stack([xs, ys], axis=-1))
    gfull, inside = sample(g_img, sc[..., 0], sc[..., 1], interpolation)
    outside = ~inside.all(axis=1)
    nodata = ~outside & np.isnan(gfull).any(axis=1)
    return gfull, outside, nodata


def _window_and_gradients(gfull: np.ndarray, m: int, n_obs: int):
    """``g⁰`` on the window and its central differences ``∂g⁰/∂dx``, ``∂g⁰/∂dy`` (k, n)
    from the resampled ``m x m`` margin grid."""
    G = gfull.reshape(-1, m, m)
    g = G[:, 1:-1, 1:-1].reshape(-1, n_obs)
    gdx = 0.5 * (G[:, 1:-1, 2:] - G[:, 1:-1, :-2]).reshape(-1, n_obs)
    gdy = 0.5 * (G[:, 2:, 1:-1] - G[:, :-2, 1:-1]).reshape(-1, n_obs)
    return g, gdx, gdy


def _start_radiometry(p: np.ndarray, g: np.ndarray, f: np.ndarray, fstd: np.ndarray) -> np.ndarray:
    """Radiometric start values where ``r1`` is still NaN (first iteration), in place in ``p``.

    Matches mean and standard deviation: ``r1 = σf / σg``, ``r0 = f̄ − r1·ḡ``. Returns the
    mask of those points whose resampled window is flat (``r1`` then starts from ``σf``).
    """
    first = np.isnan(p[:, 7])
    flat_window = np.zeros(len(p), bool)
    if first.any():
        gs = g[first].std(axis=1)
        flat = ~(gs > _FLAT * np.maximum(np.abs(g[first]).max(axis=1), 1.0))
        gs = np.where(flat, 1.0, gs)
        p[first, 7] = fstd[first] / gs
        p[first, 6] = f[first].mean(axis=1) - p[first, 7] * g[first].mean(axis=1)
        flat_window[np.nonzero(first)[0][flat]] = True
    return flat_window


def _design(p, g, gdx, gdy, dx, dy, f, free):
    """Design matrix ``A`` (k, n, u) and reduced observations ``l = f − r0 − r1·g⁰`` (k, n).

    Gradients in search coordinates: ``(gx, gy)ᵀ = J⁻ᵀ (∂g⁰/∂dx, ∂g⁰/∂dy)ᵀ`` with
    ``J = [[a1, a2], [b1, b2]]``; ``A = [r1·gx, r1·gx·dx, r1·gx·dy, r1·gy, r1·gy·dx,
    r1·gy·dy, 1, g⁰]``, restricted to the ``free`` columns.
    """
    a1, a2, b1, b2 = p[:, 1:2], p[:, 2:3], p[:, 4:5], p[:, 5:6]
    det = a1 * b2 - a2 * b1
    gx = (b2 * gdx - b1 * gdy) / det
    gy = (-a2 * gdx + a1 * gdy) / det
    r0, r1 = p[:, 6:7], p[:, 7:8]
    A = np.stack([r1 * gx, r1 * gx * dx, r1 * gx * dy, r1 * gy, r1 * gy * dx, r1 * gy * dy,
                  np.ones_like(g), g], axis=-1)[:, :, free]
    return A, f - r0 - r1 * g


def _normal_equations(A: np.ndarray, ell: np.ndarray):
    """``N = AᵀPA``, ``b = AᵀPl`` (``P = I``) and the mask of singular ``N``: a zero column,
    or a condition number of the diagonally scaled ``N`` of at least ``_MAX_CONDITION``."""
    N = np.einsum("kni,knj->kij", A, A)
    b = np.einsum("kni,kn->ki", A, ell)
    diag = np.sqrt(np.abs(np.einsum("kii->ki", N)))
    with np.errstate(divide="ignore", invalid="ignore"):
        Ns = N / diag[:, :, None] / diag[:, None, :]
        cond = np.linalg.cond(np.where(np.isfinite(Ns), Ns, 0.0))
    singular = ~(np.isfinite(cond) & (cond < _MAX_CONDITION)) | ~(diag > 0).all(axis=1)
    return N, b, singular


def _solve(A, ell, N, b, free):
    """``δ = N⁻¹b`` (as (k, 8), zero for fixed parameters), ``N⁻¹`` and the residuals ``v = Aδ − l``."""
    Ninv = np.linalg.inv(N)
    delta = np.zeros((len(N), len(PARAMETERS)))
    delta[:, free] = np.einsum("kij,kj->ki", Ninv, b)
    v = np.einsum("kni,ki->kn", A, delta[:, free]) - ell
    return delta, Ninv, v


def _damp(delta: np.ndarray, prev_delta: np.ndarray, step_scale: np.ndarray) -> None:
    """Halve, in place, a geometric step that reverses the previous one (negative scalar
    product in px at the window edge): Gauss-Newton overshoot, e.g. when the window is
    resampled at a scale > 1."""
    osc = np.einsum("ki,ki->k", delta * step_scale, prev_delta * step_scale) < 0
    delta[osc] *= 0.5


def _precision(v: np.ndarray, Ninv: np.ndarray, n_obs: int, n_par: int, ia: int, ib: int):
    """``σ0 = sqrt(vᵀPv / (n − u))`` and the covariance ``σ0²·N⁻¹`` of (a0, b0), (k, 2, 2)."""
    s02 = np.einsum("kn,kn->k", v, v) / (n_obs - n_par)
    return np.sqrt(s02), s02[:, None, None] * Ninv[:, [[ia, ia], [ib, ib]], [[ia, ib], [ia, ib]]]


def _correlation(f: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Correlation coefficient of each template row of ``f`` with the window row of ``g``."""
    fc = f - f.mean(axis=1, keepdims=True)
    gc = g - g.mean(axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (fc * gc).sum(1) / np.sqrt((fc * fc).sum(1) * (gc * gc).sum(1))


def _iteration_status(p, delta, Q, J0, step_scale, tolerance: float, max_shift: float) -> np.ndarray:
    """Status after a step: ``""`` (go on), converged (step < ``tolerance`` px), shift
    beyond window (farther than ``max_shift`` from ``Q``) or diverged (non-finite, gain ≤ 0,
    or an affine determinant outside [0.5, 2] times that of the approximation ``J0``)."""
    step = np.abs(delta * step_scale).max(axis=1)
    ratio = (p[:, 1] * p[:, 5] - p[:, 2] * p[:, 4]) / np.linalg.det(J0)
    diverged = ~np.isfinite(p).all(axis=1) | ~((ratio > 0.5) & (ratio < 2.0)) | ~(p[:, 7] > 0)
    moved = np.hypot(p[:, 0] - Q[:, 0], p[:, 3] - Q[:, 1]) > max_shift
    st = np.full(len(p), "", dtype=object)
    st[step < tolerance] = CONVERGED
    st[moved] = SHIFT_BEYOND_WINDOW
    st[diverged] = DIVERGED
    return st


def iterate(pb: LsmProblem, s: LsmState, it: int) -> bool:
    """Iteration ``it`` of the Gauss-Markov model for every point still iterating (status
    ``""``), updating ``s``; False when no point is left to iterate."""
    act = np.nonzero(s.status == "")[0]
    if act.size == 0:
        return False
    p = s.par[act]
    gfull, outside, nodata = _resample_search(pb.g_img, p, pb.win.DX[act], pb.win.DY[act], pb.interpolation)
    s.status[act[outside]] = WINDOW_OUTSIDE
    s.status[act[nodata]] = NODATA
    keep = ~(outside | nodata)
    act, p, gfull = act[keep], p[keep], gfull[keep]
    if act.size == 0:
        return False
    s.iterations[act] = it
    g, gdx, gdy = _window_and_gradients(gfull, pb.win.m, pb.n_obs)
    f = pb.win.f[act]
    s.status[act[_start_radiometry(p, g, f, pb.win.fstd[act])]] = FLAT
    A, ell = _design(p, g, gdx, gdy, pb.win.dx[act], pb.win.dy[act], f, pb.free)
    N, b, singular = _normal_equations(A, ell)
    singular &= s.status[act] == ""
    s.status[act[singular]] = SINGULAR
    live = s.status[act] == ""
    act, p, A, ell, N, b, f, g = act[live], p[live], A[live], ell[live], N[live], b[live], f[live], g[live]
    if act.size == 0:
        return False
    delta, Ninv, v = _solve(A, ell, N, b, pb.free)
    _damp(delta, s.prev_delta[act], pb.step_scale)
    s.prev_delta[act] = delta
    p = p + delta
    s.par[act] = p
    s.sigma0[act], s.covariance[act] = _precision(v, Ninv, pb.n_obs, len(pb.free), pb.ia, pb.ib)
    s.rho[act] = _correlation(f, g)
    s.status[act] = _iteration_status(p, delta, pb.Q[act], pb.J0[act], pb.step_scale, pb.tolerance,
                                      pb.max_shift)
    return True


def final_status(status: np.ndarray, rho: np.ndarray, cov: np.ndarray, min_correlation: float,
                  max_sigma: float) -> np.ndarray:
    """Close ``status`` in place: still iterating → max iterations; converged but correlated
    below ``min_correlation`` → low correlation, or σx or σy above ``max_sigma`` → low
    signal. Returns (σx, σy) (N, 2) from the covariance."""
    status[status == ""] = MAX_ITERATIONS
    status[(status == CONVERGED) & ~(rho >= min_correlation)] = LOW_CORRELATION
    sig = np.sqrt(np.stack([cov[:, 0, 0], cov[:, 1, 1]], axis=1))
    status[(status == CONVERGED) & ~(sig.max(axis=1) <= max_sigma)] = LOW_SIGNAL
    return sig
