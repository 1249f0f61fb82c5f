"""The frozen result of a bundle adjustment: map coordinates, precision and statistics (array layer).

Orientations go back to the map CRS (``X_map = X_local + O``, PATB angles from ``R·diag(1, −1, −1)``);
every σ and covariance below is scaled by ``σ̂ = max(σ₀, 1)`` (:func:`covariance_scale`), written ``σ₀`` there: a
block whose residuals are smaller than their a-priori σ (σ₀ < 1) keeps the a-priori precision — σ₀ < 1 says
the a-priori σ were pessimistic or the redundancy is small, not that the orientation is better than its
observations allow (the same floor as the data snooping's, :mod:`fotogeo.orientation.bundle_robust`). When one
observation group's own ``σ̂_g`` (:mod:`fotogeo.orientation.bundle_variance`) exceeds ``σ̂`` — GNSS positions or
control given a σ far below their errors, whose misfit the image points' redundancy dilutes in σ₀ — each group's
weights are divided by ``f_g²``, starting from ``max(σ̂_g, σ̂)²``, and the block solved again until every group's
σ̂_g is 1 (:func:`reweighted`; Förstner (1979), Koch (1999): iterated variance components, never below a group's
a-priori σ); the orientations and the covariances are then both those of the re-weighted groups, not scaled
again, while σ₀ and the groups' σ̂_g reported stay those of the given weights (what their a-priori σ say).
σ of the orientation are ``σ₀ √diag(S⁻¹)`` (positions in m, rotations about the camera axes in
degrees, as :mod:`fotogeo.models.collinearity` reports them; NaN where the diagonal is negative, a singular
system), given the rest of the block ``σ₀ √diag((S_jj)⁻¹)`` (:func:`sigma_in_block`), σ of the points
``σ₀ √diag(Σ_bb,i)``. The full covariance of each frame's orientation is the ``6 × 6`` diagonal block
``σ₀² (S⁻¹)_jj`` in the unknowns' order ``X0, Y0, Z0`` (m, map axes) then ``δθ`` (rad), the rotation
increment about the OpenCV camera axes (x right, y down, z forward) of the bundle's update
``R_j ← R_j·exp([δθ]×)`` (:mod:`fotogeo.orientation.bundle_jacobian`); with self-calibration also the
free interior parameters' block and their cross-covariance with each frame (what
:mod:`fotogeo.orientation.ground_sigma` propagates to the ground). Statistics: σ₀, the image RMS of the used
observations (px), and per role the RMSE of ``adjusted − known`` per axis, planimetric
``√(RMSE_X² + RMSE_Y²)`` and in height, in metres: control (residuals of the weighted coordinates: how far their σ
let them move), check (true errors) and ``control_images`` (the control points placed by their rays alone,
:mod:`fotogeo.orientation.bundle_control`: errors in metres comparable to the check points').
"""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from ..errors import FotogeoError, FotogeoWarning
from ..geometry.camera import ExteriorOrientation, angles_patb
from ..models.precision import determined_sqrt, undetermined
from . import bundle_jacobian as bj
from .bundle_control import images_only_errors, rmse
from .bundle_robust import largest_w, posterior


def _rmse(d: np.ndarray) -> dict:
    if len(d) == 0:
        return {"n": 0}
    r = np.sqrt(np.mean(d ** 2, axis=0))
    return {"n": int(len(d)), "rmse_x_m": float(r[0]), "rmse_y_m": float(r[1]), "rmse_z_m": float(r[2]),
            "rmse_planimetric_m": float(np.hypot(r[0], r[1])),
            "max_planimetric_m": float(np.max(np.hypot(d[:, 0], d[:, 1]))),
            "max_z_m": float(np.max(np.abs(d[:, 2])))}


def covariance_scale(sigma0: float) -> tuple[float, str]:
    """``(σ̂, rule)``: the factor of every σ and covariance (module docstring) and the sentence stating it.

    >>> covariance_scale(0.33)[0], covariance_scale(2.5)[0], covariance_scale(float("nan"))[0]
    (1.0, 2.5, 1.0)
    """
    if not np.isfinite(sigma0):
        return 1.0, "covariances scaled by 1 (the a-priori precision): sigma0 is undefined (no redundancy)"
    if sigma0 < 1.0:
        return 1.0, (f"covariances scaled by 1 (the a-priori precision), not by sigma0 {sigma0:.3g}: residuals "
                     f"below their a-priori sigma do not make the orientation more precise than its observations")
    return float(sigma0), f"covariances scaled by sigma0 {sigma0:.3g} (residuals above their a-priori sigma)"


