"""Solving the reduced camera system by a banded Cholesky factorisation (array layer).

The reduced camera matrix ``S`` (:mod:`fotogeo.orientation.bundle_normals`) couples two frames
only when they share points: in a block of strips a frame meets its neighbours along its strip
and in the strips beside it. Ordered by the reverse Cuthill–McKee permutation of that frame
graph (Cuthill & McKee 1969, :func:`scipy.sparse.csgraph.reverse_cuthill_mckee`), the frame
part ``A`` of ``S`` is a band matrix of half-bandwidth ``6 b + 5`` (``b`` frames), factorised by
LAPACK's band Cholesky (``pbtrf`` through :func:`scipy.linalg.cholesky_banded`) in
``O(n b²)`` instead of ``O(n³)`` (Triggs et al. (2000) §6.3: the reduced system of a bundle
adjustment is sparse). The ``k`` free interior parameters couple with every frame; they
border the band and are eliminated by a small Schur complement::

    S = | A   B |     A y = [B, r_a],   Sc x_c = r_c − Bᵀ A⁻¹ r_a,   x_a = A⁻¹ (r_a − B x_c)
        | Bᵀ  C |     Sc = C − Bᵀ A⁻¹ B

A band wider than a third of the frame unknowns gains nothing: ``S`` is then factorised dense.
A matrix that is not positive definite raises :class:`numpy.linalg.LinAlgError`, as the dense
factorisation does.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve, cho_solve_banded, cholesky_banded


def frame_band(pair_frames: np.ndarray, n_frames: int) -> tuple[np.ndarray, int]:
    """``(order, b)``: the reverse Cuthill–McKee order of the frames sharing points (``pair_frames``
    ``(G, 2)``) and the half-bandwidth ``b`` in frames it gives."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee
    if len(pair_frames) == 0:
        return np.arange(n_frames), 0
    j, l = pair_frames[:, 0], pair_frames[:, 1]
    graph = csr_matrix((np.ones(2 * len(j)), (np.r_[j, l], np.r_[l, j])), shape=(n_frames, n_frames))
    order = np.asarray(reverse_cuthill_mckee(graph, symmetric_mode=True), dtype=np.intp)
    position = np.empty(n_frames, dtype=np.intp)
    position[order] = np.arange(n_frames)
    return order, int(np.max(np.abs(position[j] - position[l])))


def solve_reduced(S: np.ndarray, rhs: np.ndarray, order: np.ndarray, band: int) -> np.ndarray:
    """``S⁻¹ rhs`` (module docstring); ``order``, ``band`` from :func:`frame_band`."""
    fact = _band_cholesky(S, order, band)
    if fact is None:
        return cho_solve(cho_factor(S, check_finite=False), rhs, check_finite=False)
    p6, u, c = fact
    n_eo = len(p6)
    B, r_a = S[p6, n_eo:], rhs[p6]
    y = cho_solve_banded((c, False), np.column_stack([B, r_a]), check_finite=False)
    x = np.empty_like(rhs)
    if B.shape[1]:
        k = B.shape[1]
        x_c = cho_solve(cho_factor(S[n_eo:, n_eo:] - B.T @ y[:, :k], check_finite=False),
                        rhs[n_eo:] - B.T @ y[:, k], check_finite=False)
        x[n_eo:] = x_c
        x[p6] = y[:, k] - y[:, :k] @ x_c
    else:
        x[p6] = y[:, 0]
    return x


def _band_cholesky(S, order, band):
    """``(p6, u, c)``: the frame unknowns' order, the half-bandwidth and the band Cholesky factor of
    the frame part of ``S`` (LAPACK upper band storage), or None when the band is too wide."""
    n_eo = 6 * len(order)
    u = 6 * band + 5
    if u > n_eo // 3:
        return None
    p6 = (6 * order[:, None] + np.arange(6)).ravel()
    A = S[np.ix_(p6, p6)]
    ab = np.zeros((u + 1, n_eo))
    for d in range(u + 1):
        ab[u - d, d:] = np.diagonal(A, d)
    try:
        return p6, u, cholesky_banded(ab, lower=False, check_finite=False)
    except LinAlgError as e:
        raise np.linalg.LinAlgError(str(e)) from None


def selected_inverse(S: np.ndarray, order: np.ndarray, band: int) -> np.ndarray | None:
    """``S⁻¹`` on the band of ``S`` and the interior rows, other entries 0 — all that the precision,
    the correlations and the redundancy numbers read (the frame pairs sharing points lie in the
    band) — or None when the band is too wide (then ``S⁻¹`` is formed dense).

    The band of ``A⁻¹`` follows from its band Cholesky factor ``A = UᵀU`` by Takahashi's recurrence
    (Takahashi, Fagan & Chen 1973), row by row from the last:
    ``Z[i, i+1:i+u+1] = −l·Z[i+1:i+u+1, i+1:i+u+1]``, ``Z[i, i] = 1/U_ii² − l·Z[i, i+1:i+u+1]``,
    ``l = U[i, i+1:i+u+1] / U_ii`` (entries outside the band are never needed); the border
    (module docstring) adds ``A⁻¹B Sc⁻¹ BᵀA⁻¹`` on the band, ``−A⁻¹B Sc⁻¹`` and ``Sc⁻¹``."""
    fact = _band_cholesky(S, order, band)
    if fact is None:
        return None
    p6, u, c = fact
    n_eo = len(p6)
    U = np.zeros((n_eo, n_eo))
    for d in range(u + 1):
        U[np.arange(n_eo - d), np.arange(d, n_eo)] = c[u - d, d:]
    Z = np.zeros((n_eo, n_eo))
    for i in range(n_eo - 1, -1, -1):
        hi = min(n_eo, i + u + 1)
        l = U[i, i + 1:hi] / U[i, i]
        z = -(l @ Z[i + 1:hi, i + 1:hi])
        Z[i, i + 1:hi] = z
        Z[i + 1:hi, i] = z
        Z[i, i] = 1.0 / U[i, i] ** 2 - l @ z
    out = np.zeros_like(S)
    if len(S) > n_eo:
        B = S[p6, n_eo:]
        Y = cho_solve_banded((c, False), B, check_finite=False)  # A⁻¹ B
        Sc_inv = np.linalg.inv(S[n_eo:, n_eo:] - B.T @ Y)
        YS = Y @ Sc_inv
        for d in range(u + 1):
            i = np.arange(n_eo - d)
            corr = np.einsum("ik,ik->i", YS[i], Y[i + d])
            Z[i, i + d] += corr
            if d:
                Z[i + d, i] += corr
        out[n_eo:, n_eo:] = Sc_inv
        out[p6, n_eo:] = -YS
        out[n_eo:, p6] = -YS.T
    out[np.ix_(p6, p6)] = Z
    return out
