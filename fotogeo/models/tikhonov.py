"""Tikhonov-regularised least squares with λ chosen by cross-validation, from one decomposition.

``min ‖A p − l‖² + λ² ‖L p‖²`` over a logarithmic grid ``λ = σ_max(A) · 10^k``; the criterion
(leave-one-out PRESS with the one-standard-error rule, or GCV) and why are documented in
:mod:`fotogeo.models.rfm`, the user of this module. :func:`tikhonov_cv` evaluates every λ
of the grid from one generalised SVD; :func:`tikhonov_at` solves at one given λ.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .spatial import design_diagnostics
from .threads import blas_threads_for

#: log10(λ / σ_max) candidates
_LOG_GRID = np.arange(-8.0, 1.01, 0.25)
#: cross-validation criterion for λ: "loo" (PRESS) or "gcv"
CRITERION = "loo"
#: take the largest λ whose criterion is ≤ min + SE_FACTOR · (its standard error) + TOLERANCE · min
TOLERANCE = 0.05
SE_FACTOR = 1.0
#: criteria within this relative difference are equal (their last bits depend on the BLAS at hand): among equal
#: minima the larger λ is the minimum, and a criterion equal to the limit is within it
TIE = 1e-9


def tikhonov_cv(A, l, Lmat, grid=_LOG_GRID, accept=None, row_blocks=None):
    """Solve ``min ‖A p − l‖² + λ² ‖Lmat p‖²`` with λ chosen by cross-validation over ``grid``.

    ``CRITERION`` "loo" (default) uses leave-one-out PRESS, "gcv" generalised cross-validation;
    ``accept(p)`` may reject candidate solutions. ``row_blocks`` (optional): groups of rows
    that are zero outside a few columns (one per image axis), as ``(rows, columns)`` pairs,
    factorised separately (:class:`_BlockDesign`).

    One decomposition serves every λ (the generalised SVD of the pair ``(A, L)``; Hansen
    1998, "Rank-deficient and discrete ill-posed problems", sec. 2.1): with ``R`` any
    factor of ``RᵀR = AᵀA`` (the R of a QR factorisation) and the QR factorisation
    ``[R; σ_max L] = [Q₁; Q₂] Rₛ`` (``Rₛ`` square, invertible when the pair has full column
    rank), the SVD ``Q₁ = U diag(c) Wᵀ`` gives ``Q₂ᵀQ₂ = W diag(1 − c²) Wᵀ``, so that with
    ``μ = λ / σ_max``, ``dⱼ = cⱼ² + μ² (1 − cⱼ²)`` and ``B = A Rₛ⁻¹ W``::

        p(λ) = Rₛ⁻¹ W (Bᵀ l / d),    A p(λ) = B (Bᵀ l / d),    Hᵢᵢ(λ) = Σⱼ Bᵢⱼ² / dⱼ

    (``Hᵢᵢ`` the leverages of the influence matrix). Residuals and leverages of all λ are
    then two matrix products instead of a factorisation per λ — the same solutions and the
    same choice as a solve per λ (tested). A λ is skipped where ``[R; λ L]`` is
    numerically singular (condition above 1e13; it equals that of ``diag(√d) Wᵀ Rₛ``,
    bounded by ``cond(Rₛ) · max √d / min √d``, computed only when that bound is inconclusive).

    Returns ``(p, λ, λ/σ_max, tr H, (cond, rank))``, the last pair that of :func:`~fotogeo.
    models.spatial.design_diagnostics` of ``A``. Raises :class:`ModelError` if no λ gives a
    solution. Runs on one BLAS thread (:mod:`~fotogeo.models.threads`): the same λ and
    coefficients whatever the caller's thread setting.
    """
    with blas_threads_for(*np.shape(A)):
        return _tikhonov_cv(A, l, Lmat, grid, accept, row_blocks)


def _tikhonov_cv(A, l, Lmat, grid, accept, row_blocks):
    design = _BlockDesign(A, row_blocks)
    sv = np.linalg.svd(design.R, compute_uv=False)
    smax = float(sv[0]) if sv.size else 0.0
    if not np.isfinite(smax) or smax == 0:
        raise ModelError("RFM: the design matrix is zero or not finite; check the points")
    diagnostics = design_diagnostics(design.R) if len(sv) == A.shape[1] else design_diagnostics(A)
    m = A.shape[1]
    stacked = np.vstack([design.R, smax * Lmat])
    cands = []
    if stacked.shape[0] >= m:
        Qs, Rs = np.linalg.qr(stacked)
        rs_sv = np.linalg.svd(Rs, compute_uv=False)
        if rs_sv[-1] > rs_sv[0] * 1e-15:
            _, c, Wt = np.linalg.svd(Qs[:design.R.shape[0]], full_matrices=True)
            c = np.minimum(np.concatenate([c, np.zeros(m - len(c))]), 1.0)  # c = 0 beyond the rank of R
            to_p = np.linalg.solve(Rs, Wt.T)
            B = design.times(to_p)
            gsvd = (c, 1.0 - c * c, B, to_p, Wt @ Rs, rs_sv[0] / rs_sv[-1])
            cands = _candidates(l, grid, gsvd, accept)
    if not cands:
        raise ModelError("RFM: no regularisation parameter gives a solution; the points leave the first-"
                         "order terms undetermined (e.g. all at one height); add points or use a 2-D model")
    best = cands[choose(np.array([c[0] for c in cands]), np.array([c[5] for c in cands]),
                        np.array([c[2] for c in cands]))]
    return best[1], best[2] * smax, best[3], best[4], diagnostics


def choose(score, se, lam) -> int:
    """The index of the λ chosen (module constants): the largest ``lam`` whose ``score`` is ≤ the minimum plus
    ``SE_FACTOR`` times the minimum's standard error ``se`` plus ``TOLERANCE`` times the minimum; scores within
    :data:`TIE` of each other are equal, the larger λ being the minimum among equal ones — so that the choice
    does not hang on the last bits of a BLAS.

    >>> int(choose(np.array([2.0, 1.0, 1.0 + 1e-12, 3.0]), np.array([0.1, 0.1, 0.2, 0.1]), np.array([1, 2, 3, 4])))
    2
    """
    gmin = float(np.min(score))
    if not np.isfinite(gmin):
        return int(np.argmax(lam))
    equal = np.flatnonzero(score <= gmin + TIE * abs(gmin))
    imin = equal[np.argmax(lam[equal])]
    limit = gmin + se[imin] * SE_FACTOR + TOLERANCE * gmin
    within = np.flatnonzero(score <= limit + TIE * abs(limit))
    return int(within[np.argmax(lam[within])])


def tikhonov_at(A, l, Lmat, lambda_rel, row_blocks=None):
    """The solution of ``min ‖A p − l‖² + λ² ‖Lmat p‖²`` at ``λ = lambda_rel · σ_max(A)``, or
    None where ``[A; λ Lmat]`` is numerically singular (one QR of ``[A l; λ Lmat 0]``); one BLAS thread."""
    with blas_threads_for(*np.shape(A)):
        return _tikhonov_at(A, l, Lmat, lambda_rel, row_blocks)


def _tikhonov_at(A, l, Lmat, lambda_rel, row_blocks):
    m = A.shape[1]
    R = _BlockDesign(A, row_blocks, l).R
    smax = np.linalg.svd(R[:, :m], compute_uv=False)[0]
    stacked = np.vstack([R, np.column_stack([lambda_rel * smax * Lmat, np.zeros(len(Lmat))])])
    if stacked.shape[0] <= m:
        return None
    Rf = np.linalg.qr(stacked, mode="r")[:m]
    diag = np.abs(np.diag(Rf[:, :m]))
    if not np.isfinite(smax) or smax == 0 or diag.min() <= diag.max() * 1e-13:
        return None
    return np.linalg.solve(Rf[:, :m], Rf[:, m])


class _BlockDesign:
    """A design matrix whose row blocks are each zero outside a few columns.

    ``row_blocks``: ``(rows, columns)`` pairs (slice, index array), or None for one block of
    all rows and columns. ``R`` stacks the QR factors of the blocks (restricted to their
    columns), so ``RᵀR = AᵀA``; with ``l`` given, ``R`` has one more column: the factor of
    ``[A l]``. ``times(M)`` is ``A @ M`` block by block. With the two image axes of the RFM
    as blocks, each factorisation is a quarter of one of the whole matrix.
    """

    def __init__(self, A, row_blocks=None, l=None):
        self.A = A
        self.parts = []
        factors = []
        m = A.shape[1]
        for rows, cols in row_blocks or [(slice(0, A.shape[0]), np.arange(m))]:
            sub = A[rows][:, cols]
            self.parts.append((rows, cols, sub))
            if l is not None:
                sub, cols = np.column_stack([sub, l[rows]]), np.append(cols, m)
            r = np.linalg.qr(sub, mode="r") if sub.shape[0] > sub.shape[1] else sub
            full = np.zeros((r.shape[0], m + (l is not None)))
            full[:, cols] = r
            factors.append(full)
        self.R = np.vstack(factors)

    def times(self, M):
        out = np.empty((self.A.shape[0], M.shape[1]))
        for rows, cols, sub in self.parts:
            out[rows] = sub @ M[cols]
        return out


def _candidates(l, grid, gsvd, accept):
    """``(criterion, p, μ, μ, tr H, standard error)`` for every accepted ``μ = 10^k`` of ``grid``."""
    c, s2, B, to_p, WtRs, rs_cond = gsvd
    n = len(l)
    mu = 10.0 ** np.asarray(grid, dtype=np.float64)
    den = c * c + (mu * mu)[:, None] * s2                     # (grid, m)
    g = np.sqrt(den)
    coef = (B.T @ l) / den
    P = coef @ to_p.T                                         # solutions, one row per λ
    fitted = coef @ B.T
    H = (1.0 / den) @ (B * B).T                               # leverages, one row per λ
    cands = []
    for i, k in enumerate(grid):
        if rs_cond * g[i].max() >= 1e13 * g[i].min():  # the bound is inconclusive: exact condition
            sv = np.linalg.svd(g[i][:, None] * WtRs, compute_uv=False)
            if sv[-1] <= sv[0] * 1e-13:
                continue
        if accept is not None and not accept(P[i]):
            continue
        res, hii = l - fitted[i], H[i]
        trH = float(hii.sum())
        if n - trH < 0.5 or hii.max() > 1 - 1e-9:
            crit, se = np.inf, 0.0  # no redundancy left: cross-validation undefined
        elif CRITERION == "loo":
            e2 = (res / (1 - hii)) ** 2
            crit, se = float(e2.sum()), float(np.sqrt(n) * e2.std())
        else:
            crit, se = n * float(res @ res) / (n - trH) ** 2, 0.0
        cands.append((crit, P[i], 10.0 ** k, 10.0 ** k, trH, se))
    return cands
