"""Reduced normal equations of the bundle adjustment (array layer).

Unknowns are split into the *camera side* ``a`` (6 exterior-orientation increments per frame,
``δC`` and ``δθ``, then the free interior parameters shared by all frames) and the *points*
``b_i`` (3 per ground point). With the observation Jacobians ``J = [J_c  J_p]``, the weights
``P`` and the residuals ``v = f(x) − l`` the normal equations ``N δ = −Jᵀ P v`` have the
arrow-head form (Triggs et al. (2000) §6; Yastıklı's bundle block adjustment)::

    | U   W | |δa|     |g_a|        U = Σ J_cᵀ P J_c + priors          (dense, nc × nc)
    | Wᵀ  V | |δb| = − |g_b|        V = blockdiag(V_i), V_i = Σ J_pᵀ P J_p + control weights (3 × 3)
                                     W_a = J_c,aᵀ P_a J_p,a             (one nc × 3 block per observation)

Eliminating the points (Schur complement) leaves the reduced camera system::

    S = U − Σ_i W_i V_i⁻¹ W_iᵀ,    S δa = −(g_a − Σ_i W_i V_i⁻¹ g_b,i),
    δb_i = −V_i⁻¹ (g_b,i + W_iᵀ δa)

where ``W_i`` is the ``nc × 3`` column of point ``i``. All the ``W_i`` side by side form one
sparse ``nc × 3P`` matrix ``W`` (``W_a`` at the rows of observation ``a``'s frame and the
interior, the columns of its point; observations of one point sum on the interior rows), and
``Y = W·blockdiag(V⁻¹)`` has the same pattern, so ``Σ_i W_i V_i⁻¹ W_iᵀ = Y Wᵀ`` is one sparse
product. Levenberg–Marquardt damping multiplies the diagonals of ``U`` and ``V`` by ``1 + λ``.

The inverse of ``N`` in blocks (precision and redundancy numbers) follows from ``S⁻¹``::

    Σ_aa = S⁻¹,   Σ_ab,i = −T_i V_i⁻¹,   Σ_bb,i = V_i⁻¹ + V_i⁻¹ W_iᵀ T_i V_i⁻¹,   T_i = S⁻¹ W_i

(only the rows of ``T_i`` of the frames that observe point ``i`` are needed: one ``(6 + k) × 3``
block per observation); ``S⁻¹ W`` is formed for chunks of points so the memory stays bounded.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CHUNK = 20000


@dataclass(frozen=True)
class Structure:
    """Which frame and point each observation belongs to (observations sorted by point)."""

    frame: np.ndarray  # (n,)
    point: np.ndarray  # (n,) non-decreasing
    n_frames: int
    n_points: int
    free_interior: np.ndarray  # indices into INTERIOR_NAMES
    starts: np.ndarray  # (P,) first observation of each point
    counts: np.ndarray  # (P,) observations per point (≥ 1)
    by_frame: tuple  # observation indices per frame
    index: np.ndarray  # (n, 6 + k) camera-side unknowns of each observation
    indptr: np.ndarray  # the fixed pattern of the sparse Wᵀ (CSR, 3P × nc): row starts,
    indices: np.ndarray  # column indices,
    eo_pos: np.ndarray  # positions of the EO entries of W_a (n, 6, 3) in its data,
    int_pos: np.ndarray  # positions of the interior entries of W_i (P, k, 3)

    @property
    def n_camera(self) -> int:
        return 6 * self.n_frames + len(self.free_interior)

    def camera_index(self, obs=None) -> np.ndarray:
        """``(n, 6 + k)`` camera-side unknown indices of observations (EO of its frame, then interior)."""
        return self.index if obs is None else self.index[obs]


def make_structure(frame, point, n_frames: int, n_points: int, free_interior) -> Structure:
    """The :class:`Structure` of observations sorted by ``point``, then ``frame`` (every point observed).

    The sparse ``Wᵀ`` (``3P × nc``, CSR) has a fixed pattern: row ``3i + j`` holds, for each
    observation ``a`` of point ``i`` (frames ascending), the 6 entries ``W_a[:6, j]`` at the columns
    of its frame's orientation, then the ``k`` interior entries ``Σ_a W_a[6:, j]``."""
    frame = np.asarray(frame, dtype=np.intp)
    point = np.asarray(point, dtype=np.intp)
    n = len(point)
    counts = np.bincount(point, minlength=n_points)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    by_frame = tuple(np.flatnonzero(frame == j) for j in range(n_frames))
    free = np.asarray(free_interior, dtype=np.intp)
    k = len(free)
    index = np.concatenate([6 * frame[:, None] + np.arange(6),
                            np.broadcast_to(6 * n_frames + np.arange(k), (n, k))], axis=1)
    row_len = np.repeat(6 * counts + k, 3)
    indptr = np.concatenate([[0], np.cumsum(row_len)])
    row0 = indptr[:-1].reshape(n_points, 3)  # start of row 3i + j
    within = np.arange(n) - starts[point]  # rank of the observation in its point
    eo_pos = row0[point][:, None, :] + 6 * within[:, None, None] + np.arange(6)[None, :, None]
    int_pos = row0[:, None, :] + 6 * counts[:, None, None] + np.arange(k)[None, :, None]
    indices = np.empty(indptr[-1], dtype=np.int32 if 6 * n_frames + k < 2 ** 31 else np.int64)
    indices[eo_pos] = (6 * frame[:, None, None] + np.arange(6)[None, :, None])
    indices[int_pos] = 6 * n_frames + np.arange(k)[None, :, None]
    return Structure(frame, point, n_frames, n_points, free, starts, counts, by_frame, index, indptr, indices,
                     eo_pos, int_pos)


