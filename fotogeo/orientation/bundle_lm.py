"""Levenberg–Marquardt iterations of the bundle adjustment (array layer).

The objective, in the block's local Cartesian frame, is the weighted sum of squares

    E = Σ_a p_a |v_a|² + Σ_i Σ_axis w_i,axis (X_i − X_i,control)² + Σ_j (priors on C_j and θ_j)

with ``v_a`` the image residual (px; :mod:`fotogeo.orientation.bundle_jacobian`), ``p_a = ρ_a / σ_a²``
(a priori σ of the observation in px, ρ_a the robust weight), control coordinates observed
with weights ``1/σ²`` per axis, and optional priors on the exterior orientation (GNSS/INS),
the angle prior as the rotation vector ``log(R_priorᵀ R)``. Each iteration solves the reduced
normal equations (:mod:`fotogeo.orientation.bundle_normals`, factorised as a band:
:mod:`fotogeo.orientation.bundle_banded`) with damping ``λ`` (Marquardt
1963: the diagonals scaled by ``1 + λ``), accepts the step if ``E`` decreases (``λ ← λ/10``) or
rejects it (``λ ← 4λ``; a step putting a point behind a camera is rejected too), and stops when
``E`` changes by less than ``tol`` relatively (1e-7: ``E`` is a χ², so the parameters then move
by far less than their σ), or ``λ`` exceeds ``1e10`` (no step decreases ``E``: a minimum).

With a :class:`Huber` cost (the robust phase) ``p_a |v_a|²`` is replaced by ``σ̂_a² ρ(e_a)``,
``e_a = |v_a| √p_a / σ̂_a``, Huber's (1964) ``ρ(e) = e²`` for ``e ≤ k`` and ``2ke − k²`` beyond, and skipped
(constant) where ``|v_a| √p_a`` exceeds ``s_a`` — a redescending M-estimator (Hampel 1974): a gross error
has no pull on the solution at all. Every linearisation weighs the observations ``p_a min(1, k/e_a)``,
``10⁻⁶ p_a`` where skipped, at the current state (iteratively reweighted Gauss–Newton; the step descends on
``ρ``, and a skipped observation comes back once the solution reaches it). ``σ̂_a`` and ``s_a`` are fixed
for the run (:func:`fotogeo.orientation.bundle.adjust_block` sets ``s_a`` once, from the residuals at the
approximate orientation). Huber's bounded influence alone is not enough: on a rendered 3 × 5 block 20
observations of 385–635 px at the start (0.6 %; wrong matches) pulled the minimum of the Huber cost 180 m
and 14° away from the truth — the adjustment reached it from the truth too — while skipping them
converges to 1.4 m in 5 iterations.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import LinAlgError

from ..errors import ModelError
from . import bundle_jacobian as bj
from .bundle_banded import solve_reduced
from .bundle_normals import Normals, Structure, assemble, back_substitute, reduced_system


@dataclass(frozen=True)
class Problem:
    """One adjustment problem: the active observations (sorted by point) and their weights."""

    st: Structure
    pixel: np.ndarray  # (n, 2) measured, corner convention
    p0: np.ndarray  # (n,) 1 / σ² of the observations (px⁻²)
    obs_ids: np.ndarray  # (n,) indices into the block's observations
    point_ids: np.ndarray  # (P,) indices into the block's points
    ctrl_w: np.ndarray  # (P, 3) weights of the control coordinates (0: not observed)
    ctrl_xyz: np.ndarray  # (P, 3) local control coordinates
    eo_w: np.ndarray  # (m, 6) weights of the EO priors (0: none)
    eo_C: np.ndarray  # (m, 3)
    eo_R: np.ndarray  # (m, 3, 3)
    scale: np.ndarray  # (2,) pixels per unit of focal length


@dataclass(frozen=True)
class State:
    R: np.ndarray  # (m, 3, 3) OpenCV camera axes -> local world
    C: np.ndarray  # (m, 3) local
    X: np.ndarray  # (P, 3) local, the problem's points
    interior: np.ndarray  # (8,) INTERIOR_NAMES


def residuals(pb: Problem, s: State) -> tuple[np.ndarray, np.ndarray]:
    """Image residuals ``v = projected − measured`` ``(n, 2)`` and the camera depths ``z`` ``(n,)``."""
    c = bj.camera_coordinates(s.R, s.C, s.X, pb.st.frame, pb.st.point)
    return bj.project_camera(c, s.interior, pb.scale) - pb.pixel, c[:, 2]


def eo_prior_residual(pb: Problem, s: State) -> np.ndarray:
    ang = bj.log_rotation(np.einsum("mji,mjk->mik", pb.eo_R, s.R))
    return np.concatenate([s.C - pb.eo_C, ang], axis=1)


@dataclass(frozen=True)
class Huber:
    """The skipped Huber cost of the image residuals: threshold ``k``, scale ``scale`` and skip limit ``skip``
    of ``|v| √p`` (each a number or one per observation; module docstring)."""

    k: float
    scale: np.ndarray
    skip: np.ndarray

    def normalised(self, v: np.ndarray, p: np.ndarray) -> np.ndarray:
        return np.linalg.norm(v, axis=1) * np.sqrt(p) / self.scale

    def weights(self, v: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``p·min(1, k/e)``, ``10⁻⁶ p`` where skipped: the weights of the linearisation at residuals ``v``."""
        e = self.normalised(v, p)
        return p * np.where(e * self.scale > self.skip, 1e-6, np.where(e > self.k, self.k / np.maximum(e, 1e-300), 1.0))

    def cost(self, v: np.ndarray, p: np.ndarray) -> float:
        e = np.minimum(self.normalised(v, p), self.skip / self.scale)
        return float(np.sum(self.scale ** 2 * (e * e - np.maximum(e - self.k, 0.0) ** 2)))  # 2ke − k² beyond k