#: the groups of :func:`fotogeo.orientation.bundle_variance.variance_components` and the Problem's weights they scale
_GROUPS = ("image", "control", "position_prior", "attitude_prior")


def group_factors(groups: dict, sigma0: float) -> dict:
    """``{group: f_g}``, ``f_g = max(σ̂_g, σ̂)`` with ``σ̂`` of :func:`covariance_scale`; a group without σ̂_g
    (too little redundancy) gets ``σ̂``.

    >>> group_factors({"image": {"sigma0": 0.7}, "position_prior": {"sigma0": 5.0}, "control": {"sigma0": None}}, 0.8)
    {'image': 1.0, 'position_prior': 5.0, 'control': 1.0}
    """
    base = covariance_scale(sigma0)[0]
    out = {}
    for k, g in groups.items():
        s = g.get("sigma0")
        out[k] = max(float(s), base) if s is not None and np.isfinite(s) else base
    return out


def _reweighted(pb, f: dict, base: float):
    e = np.repeat([f.get("position_prior", base), f.get("attitude_prior", base)], 3)
    return replace(pb, p0=pb.p0 / f.get("image", base) ** 2, ctrl_w=pb.ctrl_w / f.get("control", base) ** 2,
                   eo_w=pb.eo_w / e ** 2)


def _converged(f: dict, s: dict, tol: float = 0.05) -> bool:
    """Every group's re-estimated ``σ̂_g`` within ``tol`` of 1, or below it where its factor is at the floor 1 (a
    group is never weighted above its a-priori σ); a group without ``σ̂_g`` (NaN) cannot move."""
    return all(not np.isfinite(s[k]) or abs(s[k] - 1.0) <= tol or (f[k] <= 1.0 and s[k] <= 1.0 + tol) for k in f)


#: the prior groups: observations of the unknowns themselves, which the image points may check too little to
#: estimate their σ̂_g (redundancy below 1: NaN, :mod:`fotogeo.orientation.bundle_variance`)
_PRIORS = ("control", "position_prior", "attitude_prior")


def uncheckable(groups: dict, f: dict, base: float) -> list:
    """The prior groups without ``σ̂_g`` (redundancy ``r_g`` < 1) that may hold the misfit another group shows, when
    one group's factor ``f_g`` exceeds ``base`` by more than 5 %: the misfit cannot be attributed. An error in a
    group nothing checks goes into the others' residuals (attitude priors 0.3° off given 0.001°, ``r_g`` 0.05:
    GNSS good to 0.05 m given 0.5 m showed σ̂ 6.6, the images 2.1); re-weighting those would widen the good
    groups and keep the wrong one, moving the frames further off (position errors 2.84 → 3.12 m,
    ``tests/test_bundle_variance_unattributed.py``). Such a group is named when its own ``vᵀPv / r_g`` (a σ̂_g² of
    little weight) exceeds a quarter of the largest checked factor squared, ``(f_max / 2)²``: attitude priors 0.3°
    off given 0.001° gave 118–288 against GNSS 6.6²–12.7² (≥ 43, seeds 10–12), GCPs at centimetres 3.0 against
    GNSS 5.59² (the held-out 3 × 4 block of ``benchmarks/triangulate_sigma_bench.py``, seed 21) and 0.2 against
    1.19² (3 GCP, seed 26), whose GNSS is then re-weighted. Without ``vtpv`` the group is named.

    >>> nan = float("nan")
    >>> uncheckable({"position_prior": {"sigma0": 6.6}, "attitude_prior": {"sigma0": nan, "redundancy": 0.05,
    ...              "vtpv": 15.2}}, {"position_prior": 6.6, "attitude_prior": 1.0}, 1.0)
    ['attitude_prior']
    >>> uncheckable({"position_prior": {"sigma0": 5.6}, "control": {"sigma0": nan, "redundancy": 0.07,
    ...              "vtpv": 0.21}}, {"position_prior": 5.6, "control": 1.0}, 1.0)
    []
    """
    blind = [k for k in _PRIORS if k in groups and not np.isfinite(groups[k].get("sigma0") or np.nan)]
    top = max((v for k, v in f.items() if k not in blind), default=base)
    if top <= 1.05 * base:
        return []
    share = {k: groups[k].get("redundancy", 0.0) * (top / 2) ** 2 for k in blind}
    return [k for k in blind if not groups[k].get("vtpv", np.inf) <= share[k]]


