"""Robust estimation, data snooping and precision of the bundle adjustment (array layer).

*Reweighting* (Huber 1964): with the normalised residual of observation ``a``
``e_a = |v_a| √p_a / σ̂``, ``σ̂ = median(|v| √p) / 1.1774`` (the median of a 2-D Gaussian
residual's norm is ``σ √(2 ln 2)``), the robust weight is ``ρ_a = min(1, k / e_a)``.

*Data snooping* (Baarda 1968) with redundancy numbers in closed form (Förstner 1987): with
``Q_a = J_a N⁻¹ J_aᵀ`` the cofactor of the adjusted observation (from the blocks of ``N⁻¹``,
:func:`fotogeo.orientation.bundle_inverse.observation_cofactors`) the residual's cofactor is
``Q_vv,a = 1/p_a − diag Q_a`` per axis, the redundancy numbers ``r_a = p_a Q_vv,a`` (they sum
to the redundancy ``2n + n_control − u``) and the standardised residual
``w_a = |v_a| / (σ_t √Q_vv,a)`` with ``σ_t = max(σ̂₀, 1)``, ``σ̂₀² = E / (n_obs − u)``: Pope's τ
test when the observations fit worse than their a priori σ, Baarda's test with the known
``σ₀ = 1`` when they fit better — a residual within the σ its observation was given is never a
blunder (with σ̂₀ = 0.18 on the NGI pair the τ test culled tie observations of 0.04–0.15 px whose
LSM σ was 0.2 px). An axis whose redundancy number is below :data:`MIN_REDUNDANCY` is not
testable (its ``Q_vv`` is a difference of nearly equal numbers — the along-epipolar axis of a
2-ray point): its ``w`` is NaN. Control coordinates are tested the same way (``Q_vv = 1/w −
(Σ_bb,i)_axis``); a flagged control point is demoted (its coordinates no longer used, role
``rejected``) rather than its rays culled. ``w_a > 3.29`` (α = 0.1 %; a block's redundancy is
large enough for the normal quantile) flags observation ``a``; per point only the worst flagged observation is culled per
round (a flagged tie point left with < 3 rays is dropped whole), and the block is solved again.

*Precision*: ``σ₀² N⁻¹`` gives the a-posteriori covariance; for every free interior parameter
``k`` the multiple correlation with all other camera-side unknowns (points eliminated) is
``ϱ_k = √(1 − 1/(S_kk (S⁻¹)_kk))`` (``S`` the reduced camera matrix); ``ϱ_k`` close to 1 means
the block cannot tell the parameter from the exterior orientations (a free focal length
over flat ground against the flying heights) — unless the block determines it nevertheless:
its a-posteriori σ ``σ̂₀ √Q_kk`` times the RMS of ``|∂pixel/∂b_k|`` over the observations (``σ_px``,
what its uncertainty moves the image points by) within half a pixel, or the image σ ``σ̂₀ · median(1/√p)``
when larger (:data:`fotogeo.orientation.bundle_rules.DETERMINED_PX`). A
principal-point shift is a tilt of the camera but for terms of second order in the image
coordinates, which the decentering terms take only in part: its ϱ comes close to 1,
yet many rays determine it. A parameter correlated and imprecise is held fixed.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..models.precision import dense_inverse, determined_sqrt, unit_scaled
from . import bundle_jacobian as bj
from .bundle_lm import Huber, Problem, State, eo_prior_residual, cost, linearise
from .bundle_banded import selected_inverse
from .bundle_inverse import inverse_blocks, observation_cofactors
from .bundle_normals import reduced_system
from .bundle_variance import variance_components

CRITICAL_W = 3.29
#: a residual axis whose redundancy number is below this is not testable (``w`` NaN): an error there
#: shows as 1 % of itself (minimal detectable bias 41 σ) and ``Q_vv`` is rounding noise
MIN_REDUNDANCY = 0.01
RAYLEIGH_MEDIAN = float(np.sqrt(2 * np.log(2)))


def robust_scale(v: np.ndarray, p: np.ndarray) -> float:
    """``σ̂ = median(|v| √p) / 1.1774`` of image residuals ``v`` ``(n, 2)`` (module docstring)."""
    return max(float(np.median(np.linalg.norm(v, axis=1) * np.sqrt(p))) / RAYLEIGH_MEDIAN, 1e-12)


def huber_weights(v: np.ndarray, p: np.ndarray, k: float = 2.0) -> np.ndarray:
    """Robust weights ``ρ = min(1, k / e)`` of image residuals ``v`` ``(n, 2)`` (module docstring)."""
    e = np.linalg.norm(v, axis=1) * np.sqrt(p) / robust_scale(v, p)
    return np.where(e > k, k / np.maximum(e, 1e-300), 1.0)


def _image_residuals(pb: Problem, s: State) -> np.ndarray:
    return bj.project(s.R, s.C, s.X, pb.st.frame, pb.st.point, s.interior, pb.scale) - pb.pixel


def skipped_huber(pb: Problem, s: State, k: float, skip_c: float, skip=None) -> Huber:
    """The skipped Huber cost (:mod:`~fotogeo.orientation.bundle_lm`) at the scale of the residuals at ``s``,
    per observation the block's or its frame's when larger (a frame whose start is worse than the others' is
    not skipped whole); ``skip`` the limit of ``|v| √p`` [``skip_c`` scales, at least ``skip_c`` a-priori σ:
    as in data snooping, a residual within the σ its observation was given is never an error — on the NGI pair,
    started from registration (residuals σ̂ below the a priori σ), 10 σ̂ skipped 7 observations snooping
    accepts and moved the adjustment 3.6 m from the run started 20 m / 0.5° off]."""
    v = _image_residuals(pb, s)
    scale = np.full(pb.st.n_frames, robust_scale(v, pb.p0))
    for j in np.unique(pb.st.frame):
        sel = pb.st.frame == j
        scale[j] = max(scale[j], robust_scale(v[sel], pb.p0[sel]))
    scale = scale[pb.st.frame]
    return Huber(k, scale, skip_c * np.maximum(scale, 1.0) if skip is None else skip)


def skipped(pb: Problem, s: State, huber: Huber, keep: np.ndarray):
    """``(indices, e, v)``: the observations not in ``keep`` that ``huber`` skips at ``s`` (``|v| √p`` beyond
    ``huber.skip``: ``skip_c`` times the robust σ of the start), all normalised residuals and residuals.
    :func:`fotogeo.orientation.bundle.adjust_block` removes them before data snooping, which solves by least
    squares: a gross error left in pulls the block again (a rendered 3 × 5 block went from 1.4 m to a corner
    frame 270 m off)."""
    v = _image_residuals(pb, s)
    e = huber.normalised(v, pb.p0)
    return np.flatnonzero((e * huber.scale > huber.skip) & ~keep), e, v


@dataclass(frozen=True)
class Posterior:
    """A-posteriori statistics of one adjustment (module docstring)."""

    sigma0: float
    redundancy: int  # number of observations − unknowns
    S: np.ndarray  # reduced camera matrix (undamped)
    S_inv: np.ndarray  # its inverse (cofactors of the camera-side unknowns) on the band of S and the interior rows
    point_cofactor: np.ndarray  # (P, 3, 3)
    r: np.ndarray  # (n, 2) redundancy numbers
    w: np.ndarray  # (n, 2) standardised residuals (NaN: not testable)
    v: np.ndarray  # (n, 2) image residuals
    w_control: np.ndarray  # (P, 3) standardised residuals of the control coordinates (NaN elsewhere, not testable)
    groups: dict = field(default_factory=dict)  # σ̂ per observation group (fotogeo.orientation.bundle_variance)
    interior_px: np.ndarray = field(default_factory=lambda: np.zeros(0))  # RMS |∂pixel/∂b| of each free interior b
    image_sigma: float = float("nan")  # median a-priori σ of the image observations (px)


def _inverse(S: np.ndarray, st=None) -> np.ndarray:
    """``S⁻¹`` scaled to a unit diagonal first, a tiny ridge keeping a singular ``S`` invertible (the
    correlations of an undetermined parameter then come out as 1). With the block's band
    (``st``, :mod:`fotogeo.orientation.bundle_banded`) only its band and interior rows are formed
    — all that is read of it — by Takahashi's recurrence on the band Cholesky factor; otherwise
    (a wide band, or a matrix not positive definite) dense, by Cholesky factorisation (LAPACK
    ``potrf`` and ``potri``: a third of the work of a general inverse), falling back to the
    general (pseudo-)inverse (:mod:`fotogeo.models.precision`, the resection's too)."""
    Sn, d = unit_scaled(S)
    inv = None
    if st is not None:
        try:
            inv = selected_inverse(Sn, st.band_order, st.band_frames)
        except np.linalg.LinAlgError:
            inv = None
    if inv is None:
        inv = dense_inverse(Sn)
    return inv / d[:, None] / d[None, :]


def posterior(pb: Problem, s: State, p: np.ndarray) -> Posterior:
    """σ₀, the inverse blocks, redundancy numbers and standardised residuals at ``s``; σ̂ per observation group
    (:mod:`fotogeo.orientation.bundle_variance`)."""
    nm, J_c, J_p, v = linearise(pb, s, p)
    S, _, Vinv = reduced_system(pb.st, nm, 0.0)
    S_inv = _inverse(S, pb.st)
    T, S_bb = inverse_blocks(pb.st, nm, S_inv, Vinv)
    Q = observation_cofactors(pb.st, J_c, J_p, S_inv, T, Vinv, S_bb)
    n_obs = 2 * len(v) + int(np.count_nonzero(pb.ctrl_w)) + int(np.count_nonzero(pb.eo_w))
    u = pb.st.n_camera + 3 * pb.st.n_points
    dof = n_obs - u
    e = cost(pb, s, p)
    sigma0 = float(np.sqrt(e / dof)) if dof > 0 else float("nan")
    qvv = 1.0 / np.maximum(p, 1e-300)[:, None] - np.stack([Q[:, 0, 0], Q[:, 1, 1]], axis=1)
    qvv = np.maximum(qvv, 1e-12 / np.maximum(p, 1e-300)[:, None])
    r = p[:, None] * qvv
    s_t = max(sigma0, 1.0) if np.isfinite(sigma0) else 1.0
    w = np.where(r >= MIN_REDUNDANCY, np.abs(v) / (s_t * np.sqrt(qvv)), np.nan)
    ctrl = pb.ctrl_w > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        qc = np.where(ctrl, 1.0 / pb.ctrl_w - np.diagonal(S_bb, axis1=1, axis2=2), np.nan)
        r_c = qc * pb.ctrl_w
        w_c = np.abs(s.X - pb.ctrl_xyz) / (s_t * np.sqrt(np.maximum(qc, 1e-12 / np.maximum(pb.ctrl_w, 1e-300))))
    groups = variance_components(p, v, r, pb.ctrl_w, s.X - pb.ctrl_xyz, np.diagonal(S_bb, axis1=1, axis2=2),
                                 pb.eo_w, eo_prior_residual(pb, s), np.diag(S_inv))
    interior_px = np.sqrt(np.mean(np.sum(J_c[:, :, 6:] ** 2, axis=1), axis=0)) if len(v) else np.zeros(0)
    return Posterior(sigma0, dof, S, S_inv, S_bb, r, w, v, np.where(ctrl & (r_c >= MIN_REDUNDANCY), w_c, np.nan),
                     groups, interior_px, float(np.median(1.0 / np.sqrt(np.maximum(p, 1e-300)))) if len(p) else 1.0)


def largest_w(w: np.ndarray) -> np.ndarray:
    """The largest testable standardised residual of every row of ``w`` ``(n, k)``; NaN where no axis is
    testable.

    >>> largest_w(np.array([[np.nan, 2.0], [np.nan, np.nan]])).tolist()
    [2.0, nan]
    """
    return np.fmax.reduce(w, axis=1) if w.shape[1] else np.full(len(w), np.nan)


def worst_per_point(pb: Problem, w: np.ndarray, critical: float = CRITICAL_W, tie=None):
    """``(worst, with_point)``: indices (into the problem's observations) of the worst observation of
    each point whose standardised residual exceeds ``critical``, and of all the observations of the
    flagged tie and check points (``tie``: ``(P,)`` mask) that would keep fewer than 3 rays — with 2 rays the
    part of an error along the epipolar line has no redundancy, and in a near-collinear 3-ray
    point the w-tests of two rays are nearly equal, so the point is dropped rather than guessed."""
    wmax = np.nan_to_num(largest_w(w), nan=-np.inf)
    order = np.lexsort((-wmax, pb.st.point))  # by point, worst first
    first = np.r_[True, pb.st.point[order][1:] != pb.st.point[order][:-1]]
    cand = order[first]
    worst = np.sort(cand[wmax[cand] > critical])
    if tie is None:
        return worst, worst
    pts = pb.st.point[worst]
    gone = pts[tie[pts] & (pb.st.counts[pts] <= 3)]
    return worst, np.union1d(worst, np.flatnonzero(np.isin(pb.st.point, gone)))


def interior_correlations(pb: Problem, post: Posterior, frame_names, interior_names) -> list[dict]:
    """For each free interior parameter: its multiple correlation ``ϱ`` with all other
    camera-side unknowns, its largest pairwise correlation and partner, and its a-posteriori σ in its
    unit and in pixels, ``σ_px = σ̂₀ √Q_kk · RMS|∂pixel/∂b_k|`` over the observations, with the image σ
    ``σ̂₀ σ_image`` it is compared with (module docstring); σ NaN where it reads undetermined
    (:func:`~fotogeo.models.precision.determined_sqrt`: a negative or ridge-made inverse diagonal)."""
    m = pb.st.n_frames
    S, Si = post.S, post.S_inv
    names = [f"{frame_names[j]}.{a}" for j in range(m) for a in ("X0", "Y0", "Z0", "omega", "phi", "kappa")]
    names += [interior_names[k] for k in pb.st.free_interior]
    sd = np.sqrt(np.maximum(np.diag(Si), 1e-300))
    s0 = post.sigma0 if np.isfinite(post.sigma0) else 1.0
    out = []
    for q, k in enumerate(pb.st.free_interior):
        i = 6 * m + q
        vif = S[i, i] * Si[i, i]
        rho = float(np.sqrt(max(0.0, 1.0 - 1.0 / vif))) if vif > 0 else 1.0
        corr = Si[i] / (sd[i] * sd)
        corr[i] = 0.0
        j = int(np.argmax(np.abs(corr)))
        px = float(post.interior_px[q]) if q < len(post.interior_px) else float("nan")
        sigma = s0 * float(determined_sqrt(Si[i, i], vif))  # NaN: undetermined, never "within half a pixel"
        out.append({"parameter": interior_names[k], "multiple_correlation": rho,
                    "partner": names[j], "correlation": float(corr[j]), "sigma": sigma,
                    "sigma_px": sigma * px, "image_sigma_px": float(s0 * post.image_sigma)})
    return out
