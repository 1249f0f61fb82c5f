"""Is every frame of an adjusted block determined? (array layer)

σ₀ and the image RMS of a block stay small when a frame is held by two or three points: the
adjustment then fits those few observations exactly, whatever the frame's orientation. Only the
frame's own observation geometry and the a-posteriori precision of its orientation reveal it
(a frame rotated 30° the wrong way, tied by three points, had σ₀ 1.08 and angle σ of 200–1000°).
After the adjustment every frame is therefore checked (:func:`frame_quality`,
:func:`undetermined_frames`) on

* **points**: the number of distinct points it observes among the used observations (the frame
  has 6 unknowns: 3 points determine it exactly, with no redundancy to detect an error);
  at least ``min_points`` (default 6);
* **spread**: the area of the convex hull of those observations as a fraction of the frame
  (points clustered in a corner or along a line do not hold the angles); at least
  ``min_spread`` (default 0.05);
* **precision**: the largest a-posteriori σ of its three rotations (degrees, from the inverse of the
  reduced normal equations, scaled by ``max(σ₀, 1)``: a σ₀ below 1 says the image σ was pessimistic,
  it does not make a datum that rests on GNSS or attitude priors any better — on a rendered oblique
  block without GCPs, σ₀ 0.69 scaled a 0.60° angle σ to 0.41° while every frame was 1.0–1.1° off, the
  rotation the GPS noise gives the block); at most ``max_angle_sigma`` (default 0.5°). With
  angle priors (``eo_sigma``, INS/gimbal) a frame the images do not determine keeps about the
  prior's σ and fails the same test.
* **position precision**: the largest a-posteriori σ of its projection centre ``σ_C = max(σX, σY, σZ)``
  (m, scaled by ``max(σ₀, 1)`` as the angle σ) at most ``D̄ · tan(max_angle_sigma)``, ``D̄`` the mean
  distance from the adjusted centre to the adjusted points it observes. A centre displaced by ``δ`` turns the
  rays to ground at distance ``D`` by ``δ / D`` rad, as a rotation of that angle would: the bound asks the
  position as precisely as the angle limit asks the attitude. It catches the frame whose angles are
  determined while its position is not — the end frame of a strip whose points have only two rays, its own
  and its neighbour's: the pair's scale is free, the frame slides along the base with every observation
  unchanged (a simulated 2 × 4 block with such an end frame: angle σ 0.15°, position undetermined — it read
  σ 0 m before :mod:`~fotogeo.orientation.bundle_result` gave a singular direction NaN —, and with one third ray
  measured to 50 px σ 81.7 m against a 9.1 m bound; both passed on their angle σ before). A frame with a
  position prior (GNSS) is not tested: its position is as good as the prior (the eBee frames of
  tests/test_triangulate_drone.py: σ 15–23 m at σ₀ 4.4 against bounds of 0.8–1.0 m, held by their GPS).

* **its own tie points**: the share of its observations that data snooping rejected as blunders; at most
  ``max_blunder_share`` (default 25 %). A frame the adjustment turned the wrong way keeps the minority of
  its observations that fit the wrong orientation and rejects the rest — then it has points, spread and a
  small σ, and every test above passes: on a rendered 3 × 5 block adjusted without the robust phase's
  skipping, corner frame s3_01 came out 266 m and 14° wrong with σ 2.3 m / 0.11° while 41 % of its
  observations were rejected as blunders (the right frames of the block: at most 8 %; of the rendered
  100-frame block: at most 8 %). Tie points dropped for their ray geometry are not counted (near-parallel
  rays at a strip's end: up to 48 % of a right frame's).

* **agreement with its priors** (:func:`prior_contradicted_frames`): a frame held by its attitude prior
  with few, wrong tie points passes the three tests above — enough points, spread, and the prior's σ — while
  the wrong ties turn it far from where its GNSS/INS/gimbal put it. Each prior observation ``l`` (position
  m, rotation about the camera axes °) has the residual ``v = l̂ − l`` (adjusted − prior; the rotation
  ``log(R_priorᵀ R̂)``) with the cofactor ``Q_v = Q_l − Q_l̂``, i.e. ``σ_v² = σ_prior² − σ_adj²/σ₀²``
  (a priori σ₀ = 1). Per frame and group ``T = Σ_k (v_k / σ_v,k)²`` is χ² with one degree of freedom per
  component when the ties agree with the prior; ``T > χ²_crit`` fails the frame (Baarda 1968, the data
  snooping of :mod:`fotogeo.orientation.bundle` applied to the priors; critical values of the B-method,
  :data:`PRIOR_CRITICAL_CHI2`). A component the images do not inform (``σ_v`` ≤ 1 % of σ_prior) is not
  tested: its residual is zero by construction.

The rays per point (multi-ray tracks) are reported too: a frame whose points are all seen by
only two frames has no check within the block.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: default limits of :func:`undetermined_frames`
MIN_POINTS, MIN_SPREAD, MAX_ANGLE_SIGMA, MAX_BLUNDER_SHARE = 6, 0.05, 0.5, 0.25


@dataclass(frozen=True)
class FrameQuality:
    """Per frame ``(m,)``: points observed, points with ≥ 3 rays, hull fraction of the frame,
    largest angle σ (°), largest position σ (m), image RMS of its observations (px), observations, the
    share of them rejected as blunders, the mean distance from its centre to its points (m) and the largest angle
    σ given the rest of the block (°, :func:`~fotogeo.orientation.bundle_result.sigma_in_block`)."""

    frames: tuple
    points: np.ndarray
    multi_ray_points: np.ndarray
    spread: np.ndarray
    angle_sigma: np.ndarray
    position_sigma: np.ndarray
    image_rms: np.ndarray
    observations: np.ndarray
    blunder_share: np.ndarray
    distance: np.ndarray
    angle_sigma_in_block: np.ndarray

    def rows(self) -> list:
        """One dict per frame (the report's ``frame_quality``)."""
        return [{"name": n, "points": int(p), "multi_ray_points": int(r), "spread": round(float(s), 4),
                 "angle_sigma_deg": float(a), "position_sigma_m": float(q), "image_rms_px": float(v),
                 "blunder_share": round(float(b), 4), "object_distance_m": round(float(d), 3)}
                for n, p, r, s, a, q, v, b, d in zip(self.frames, self.points, self.multi_ray_points, self.spread,
                                                      self.angle_sigma, self.position_sigma, self.image_rms,
                                                      self.blunder_share, self.distance)]


def _hull_fraction(px: np.ndarray, area: float) -> float:
    """Area of the convex hull of ``px`` ``(k, 2)`` over ``area``; 0 for fewer than 3 points."""
    import cv2
    if len(px) < 3:
        return 0.0
    hull = cv2.convexHull(px.astype(np.float32))
    return float(cv2.contourArea(hull)) / area


def coverage(block, used=None):
    """``(points, multi_ray_points, spread)`` per frame ``(m,)`` from the observations ``used`` (bool mask; all when
    None): distinct points observed, those with ≥ 3 rays, and the convex hull of the observations as a fraction of
    the frame."""
    m = len(block.frames)
    used = np.ones(len(block.obs_frame), bool) if used is None else used
    f, p, px = block.obs_frame[used], block.obs_point[used], block.obs_pixel[used]
    rays = np.bincount(p, minlength=len(block.point_ids))
    w, h = block.camera.image_size
    points, multi, spread = np.zeros(m, int), np.zeros(m, int), np.zeros(m)
    for j in range(m):
        sel = f == j
        pts = np.unique(p[sel])
        points[j] = len(pts)
        multi[j] = int(np.count_nonzero(rays[pts] >= 3))
        spread[j] = _hull_fraction(px[sel], float(w * h))
    return points, multi, spread


def frame_quality(result, block) -> FrameQuality:
    """:class:`FrameQuality` of every frame of the adjusted ``block`` (module docstring)."""
    m = len(block.frames)
    used = result.status == "used"
    f, p = block.obs_frame[used], block.obs_point[used]
    points, multi, spread = coverage(block, used)
    rms = np.full(m, np.nan)
    distance = _object_distances(result, block, f, p)
    for j in range(m):
        sel = f == j
        if sel.any():
            rms[j] = float(np.sqrt(np.nanmean(result.residuals[used][sel] ** 2)))
    sig = np.asarray(result.eo_sigma, float)  # scaled by max(σ0, 1) (fotogeo.orientation.bundle_result)
    inner = (np.full((m, 6), np.nan) if result.eo_sigma_in_block is None
             else np.asarray(result.eo_sigma_in_block, float))
    n_obs = np.bincount(block.obs_frame, minlength=m)
    blunders = np.bincount(block.obs_frame[result.status == "blunder"], minlength=m)
    return FrameQuality(tuple(block.frames), points, multi, spread, np.max(sig[:, 3:], axis=1),
                        np.max(sig[:, :3], axis=1), rms, n_obs, blunders / np.maximum(n_obs, 1), distance,
                        np.max(inner[:, 3:], axis=1))


def _object_distances(result, block, f: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``(m,)`` mean distance (m) from each frame's adjusted centre to the adjusted points of its used
    observations ``f``, ``p``; NaN for a frame without any."""
    m = len(block.frames)
    centres = np.array([e.centre for e in result.eo], float).reshape(m, 3)
    d = np.linalg.norm(np.asarray(result.point_xyz, float)[p] - centres[f], axis=1)
    ok = np.isfinite(d)
    total = np.bincount(f[ok], weights=d[ok], minlength=m)
    count = np.bincount(f[ok], minlength=m)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def undetermined_frames(q: FrameQuality, *, min_points: int = MIN_POINTS, min_spread: float = MIN_SPREAD,
                        max_angle_sigma: float = MAX_ANGLE_SIGMA, angle_prior=None, position_prior=None,
                        in_block=None, max_blunder_share: float = MAX_BLUNDER_SHARE) -> dict:
    """``{frame: reason}`` of the frames that fail a test of the module docstring (empty: all determined).

    ``angle_prior`` ``(m,)`` bool marks frames whose angles have a prior (INS, gimbal, autopilot): for them an
    angle σ above the limit alone is not a failure — the images hold the frame (points and spread pass), its
    absolute attitude is as good as the prior (a strip of a few frames cannot fix its own roll); see
    :func:`prior_held_frames`. ``position_prior`` marks frames with a position prior (GNSS): the position test
    is not theirs (their position is as good as the prior; a frame the images do not hold fails the others).
    ``in_block`` marks frames without an attitude prior whose attitude is to rest on the block's (re-started
    frames, :mod:`fotogeo.tools.triangulate.determinacy`): their angle σ given the rest of the block must pass
    the limit instead of the absolute one."""
    out = {}
    m = len(q.frames)
    held = np.zeros(m, bool) if in_block is None else np.asarray(in_block, bool)
    prior = (np.zeros(m, bool) if angle_prior is None else np.asarray(angle_prior, bool)) | held
    gnss = np.zeros(m, bool) if position_prior is None else np.asarray(position_prior, bool)
    limit = position_limits(q, max_angle_sigma)
    for j, name in enumerate(q.frames):
        why = _coverage_reasons(q.points[j], q.spread[j], min_points, min_spread)
        if not np.isfinite(q.angle_sigma[j]):  # never held by a prior: the adjustment has no covariance for it
            why.append("no angle σ (the normal equations are singular there: near-parallel rays or no datum)")
        elif not q.angle_sigma[j] <= max_angle_sigma and (why or not prior[j]):
            why.append(f"angle σ {q.angle_sigma[j]:.3g}° (limit {max_angle_sigma:g}°)")
        if held[j] and not q.angle_sigma_in_block[j] <= max_angle_sigma:
            why.append(f"angle σ within the block {q.angle_sigma_in_block[j]:.3g}° (limit {max_angle_sigma:g}°)")
        if np.isfinite(q.angle_sigma[j]) and not gnss[j] and not q.position_sigma[j] <= limit[j]:
            why.append(f"position σ {_metres(q.position_sigma[j])} (limit {_metres(limit[j])}: its points "
                       f"{q.distance[j]:.4g} m away × tan {max_angle_sigma:g}°; the images do not hold its position, "
                       f"e.g. its points have no third ray and its pair's scale is free: tie it to more frames or "
                       f"give its GPS position, --eo-sigma-position)")
        if q.blunder_share[j] > max_blunder_share:
            why.append(f"{round(q.blunder_share[j] * q.observations[j])} of its {q.observations[j]} observations "
                       f"({100 * q.blunder_share[j]:.0f}%) rejected as blunders (limit "
                       f"{100 * max_blunder_share:.0f}%): its orientation contradicts its own tie points")
        if why:
            out[name] = ", ".join(why)
    return out


def _coverage_reasons(points: int, spread: float, min_points: int, min_spread: float) -> list:
    why = []
    if points < min_points:
        why.append(f"{points} points (needs {min_points})")
    if spread < min_spread:
        why.append(f"points cover {100 * spread:.1f}% of the frame (needs {100 * min_spread:.0f}%)")
    return why


def sparse_frames(block, *, min_points: int = MIN_POINTS, min_spread: float = MIN_SPREAD) -> dict:
    """``{frame: reason}`` of the frames whose observations, all of them, are too few or cover too little of the
    frame — known before any adjustment. The adjustment only removes observations (as blunders), so such a frame
    would fail :func:`undetermined_frames` after it too: a run can refuse (or drop) it without adjusting first."""
    points, _, spread = coverage(block)
    out = {}
    for j, name in enumerate(block.frames):
        why = _coverage_reasons(int(points[j]), float(spread[j]), min_points, min_spread)
        if why:
            out[name] = ", ".join(why)
    return out


def position_limits(q: FrameQuality, max_angle_sigma: float = MAX_ANGLE_SIGMA) -> np.ndarray:
    """``(m,)`` the largest position σ (m) a frame may keep: ``D̄ · tan(max_angle_sigma)`` (module docstring);
    NaN (every σ fails) for a frame without points."""
    return np.asarray(q.distance, float) * np.tan(np.radians(max_angle_sigma))


def _metres(value: float) -> str:
    """A length for a message: ``0.873 m``, ``126 m``, ``4.83 km``, ``undetermined``."""
    if not np.isfinite(value):
        return "undetermined"
    return f"{value / 1000:.3g} km" if value >= 1000 else f"{value:.3g} m"


def prior_held_frames(q: FrameQuality, max_angle_sigma: float = MAX_ANGLE_SIGMA) -> dict:
    """``{frame: angle σ}`` of the frames whose angle σ exceeds the limit (held by their attitude prior when
    :func:`undetermined_frames` let them pass): reported, never silent."""
    return {n: float(a) for n, a in zip(q.frames, q.angle_sigma) if not a <= max_angle_sigma}


#: critical values of the prior test (:func:`prior_contradicted_frames`) by the number of tested components:
#: Baarda's (1968) B-method — every test detects the same error (non-centrality λ₀ = 17.07, power 80 %) as the
#: one-dimensional test at α₀ = 0.1 % (critical w 3.29); for 3 components α = 0.55 %
#: (scipy.stats.ncx2, computed once)
PRIOR_CRITICAL_CHI2 = {1: 10.83, 2: 11.73, 3: 12.63}


def prior_residuals(result, block, eo_sigma):
    """``(v, σ_v)`` ``(m, 6)`` of the priors on the orientation (position m, rotations about the camera axes °):
    ``v`` the adjusted minus the prior (the approximate orientation the block started from; the rotation as
    ``log(R_priorᵀ R)``, the residual the adjustment minimises), ``σ_v = √(σ_prior² − σ_adj²/σ₀²)`` its σ
    (the a-posteriori cofactor of a residual, ``Q_v = Q_l − Q_l̂``, with the a priori σ₀ = 1; NaN where the
    component has no prior or the images add nothing to it, ``σ_v ≤ 1 %`` of σ_prior). When the adjustment
    re-weighted its groups (:func:`~fotogeo.orientation.bundle_result.reweighted`) the test stays at the σ given
    and the solution of those weights (``result.eo_given_weights``): widened, a group's σ would absorb the few
    wrong priors (or a wrong camera held fixed) this test is there to name."""
    from .bundle_jacobian import log_rotation
    from .bundle_problem import eo_weights
    m = len(block.frames)
    w = eo_weights(eo_sigma, m)
    prior_sigma = np.where(w > 0, 1.0 / np.sqrt(np.where(w > 0, w, 1.0)), np.nan)
    prior_sigma[:, 3:] = np.degrees(prior_sigma[:, 3:])
    R0 = np.stack([e.rotation_cv for e in block.eo])
    eo = result.eo_given_weights or result.eo  # tested with the σ given, at the solution of those weights
    R = np.stack([e.rotation_cv for e in eo])
    v = np.concatenate([np.stack([e.centre for e in eo]) - np.stack([e.centre for e in block.eo]),
                        np.degrees(log_rotation(np.transpose(R0, (0, 2, 1)) @ R))], axis=1)
    post = result.eo_sigma_a_priori
    if post is None:
        from .bundle_result import covariance_scale
        post = np.asarray(result.eo_sigma, float) / covariance_scale(float(result.sigma0))[0]
    with np.errstate(invalid="ignore"):
        var = prior_sigma ** 2 - post ** 2
        sigma_v = np.where(var > (0.01 * prior_sigma) ** 2, np.sqrt(np.maximum(var, 0.0)), np.nan)
    return v, sigma_v


def prior_contradicted_frames(result, block, eo_sigma) -> dict:
    """``{frame: reason}`` of the frames whose adjusted attitude or position departs from its prior more than
    the prior's σ allows: their tie points pull them where the GNSS/INS/gimbal says they are not. Which of
    the two is wrong the test cannot tell (measured on the rendered oblique block, seed 2: DJI_205 and DJI_405
    right, their gimbal tags 21.2° and 18.4° from the truth — named as well; the tool re-starts such a frame
    without its attitude prior, :mod:`fotogeo.tools.triangulate.determinacy`).

    Per frame and per group (position, attitude) the standardised residuals of :func:`prior_residuals` give
    ``T = Σ (v_k / σ_v,k)²`` over the components with a prior, χ²-distributed with as many degrees of freedom
    when prior and images agree; ``T`` above :data:`PRIOR_CRITICAL_CHI2` fails the frame (Baarda's (1968)
    data snooping, applied to the prior observations). A frame held by its attitude prior with a few wrong
    ties passes every other test — points, spread, the prior's σ — and only this one catches it (measured on
    the rendered oblique block, seed 1: DJI_301 25.7 m from its GPS under a σ_v of 4.7 m,
    ``√T`` = 9.44 for its position; it exited 0 about 20° wrong before). The frames come most contradicted first (``T`` over its critical value):
    one wrong frame pulls its neighbours too, so a caller dropping frames drops the first and adjusts again
    (data snooping removes one observation at a time)."""
    tests = prior_tests(result, block, eo_sigma)
    out, excess = {}, {}
    for name, failed in tests.items():
        why = [f"adjusted {what} {size:.3g}{_UNIT[what]} from its prior (σ {sv:.3g}{_UNIT[what]}, test "
               f"{np.sqrt(t):.2f} > {np.sqrt(crit):.2f})" for what, (size, sv, t, crit) in failed.items()]
        out[name] = "; ".join(why) + ": its tie points and its prior disagree (wrong ties or a wrong GPS/gimbal tag)"
        excess[name] = max(t / crit for _, _, t, crit in failed.values())
    return {n: out[n] for n in sorted(out, key=excess.get, reverse=True)}


_UNIT = {"attitude": "°", "position": " m"}


def prior_tests(result, block, eo_sigma) -> dict:
    """``{frame: {"attitude" | "position": (size of v (° or m), largest σ_v, T, χ²_crit)}}`` of the groups that
    fail the prior test of :func:`prior_contradicted_frames` (frames that pass are left out)."""
    v, sv = prior_residuals(result, block, eo_sigma)
    out = {}
    for j, name in enumerate(block.frames):
        failed = {}
        for cols, what in (((3, 4, 5), "attitude"), ((0, 1, 2), "position")):
            ok = [k for k in cols if np.isfinite(sv[j, k])]
            if not ok:
                continue
            t = float(np.sum((v[j, ok] / sv[j, ok]) ** 2))
            if t > PRIOR_CRITICAL_CHI2[len(ok)]:
                failed[what] = (float(np.linalg.norm(v[j, list(cols)])), float(np.max(sv[j, ok])), t,
                                PRIOR_CRITICAL_CHI2[len(ok)])
        if failed:
            out[name] = failed
    return out