def reweighted(pb, s, post, solve=None, rounds: int = 8):
    """``(problem, state, posterior, factors)``: the solution and its posterior with each observation group's
    weights divided by its variance component (module docstring), or the input and None when no group's σ̂_g
    exceeds the scale of :func:`covariance_scale` by more than 5 %.

    Iterated variance-component estimation (Förstner 1979; Koch 1999, §3.6): from ``f_g`` of
    :func:`group_factors` the block is solved again with the weights ``p_g / f_g²`` (``solve(problem, state) ->
    state``, the adjustment's solver), every group's ``σ̂_g`` estimated at that solution and ``f_g ← max(f_g σ̂_g,
    1)``, until every ``σ̂_g`` is within 5 % of 1 (or below it at ``f_g = 1``: a group is never weighted above its
    a-priori σ), at most ``rounds`` solves (``factors["converged"]`` False and ``factors["sigma0_last"]`` the
    last σ̂_g when that limit stops it). A group whose a-priori σ is far too small pulls the solution onto its
    observations and shows a fraction of its misfit in its residuals; re-solved, the coordinates and the
    covariance come from the same weights. Without ``solve``, when the first re-solve fails, or when a prior
    group is :func:`uncheckable` (``factors["uncheckable"]``: the misfit cannot be attributed), the covariance
    of the widened weights is taken at ``s`` (``s`` not moved, ``factors["solves"]`` 0)."""
    f = group_factors({k: g for k, g in post.groups.items() if k in _GROUPS}, post.sigma0)
    base = covariance_scale(post.sigma0)[0]
    if all(v <= 1.05 * base for v in f.values()):  # the tolerance of the estimate below
        return pb, s, post, None
    blind = uncheckable(post.groups, f, base)
    best, state, done = None, s, False
    for k in range(rounds if solve is not None and not blind else 0):
        pw = _reweighted(pb, f, base)
        try:
            state = solve(pw, state)
        except FotogeoError:
            break
        pw_post = posterior(pw, state, pw.p0)
        more = {g: float(pw_post.groups.get(g, {}).get("sigma0", np.nan)) for g in f}
        best = (pw, state, pw_post, {**f, "solves": k + 1, "sigma0_last": more})
        if _converged(f, more):
            done = True
            break
        f = {g: max(v * more[g], 1.0) if np.isfinite(more[g]) else v for g, v in f.items()}
    if best is None:
        pw = _reweighted(pb, f, base)
        if blind:
            said = unattributed_sentence(post.groups, f, blind, base)
            warnings.warn(said, FotogeoWarning, stacklevel=2)
            return pw, s, posterior(pw, s, pw.p0), {**f, "solves": 0, "uncheckable": blind, "unattributed": said}
        return pw, s, posterior(pw, s, pw.p0), {**f, "solves": 0}
    best[3]["converged"] = done
    return best


def unattributed_sentence(groups: dict, f: dict, blind: list, base: float) -> str:
    """Why the groups were not re-weighted when :func:`uncheckable` names ``blind`` (``base``: σ̂ of
    :func:`covariance_scale`)."""
    high = ", ".join(f"{k} {f[k]:.3g}" for k in f if k not in blind and f[k] > 1.05 * base)
    who = ", ".join(f"{k} (redundancy {groups[k].get('redundancy', 0.0):.2f})" for k in blind)
    return (f"the misfit cannot be attributed to an observation group: {high or 'a group'} above its a-priori "
            f"sigma, but {who} has too little redundancy for its own sigma0 and may be the cause (its a-priori "
            f"sigma too small: give its real accuracy); the given-weights solution kept, not re-weighted; the "
            f"frames' sigma rest on that group's a-priori sigma and may be well below their errors")


