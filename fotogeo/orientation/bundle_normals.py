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

where ``W_i`` is the ``nc × 3`` column of point ``i``: the blocks ``W_a`` (6 × 3) of its
observations at their frames' rows and ``Σ_a W_a^int`` (k × 3) at the interior rows. The
6 × 6 block of frames ``j, l`` of ``Σ_i W_i V_i⁻¹ W_iᵀ`` is ``Σ Y_a W_bᵀ`` over the pairs of
observations ``a`` (frame ``j``) and ``b`` (frame ``l``) of one point, ``Y_a = W_a V_i⁻¹``: the
pairs are sorted by frame pair once per :class:`Structure` and each block is one matrix
product ``(6 × 3q)·(3q × 6)`` over its ``q`` pairs (the sparse pattern of ``S`` is that of
the frames sharing points; ``S`` is kept dense, ``6m + k`` square). Levenberg–Marquardt
damping multiplies the diagonals of ``U`` and ``V`` by ``1 + λ``.

The blocks of ``N⁻¹`` (precision, redundancy numbers) are in :mod:`fotogeo.orientation.bundle_inverse`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bundle_banded import frame_band



@dataclass(frozen=True)
class Structure:
    """Which frame and point each observation belongs to (observations sorted by point), and the
    pairs of observations of one point in two frames ``j < l``, sorted by ``(j, l)``."""

    frame: np.ndarray  # (n,)
    point: np.ndarray  # (n,) non-decreasing
    n_frames: int
    n_points: int
    free_interior: np.ndarray  # indices into INTERIOR_NAMES
    starts: np.ndarray  # (P,) first observation of each point
    counts: np.ndarray  # (P,) observations per point (≥ 1)
    by_frame: tuple  # observation indices per frame
    index: np.ndarray  # (n, 6 + k) camera-side unknowns of each observation
    frame_order: np.ndarray  # (n,) observations sorted by frame
    frame_bounds: np.ndarray  # (m + 1,) their frames' starts in frame_order
    pair_a: np.ndarray  # (q,) first observation of each pair (frame j)
    pair_b: np.ndarray  # (q,) second observation (frame l > j)
    pair_frames: np.ndarray  # (G, 2) the frame pairs (j, l) sharing points
    pair_bounds: np.ndarray  # (G + 1,) their starts in pair_a / pair_b
    band_order: np.ndarray  # (m,) frames in the order that makes S a band (bundle_banded)
    band_frames: int  # the half-bandwidth of S in that order, in frames

    @property
    def n_camera(self) -> int:
        return 6 * self.n_frames + len(self.free_interior)

    def camera_index(self, obs=None) -> np.ndarray:
        """``(n, 6 + k)`` camera-side unknown indices of observations (EO of its frame, then interior)."""
        return self.index if obs is None else self.index[obs]


