"""Blocks of the inverse normal matrix of the bundle adjustment: precision and redundancy numbers (array layer).

With the reduced camera matrix ``S`` of :mod:`fotogeo.orientation.bundle_normals` and its
inverse, the inverse of the full normal matrix ``N`` follows in blocks (Triggs et al. (2000) §6)::

    Σ_aa = S⁻¹,   Σ_ab,i = −T_i V_i⁻¹,   Σ_bb,i = V_i⁻¹ + V_i⁻¹ W_iᵀ T_i V_i⁻¹,   T_i = S⁻¹ W_i

Only the rows of ``T_i`` at the unknowns of the frames that observe point ``i`` (and the
interior rows) are needed: one ``(6 + k) × 3`` block ``T_a`` per observation. For a point seen
in ``c`` frames ``F_i`` they are ``S⁻¹[F_i, F_i]·W_i^eo + S⁻¹[F_i, int]·W_i^int`` — one
``6c × 6c`` product per point, batched over the points of one ray count, the ``6 × 6`` frame
blocks of ``S⁻¹`` gathered whole — and the interior rows ``S⁻¹[int, F_i]·W_i^eo +
S⁻¹[int, int]·W_i^int``, the same for every observation of the point. Only these blocks of
``S⁻¹`` are read: the frame pairs that share points and the interior rows. Points are taken in
chunks, so memory stays bounded.

The cofactor of an adjusted observation is ``Q_a = J_a N⁻¹ J_aᵀ`` with ``J_a = [J_c,a  J_p,a]``:
``J_c Σ_aa[idx_a] J_cᵀ + 2 sym(J_c Σ_ab J_pᵀ) + J_p Σ_bb,i J_pᵀ``, where ``Σ_aa[idx_a]`` is the
diagonal ``(6 + k)`` block of the observation's frame (with the interior), gathered per frame.
"""
from __future__ import annotations

import numpy as np

from .bundle_normals import Normals, Structure

CHUNK = 400_000  # doubles of gathered 6 × 6 blocks per batch (3.2 MB)


def _frame_blocks(S_inv: np.ndarray, m: int) -> np.ndarray:
    """The ``6 × 6`` frame blocks of ``S⁻¹`` as a contiguous ``(m, m, 6, 6)`` array."""
    return np.ascontiguousarray(S_inv[:6 * m, :6 * m].reshape(m, 6, m, 6).transpose(0, 2, 1, 3))


def inverse_blocks(st: Structure, nm: Normals, S_inv, Vinv):
    """``(T, Σ_bb)``: per observation ``T_a = (S⁻¹ W_i)[idx_a]`` ``(n, 6 + k, 3)`` and per point
    ``Σ_bb,i = V_i⁻¹ + V_i⁻¹ (W_iᵀ S⁻¹ W_i) V_i⁻¹`` ``(P, 3, 3)`` (module docstring)."""
    m, k = st.n_frames, len(st.free_interior)
    E = _frame_blocks(S_inv, m)
    S_fi = S_inv[:6 * m, 6 * m:].reshape(m, 6, k)
    S_ii = S_inv[6 * m:, 6 * m:]
    W = nm.W
    W_int = np.add.reduceat(W[:, 6:], st.starts, axis=0)  # (P, k, 3)
    T = np.empty(W.shape)
    WTW = np.empty((st.n_points, 3, 3))  # W_iᵀ S⁻¹ W_i
    for c in np.unique(st.counts):
        pts = np.flatnonzero(st.counts == c)
        step = max(1, CHUNK // (36 * c * c))
        for lo in range(0, len(pts), step):
            ids = pts[lo:lo + step]
            q = len(ids)
            obs = st.starts[ids][:, None] + np.arange(c)  # (q, c)
            F = st.frame[obs]
            G = E[F[:, :, None], F[:, None, :]].transpose(0, 1, 3, 2, 4).reshape(q, 6 * c, 6 * c)
            Wg = W[obs, :6].reshape(q, 6 * c, 3)
            Te = G @ Wg
            WTW[ids] = 0.0
            if k:
                Sf = S_fi[F].reshape(q, 6 * c, k)
                Te += Sf @ W_int[ids]
                Z = Sf.transpose(0, 2, 1) @ Wg + S_ii @ W_int[ids]  # (q, k, 3): the interior rows
                T[obs, 6:] = Z[:, None]
                WTW[ids] = W_int[ids].transpose(0, 2, 1) @ Z
            WTW[ids] += Wg.transpose(0, 2, 1) @ Te
            T[obs, :6] = Te.reshape(q, c, 6, 3)
    S_bb = Vinv + Vinv @ WTW @ Vinv
    return T, S_bb


def observation_cofactors(st: Structure, J_c, J_p, S_inv, T, Vinv, S_bb) -> np.ndarray:
    """``Q_a = J_a N⁻¹ J_aᵀ`` ``(n, 2, 2)``, the cofactor of each adjusted observation (module
    docstring), chunked over observations."""
    m, k = st.n_frames, len(st.free_interior)
    D = np.empty((m, 6 + k, 6 + k))  # diagonal frame blocks of S⁻¹ with the interior rows
    for j in range(m):
        ix = np.r_[6 * j:6 * j + 6, 6 * m:6 * m + k]
        D[j] = S_inv[np.ix_(ix, ix)]
    n = len(st.point)
    Q = np.empty((n, 2, 2))
    step = max(1, CHUNK // (6 + k) ** 2)
    for lo in range(0, n, step):
        s = slice(lo, min(n, lo + step))
        Jc, Jp, pt = J_c[s], J_p[s], st.point[s]
        Sab = -(T[s] @ Vinv[pt])
        cross = Jc @ Sab @ Jp.transpose(0, 2, 1)
        Q[s] = (Jc @ D[st.frame[s]] @ Jc.transpose(0, 2, 1) + cross + cross.transpose(0, 2, 1)
                + Jp @ S_bb[pt] @ Jp.transpose(0, 2, 1))
    return Q