def sparse_transposed(st: Structure, blocks: np.ndarray):
    """The sparse ``3P × nc`` CSR matrix ``Wᵀ`` of per-observation blocks ``(n, 6 + k, 3)``
    (module docstring; the pattern is :class:`Structure`'s)."""
    from scipy.sparse import csr_matrix
    data = np.empty(len(st.indices))
    data[st.eo_pos] = blocks[:, :6, :]
    if len(st.free_interior):
        data[st.int_pos] = np.add.reduceat(blocks[:, 6:, :], st.starts, axis=0)
    m = csr_matrix((data, st.indices, st.indptr), shape=(3 * st.n_points, st.n_camera))
    m.has_sorted_indices = True
    return m


@dataclass(frozen=True)
class Normals:
    U: np.ndarray  # (nc, nc)
    g_a: np.ndarray  # (nc,)
    V: np.ndarray  # (P, 3, 3)
    g_b: np.ndarray  # (P, 3)
    W: np.ndarray  # (n, nc_obs, 3)


def assemble(st: Structure, J_c, J_p, v, p, *, U_prior, g_prior, V_prior, g_b_prior) -> Normals:
    """Normal-equation blocks from the observation Jacobians ``J_c`` ``(n, 2, 6 + k)``, ``J_p``
    ``(n, 2, 3)``, residuals ``v`` ``(n, 2)`` and weights ``p`` ``(n,)``; the prior terms (the
    diagonal weights of exterior-orientation priors and control coordinates and their
    gradients) are added as they are."""
    nc = st.n_camera
    U = np.diag(U_prior).astype(np.float64)
    g_a = np.array(g_prior, dtype=np.float64)
    for j, sel in enumerate(st.by_frame):  # one dense product per frame
        if sel.size == 0:
            continue
        ix = st.camera_index(sel[:1])[0]
        Jf = J_c[sel].reshape(-1, J_c.shape[2])
        pw = np.repeat(p[sel], 2)
        U[np.ix_(ix, ix)] += Jf.T @ (Jf * pw[:, None])
        g_a[ix] += Jf.T @ (pw * v[sel].reshape(-1))
    pv = p[:, None] * v
    JpT = J_p.transpose(0, 2, 1)
    V = np.add.reduceat((JpT * p[:, None, None]) @ J_p, st.starts, axis=0)
    V[:, [0, 1, 2], [0, 1, 2]] += V_prior
    g_b = np.add.reduceat((JpT @ pv[:, :, None])[:, :, 0], st.starts, axis=0) + g_b_prior
    W = (J_c.transpose(0, 2, 1) * p[:, None, None]) @ J_p
    assert U.shape == (nc, nc)
    return Normals(U, g_a, V, g_b, W)


def inverse3(M: np.ndarray) -> np.ndarray:
    """Inverses of ``(P, 3, 3)`` matrices by the adjugate, ``M⁻¹ = adj(M) / det(M)`` (vectorised)."""
    a, b, c = M[:, 0, 0], M[:, 0, 1], M[:, 0, 2]
    d, e, f = M[:, 1, 0], M[:, 1, 1], M[:, 1, 2]
    g, h, i = M[:, 2, 0], M[:, 2, 1], M[:, 2, 2]
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * A + b * B + c * C
    if not np.all(np.abs(det) > 0):
        raise np.linalg.LinAlgError("singular 3x3 point block")
    adj = np.stack([A, c * h - b * i, b * f - c * e, B, a * i - c * g, c * d - a * f,
                    C, b * g - a * h, a * e - b * d], axis=1).reshape(-1, 3, 3)
    return adj / det[:, None, None]