def reweighted_rule(factors: dict, post) -> str:
    """The sentence of ``statistics.covariance_rule`` for the factors of :func:`reweighted` and its posterior."""
    said = ", ".join(f"{k} {factors[k]:.3g}" for k in _GROUPS if k in factors)
    if factors.get("unattributed"):
        how = factors["unattributed"] + ": covariance of the widened weights at that solution"
    elif not factors["solves"]:
        how = "the orientations could not be re-solved: covariance of the widened weights at the given-weight solution"
    elif factors.get("converged", True):
        how = (f"the orientations re-solved with those weights ({factors['solves']} solves, variance components; "
               f"sigma0 then {post.sigma0:.3g})")
    else:
        last = ", ".join(f"{k} {v:.3g}" for k, v in factors.get("sigma0_last", {}).items())
        how = (f"the orientations re-solved with those weights, not converged in {factors['solves']} solves (the "
               f"last solve's sigma0 by group: {last}; sigma0 then {post.sigma0:.3g})")
    return (f"covariances from the a-priori sigma widened per observation group by its own sigma0 where it exceeds "
            f"max(sigma0, 1) ({said}): its residuals exceed its a-priori sigma; {how}")


def covariance_blocks(S_inv: np.ndarray, sigma0: float, m: int, blank=None) -> tuple:
    """``(per frame (m, 6, 6), interior (k, k), frame-interior (m, 6, k))`` of ``σ₀² S⁻¹`` (module docstring):
    the blocks the banded inverse holds (each frame's own and the interior rows); NaN in the rows and columns of
    the unknowns ``blank`` (a mask: those whose σ reads undetermined, :func:`~fotogeo.models.precision.undetermined`
    — their inverse holds any sign and size the BLAS at hand gives)."""
    Q = sigma0 ** 2 * S_inv
    if blank is not None and np.any(blank):
        Q[blank, :] = np.nan
        Q[:, blank] = np.nan
    idx = 6 * np.arange(m)[:, None] + np.arange(6)
    frames = Q[idx[:, :, None], idx[:, None, :]]
    return frames, Q[6 * m:, 6 * m:].copy(), Q[:6 * m, 6 * m:].reshape(m, 6, -1).copy()


def sigma_in_block(S: np.ndarray, s0: float, m: int) -> np.ndarray:
    """``(m, 6)`` σ of every frame's orientation with every other unknown held: ``σ₀ √diag((S_jj)⁻¹)``, ``S_jj``
    its 6 × 6 block of the reduced camera matrix (its rays through their points and its priors); positions in
    m, rotations in degrees; NaN where the block is singular. The difference to ``eo_sigma`` is the block's own
    uncertainty (its datum: a block without GCPs turned by the noise of its GNSS positions)."""
    out = np.full((m, 6), np.nan)
    for j in range(m):
        block = S[6 * j:6 * j + 6, 6 * j:6 * j + 6]
        try:
            inv = np.diag(np.linalg.inv(block))
            out[j] = s0 * determined_sqrt(inv, inv * np.diag(block))
        except np.linalg.LinAlgError:
            continue
    out[:, 3:] = np.degrees(out[:, 3:])
    return out


def frame_eos(run) -> tuple:
    """The map orientations of ``run``'s frames (module docstring)."""
    return tuple(ExteriorOrientation(*(run.C[j] + run.origin), *angles_patb(run.R[j] @ bj.D_CV))
                 for j in range(len(run.C)))