def cost(pb: Problem, s: State, p: np.ndarray, huber: Huber | None = None) -> float:
    """The objective ``E`` (module docstring; Huber's when ``huber`` is given); ``inf`` when a point is
    behind a camera."""
    v, z = residuals(pb, s)
    if np.any(z <= 0) or not np.isfinite(v).all():
        return float("inf")
    e = huber.cost(v, p) if huber is not None else float(np.sum(p * np.sum(v * v, axis=1)))
    e += float(np.sum(pb.ctrl_w * (s.X - pb.ctrl_xyz) ** 2))
    if pb.eo_w.any():
        e += float(np.sum(pb.eo_w * eo_prior_residual(pb, s) ** 2))
    return e


def linearise(pb: Problem, s: State, p: np.ndarray):
    """``(Normals, J_c, J_p, v)`` at ``s`` with observation weights ``p``."""
    st = pb.st
    px, J_eo, J_p, J_int, _ = bj.project_with_jacobians(s.R, s.C, s.X, st.frame, st.point, s.interior, pb.scale,
                                                        additional=bool(np.any(st.free_interior >= bj.N_PHYSICAL)))
    v = px - pb.pixel
    J_c = np.concatenate([J_eo, J_int[:, :, st.free_interior]], axis=2)
    k = len(st.free_interior)
    U_prior = np.concatenate([pb.eo_w.reshape(-1), np.zeros(k)])
    g_prior = np.concatenate([(pb.eo_w * eo_prior_residual(pb, s)).reshape(-1), np.zeros(k)]) \
        if pb.eo_w.any() else np.zeros(st.n_camera)
    nm = assemble(st, J_c, J_p, v, p, U_prior=U_prior, g_prior=g_prior, V_prior=pb.ctrl_w,
                  g_b_prior=pb.ctrl_w * (s.X - pb.ctrl_xyz))
    return nm, J_c, J_p, v


def apply_step(pb: Problem, s: State, delta_a: np.ndarray, delta_b: np.ndarray) -> State:
    """The state moved by the increments (rotation multiplicatively, ``R ← R·exp([δθ]×)``)."""
    m = pb.st.n_frames
    d = delta_a[:6 * m].reshape(m, 6)
    interior = s.interior.copy()
    interior[pb.st.free_interior] += delta_a[6 * m:]
    return State(s.R @ bj.rodrigues(d[:, 3:]), s.C + d[:, :3], s.X + delta_b, interior)


def solve_step(pb: Problem, s: State, nm: Normals, lam: float) -> State | None:
    """The damped Gauss–Newton step, or None when the reduced system is not positive definite."""
    try:
        S, rhs, Vinv = reduced_system(pb.st, nm, lam)
        delta_a = solve_reduced(S, rhs, pb.st.band_order, pb.st.band_frames)
    except (LinAlgError, np.linalg.LinAlgError):
        return None
    delta_b = back_substitute(pb.st, nm, Vinv, delta_a)
    if not (np.isfinite(delta_a).all() and np.isfinite(delta_b).all()):
        return None
    return apply_step(pb, s, delta_a, delta_b)


@dataclass(frozen=True)
class LmInfo:
    iterations: int
    cost: float
    converged: bool


def levenberg_marquardt(pb: Problem, s: State, p: np.ndarray, *, max_iterations: int = 50,
                        tol: float = 1e-7, lam: float = 1e-4, progress=None,
                        huber: Huber | None = None) -> tuple[State, LmInfo]:
    """Minimise ``E`` from ``s`` (module docstring; Huber's cost with ``huber``); raises :class:`ModelError`
    when the start puts points behind a camera."""
    def normals(s):
        return linearise(pb, s, p if huber is None else huber.weights(residuals(pb, s)[0], p))[0]

    e = cost(pb, s, p, huber)
    if not np.isfinite(e):
        raise ModelError("bundle adjustment: with the approximate exterior orientation some points lie behind "
                         "their camera; check the orientation file (angles in degrees, PATB ω φ κ, heights)")
    it, converged = 0, False
    nm = normals(s)
    while it < max_iterations:
        it += 1
        if progress is not None:
            progress(it / max_iterations, f"bundle adjustment: iteration {it}, cost {e:.6g}")
        trial = solve_step(pb, s, nm, lam)
        e_new = cost(pb, trial, p, huber) if trial is not None else float("inf")
        if e_new <= e:
            small = e - e_new <= tol * max(e, 1e-300)
            s, e, lam = trial, e_new, max(lam / 10.0, 1e-12)
            if small:
                converged = True
                break
            nm = normals(s)
        else:
            lam *= 4.0
            if lam > 1e10:
                converged = True  # no decreasing step exists: at a minimum (or stuck: checked by the caller)
                break
    return s, LmInfo(it, e, converged)