def make_structure(frame, point, n_frames: int, n_points: int, free_interior) -> Structure:
    """The :class:`Structure` of observations sorted by ``point``, then ``frame`` (every point observed)."""
    frame = np.asarray(frame, dtype=np.intp)
    point = np.asarray(point, dtype=np.intp)
    n = len(point)
    counts = np.bincount(point, minlength=n_points)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    frame_order = np.argsort(frame, kind="stable")
    frame_bounds = np.searchsorted(frame[frame_order], np.arange(n_frames + 1))
    by_frame = tuple(frame_order[frame_bounds[j]:frame_bounds[j + 1]] for j in range(n_frames))
    free = np.asarray(free_interior, dtype=np.intp)
    k = len(free)
    index = np.concatenate([6 * frame[:, None] + np.arange(6),
                            np.broadcast_to(6 * n_frames + np.arange(k), (n, k))], axis=1)
    a, b = observation_pairs_of(point, starts, counts, 0, n)
    keep = frame[a] < frame[b]
    a, b = a[keep], b[keep]
    key = frame[a] * n_frames + frame[b]
    order = np.argsort(key, kind="stable")
    a, b, key = a[order], b[order], key[order]
    bounds = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if len(key) else np.zeros(0, np.intp)
    pair_frames = np.column_stack([key[bounds] // n_frames, key[bounds] % n_frames])
    band_order, band_frames = frame_band(pair_frames, n_frames)
    return Structure(frame, point, n_frames, n_points, free, starts, counts, by_frame, index, frame_order,
                     frame_bounds, a, b, pair_frames, np.r_[bounds, len(key)], band_order, band_frames)


@dataclass(frozen=True)
class Normals:
    U: np.ndarray  # (nc, nc)
    g_a: np.ndarray  # (nc,)
    V: np.ndarray  # (P, 3, 3)
    g_b: np.ndarray  # (P, 3)
    W: np.ndarray  # (n, nc_obs, 3)
    WT: np.ndarray  # (n, 3, nc_obs): the same blocks transposed, contiguous


def assemble(st: Structure, J_c, J_p, v, p, *, U_prior, g_prior, V_prior, g_b_prior) -> Normals:
    """Normal-equation blocks from the observation Jacobians ``J_c`` ``(n, 2, 6 + k)``, ``J_p``
    ``(n, 2, 3)``, residuals ``v`` ``(n, 2)`` and weights ``p`` ``(n,)``; the prior terms (the
    diagonal weights of exterior-orientation priors and control coordinates and their
    gradients) are added as they are."""
    nc = st.n_camera
    U = np.diag(U_prior).astype(np.float64)
    g_a = np.array(g_prior, dtype=np.float64)
    nk = J_c.shape[2]
    pJc = J_c * p[:, None, None]  # (n, 2, 6 + k)
    Jf, pJf, vf = J_c[st.frame_order], pJc[st.frame_order], v[st.frame_order]  # by frame: runs are views
    for j, (s, e) in enumerate(zip(st.frame_bounds[:-1].tolist(), st.frame_bounds[1:].tolist())):
        if e == s:
            continue
        ix = st.index[st.frame_order[s]]
        pJ = pJf[s:e].reshape(-1, nk)
        U[np.ix_(ix, ix)] += Jf[s:e].reshape(-1, nk).T @ pJ
        g_a[ix] += pJ.T @ vf[s:e].reshape(-1)
    WT = J_p.transpose(0, 2, 1) @ pJc
    W = WT.transpose(0, 2, 1)
    pJp = J_p * p[:, None, None]
    V = np.add.reduceat(pJp.transpose(0, 2, 1) @ J_p, st.starts, axis=0)
    V[:, [0, 1, 2], [0, 1, 2]] += V_prior
    gobs = pJp[:, 0] * v[:, 0, None] + pJp[:, 1] * v[:, 1, None]
    g_b = np.add.reduceat(gobs, st.starts, axis=0) + g_b_prior
    assert U.shape == (nc, nc)
    return Normals(U, g_a, V, g_b, W, WT)


def _adjugate_inverse(M):
    a, b, c = M[:, 0, 0], M[:, 0, 1], M[:, 0, 2]
    d, e, f = M[:, 1, 0], M[:, 1, 1], M[:, 1, 2]
    g, h, i = M[:, 2, 0], M[:, 2, 1], M[:, 2, 2]
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * A + b * B + c * C
    adj = np.stack([A, c * h - b * i, b * f - c * e, B, a * i - c * g, c * d - a * f,
                    C, b * g - a * h, a * e - b * d], axis=1).reshape(-1, 3, 3)
    return adj, det


def inverse3(M: np.ndarray) -> np.ndarray:
    """Inverses of ``(P, 3, 3)`` point blocks by the adjugate, ``M⁻¹ = adj(M) / det(M)`` (vectorised).

    A block singular to machine precision (``|det| ≤ 10⁻¹³ ∏ diag``: the rays of a wrong match
    meeting at infinity, so the point's depth is not observed) is inverted with a ridge of
    ``10⁻¹⁰ tr(M)/3``: its unobserved direction, in which its Jacobians vanish, takes no part in
    the reduced system and gets a huge variance. A block that is not finite raises."""
    adj, det = _adjugate_inverse(M)
    weak = ~(np.abs(det) > 1e-13 * np.abs(M[:, 0, 0] * M[:, 1, 1] * M[:, 2, 2]))
    if weak.any():
        if not np.isfinite(M[weak]).all():
            raise np.linalg.LinAlgError("singular 3x3 point block")
        ridge = 1e-10 * np.maximum(np.trace(M[weak], axis1=1, axis2=2) / 3, 1e-300)
        adj[weak], det[weak] = _adjugate_inverse(M[weak] + ridge[:, None, None] * np.eye(3))
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


def per_frame(st: Structure, x: np.ndarray) -> np.ndarray:
    """Sums of per-observation values ``x`` ``(n, ...)`` over each frame's observations ``(m, ...)``."""
    flat = x.reshape(len(x), -1)
    sums = [np.bincount(st.frame, weights=flat[:, c], minlength=st.n_frames) for c in range(flat.shape[1])]
    return np.stack(sums, axis=1).reshape((st.n_frames,) + x.shape[1:])


def schur_product(st: Structure, WT: np.ndarray, YT: np.ndarray) -> np.ndarray:
    """``Σ_i W_i V_i⁻¹ W_iᵀ`` ``(nc, nc)`` from ``W_aᵀ`` and ``Y_aᵀ = V_i⁻¹ W_aᵀ`` ``(n, 3, 6 + k)``: the
    frame blocks one product per frame and per frame pair (module docstring; for a run of
    observations ``Σ_a Y_a W_bᵀ = rows(Yᵀ)ᵀ·rows(Wᵀ)``, ``rows = [s:e].reshape(-1, 6 + k)`` a view), the
    interior rows from the per-point sums ``Σ_a W_a^int``."""
    m, nc, nk = st.n_frames, st.n_camera, WT.shape[2]
    out = np.zeros((nc, nc))
    Yf, Wf = YT[st.frame_order], WT[st.frame_order]
    for j, (s, e) in enumerate(zip(st.frame_bounds[:-1].tolist(), st.frame_bounds[1:].tolist())):
        out[6 * j:6 * j + 6, 6 * j:6 * j + 6] = (Yf[s:e].reshape(-1, nk).T @ Wf[s:e].reshape(-1, nk))[:6, :6]
    Ya, Wb = YT[st.pair_a], WT[st.pair_b]
    for (j, l), s, e in zip(st.pair_frames.tolist(), st.pair_bounds[:-1].tolist(), st.pair_bounds[1:].tolist()):
        blk = (Ya[s:e].reshape(-1, nk).T @ Wb[s:e].reshape(-1, nk))[:6, :6]
        out[6 * j:6 * j + 6, 6 * l:6 * l + 6] = blk
        out[6 * l:6 * l + 6, 6 * j:6 * j + 6] = blk.T
    if len(st.free_interior):
        Yi = np.add.reduceat(YT[:, :, 6:], st.starts, axis=0)  # (Σ_a W_a^int V_i⁻¹)ᵀ per point, (P, 3, k)
        Wi = np.add.reduceat(WT[:, :, 6:], st.starts, axis=0)
        cross = per_frame(st, Yi[st.point].transpose(0, 2, 1) @ WT[:, :, :6]).transpose(1, 0, 2).reshape(-1, 6 * m)
        out[6 * m:, :6 * m] = cross
        out[:6 * m, 6 * m:] = cross.T
        out[6 * m:, 6 * m:] = np.einsum("pck,pcl->kl", Yi, Wi)
    return out


def reduced_system(st: Structure, nm: Normals, lam: float = 0.0):
    """``(S, rhs, V⁻¹)`` of the reduced camera system with damping ``λ`` (module docstring)."""
    Vinv = inverse3(_damped(nm.V, lam, (1, 2)))
    YT = Vinv[st.point] @ nm.WT  # Y_aᵀ = V_i⁻¹ W_aᵀ
    S = _damped(nm.U, lam, (0, 1)) - schur_product(st, nm.WT, YT)
    y = np.einsum("acr,ac->ar", YT, nm.g_b[st.point])  # Y_a g_b,i per observation
    t = np.concatenate([per_frame(st, y[:, :6]).reshape(-1), y[:, 6:].sum(axis=0)])
    return 0.5 * (S + S.T), -(nm.g_a - t), Vinv


def back_substitute(st: Structure, nm: Normals, Vinv, delta_a) -> np.ndarray:
    """Point increments ``δb_i = −V_i⁻¹ (g_b,i + W_iᵀ δa)`` ``(P, 3)``."""
    Wd = np.einsum("arc,ar->ac", nm.W, delta_a[st.index])
    Wd = np.add.reduceat(Wd, st.starts, axis=0)
    return -(Vinv @ (nm.g_b + Wd)[:, :, None])[:, :, 0]


def observation_pairs_of(point, starts, counts, lo: int, hi: int):
    """``(a, b)``: every ordered pair of observations of the same point, for the observations
    ``lo:hi`` (sorted by point) as ``a`` (grouped by ``a``, each observation paired with itself too)."""
    a_obs = np.arange(lo, hi)
    reps = counts[point[a_obs]]
    a = np.repeat(a_obs, reps)
    first = np.repeat(np.cumsum(reps) - reps, reps)
    b = starts[point[a]] + (np.arange(len(a)) - first)
    return a, b


def observation_pairs(st: Structure, lo: int, hi: int):
    """:func:`observation_pairs_of` the observations of ``st``."""
    return observation_pairs_of(st.point, st.starts, st.counts, lo, hi)