def make_result(block, run, pb, post, fixed, correlations, blunders, timings, given=None, factors=None,
                given_eo=None):
    """A :class:`~fotogeo.orientation.bundle.BundleResult` from the final state of ``run``, ``pb`` and ``post`` its
    problem and posterior; ``given``: the posterior with the given weights when ``pb`` was re-weighted per group
    (:func:`reweighted`, ``factors``) — σ₀ and the groups' σ̂ reported are then the given weights' (what the
    groups' a-priori σ say), residuals and covariances the re-weighted solution's; ``given_eo`` the orientations
    of the given weights (the priors' test)."""
    from .bundle_types import BundleResult
    m, P, n = len(block.frames), len(block.point_ids), len(block.obs_frame)
    given = given if given is not None else post
    cov, (s0, rule) = post, covariance_scale(post.sigma0)
    if factors is not None:
        rule = reweighted_rule(factors, post)
    eo = frame_eos(run)
    blank = undetermined(np.diag(cov.S_inv), np.diag(cov.S_inv) * np.diag(cov.S))
    sd = s0 * determined_sqrt(np.diag(cov.S_inv), np.diag(cov.S_inv) * np.diag(cov.S))
    eo_sigma = sd[:6 * m].reshape(m, 6).copy()
    eo_sigma[:, 3:] = np.degrees(eo_sigma[:, 3:])
    a_priori = determined_sqrt(np.diag(given.S_inv), np.diag(given.S_inv) * np.diag(given.S))[:6 * m].reshape(m, 6)
    a_priori[:, 3:] = np.degrees(a_priori[:, 3:])
    interior_sigma = {bj.INTERIOR_NAMES[k]: float(sd[6 * m + q]) for q, k in enumerate(pb.st.free_interior)}
    cam = replace(block.camera, focal_length=float(run.interior[0]),
                  principal_point=(float(run.interior[1]), float(run.interior[2])))
    names = bj.INTERIOR_NAMES[3:bj.N_PHYSICAL]
    if np.any(run.interior[bj.N_PHYSICAL:] != 0):  # Ebner's terms, when estimated
        names = bj.INTERIOR_NAMES[3:]
    distortion = {k: float(run.interior[bj.INTERIOR_NAMES.index(k)]) for k in names}
    xyz = np.full((P, 3), np.nan)
    xyz[pb.point_ids] = run.X[pb.point_ids] + run.origin
    psig = np.full((P, 3), np.nan)
    psig[pb.point_ids] = s0 * np.sqrt(np.maximum(np.diagonal(cov.point_cofactor, axis1=1, axis2=2), 0.0))
    rays = np.zeros(P, int)
    rays[pb.point_ids] = pb.st.counts
    live = np.isfinite(xyz[block.obs_point]).all(axis=1)
    res = np.full((n, 2), np.nan)
    res[live] = bj.project(run.R, run.C, run.X, block.obs_frame[live], block.obs_point[live], run.interior,
                           pb.scale) - block.obs_pixel[live]
    status = np.where(live, "blunder", "dropped").astype(object)
    status[[b["observation"] for b in blunders if "observation" in b and not live[b["observation"]]]] = "blunder"
    status[pb.obs_ids] = "used"
    red = np.full((n, 2), np.nan)
    red[pb.obs_ids] = post.r
    w = np.full(n, np.nan)
    w[pb.obs_ids] = largest_w(post.w)  # NaN: not testable
    stats = {"sigma0": given.sigma0, "covariance_scale": s0, "covariance_rule": rule,
             "redundancy": int(post.redundancy), "n_frames": m,
             "n_points": int(len(pb.point_ids)), "n_observations": int(len(pb.obs_ids)),
             "image_rms_px": float(np.sqrt(np.mean(np.sum(post.v ** 2, axis=1) / 2))),
             "n_blunders": len(blunders), "mean_redundancy_number": float(np.mean(post.r)),
             "variance_components": given.groups}
    if factors is not None:
        stats["group_factors"] = {k: v for k, v in factors.items() if k in _GROUPS or k == "solves"}
        stats["reweighting"] = {k: v for k, v in factors.items() if k not in stats["group_factors"]}
        stats["sigma0_reweighted"] = post.sigma0
    for role in ("control", "check"):
        sel = (block.role == role) & np.isfinite(xyz).all(axis=1)
        stats[role] = _rmse(xyz[sel] - block.point_xyz[sel])
    stats["n_blunders"] = sum(1 for b in blunders if b.get("kind") == "image")
    stats["n_control_rejected"] = int(np.count_nonzero(block.role == "rejected"))
    result = BundleResult(tuple(block.frames), block.role.copy(), eo, eo_sigma, cam, distortion, interior_sigma, xyz,
                          psig, rays, res, status.astype(str), red, w, given.sigma0, stats, tuple(fixed),
                          tuple(correlations),
                          tuple(blunders), run.iterations, timings, *covariance_blocks(cov.S_inv, s0, m, blank),
                          tuple(bj.INTERIOR_NAMES[k] for k in pb.st.free_interior), sigma_in_block(cov.S, s0, m),
                          a_priori, given_eo if factors is not None else None)
    errors = images_only_errors(result, block)
    stats["control_images"] = rmse(errors[np.isfinite(errors[:, :2]).all(axis=1)])
    return result