def _damped(M, lam, axis_diag):
    if lam == 0:
        return M
    M = M.copy()
    d = np.diagonal(M, axis1=axis_diag[0], axis2=axis_diag[1])
    add = lam * np.maximum(d, 1e-12)
    if M.ndim == 2:
        M[np.diag_indices(M.shape[0])] += add
    else:
        M[:, [0, 1, 2], [0, 1, 2]] += add
    return M


def reduced_system(st: Structure, nm: Normals, lam: float = 0.0):
    """``(S, rhs, V⁻¹)`` of the reduced camera system with damping ``λ`` (module docstring)."""
    Vinv = inverse3(_damped(nm.V, lam, (1, 2)))
    Wt = sparse_transposed(st, nm.W)
    Yt = sparse_transposed(st, nm.W @ Vinv[st.point])  # (W_a V_i⁻¹)ᵀ
    S = _damped(nm.U, lam, (0, 1)) - (Yt.T @ Wt).toarray()
    rhs = -(nm.g_a - Yt.T @ nm.g_b.reshape(-1))
    return 0.5 * (S + S.T), rhs, Vinv


def back_substitute(st: Structure, nm: Normals, Vinv, delta_a) -> np.ndarray:
    """Point increments ``δb_i = −V_i⁻¹ (g_b,i + W_iᵀ δa)`` ``(P, 3)``."""
    Wd = (sparse_transposed(st, nm.W) @ delta_a).reshape(-1, 3)
    return -(Vinv @ (nm.g_b + Wd)[:, :, None])[:, :, 0]


def observation_pairs(st: Structure, lo: int, hi: int):
    """``(a, b)``: every ordered pair of observations of the same point, for the observations
    ``lo:hi`` as ``a`` (grouped by ``a``, each observation paired with itself too)."""
    a_obs = np.arange(lo, hi)
    reps = st.counts[st.point[a_obs]]
    a = np.repeat(a_obs, reps)
    first = np.repeat(np.cumsum(reps) - reps, reps)
    b = st.starts[st.point[a]] + (np.arange(len(a)) - first)
    return a, b


def inverse_blocks(st: Structure, nm: Normals, S_inv, Vinv):
    """``(T, Σ_bb)``: per observation ``T_a = (S⁻¹ W_i)[idx_a] = Σ_b S⁻¹[idx_a, idx_b] W_b`` over the
    observations ``b`` of its point, ``(n, 6 + k, 3)``, and per point
    ``Σ_bb,i = V_i⁻¹ + V_i⁻¹ (W_iᵀ S⁻¹ W_i) V_i⁻¹`` ``(P, 3, 3)`` (module docstring)."""
    idx = st.index
    T = np.empty(nm.W.shape)
    n = len(st.point)
    step = max(1, CHUNK // 4)
    for lo in range(0, n, step):
        hi = min(n, lo + step)
        a, b = observation_pairs(st, lo, hi)
        contrib = S_inv[idx[a][:, :, None], idx[b][:, None, :]] @ nm.W[b]
        bounds = np.flatnonzero(np.r_[True, a[1:] != a[:-1]])
        T[lo:hi] = np.add.reduceat(contrib, bounds, axis=0)  # every observation pairs with itself
    WT = np.add.reduceat(nm.W.transpose(0, 2, 1) @ T, st.starts, axis=0)
    S_bb = Vinv + Vinv @ WT @ Vinv
    return T, S_bb


def observation_cofactors(st: Structure, J_c, J_p, S_inv, T, Vinv, S_bb) -> np.ndarray:
    """``Q_a = J_a N⁻¹ J_aᵀ`` ``(n, 2, 2)``, the cofactor of each adjusted observation, from the
    blocks of ``N⁻¹`` (chunked over observations)."""
    n = len(st.point)
    Q = np.empty((n, 2, 2))
    for lo in range(0, n, CHUNK):
        s = slice(lo, min(n, lo + CHUNK))
        idx = st.camera_index(np.arange(s.start, s.stop))
        Jc, Jp, pt = J_c[s], J_p[s], st.point[s]
        Saa = S_inv[idx[:, :, None], idx[:, None, :]]
        Sab = -(T[s] @ Vinv[pt])
        cross = Jc @ Sab @ Jp.transpose(0, 2, 1)
        Q[s] = (Jc @ Saa @ Jc.transpose(0, 2, 1) + cross + cross.transpose(0, 2, 1)
                + Jp @ S_bb[pt] @ Jp.transpose(0, 2, 1))
    return Q
