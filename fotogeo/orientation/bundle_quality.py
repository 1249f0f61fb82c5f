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

The rays per point (multi-ray tracks) are reported too: a frame whose points are all seen by
only two frames has no check within the block.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: default limits of :func:`undetermined_frames`
MIN_POINTS, MIN_SPREAD, MAX_ANGLE_SIGMA = 6, 0.05, 0.5


@dataclass(frozen=True)
class FrameQuality:
    """Per frame ``(m,)``: points observed, points with ≥ 3 rays, hull fraction of the frame,
    largest angle σ (°), largest position σ (m), image RMS of its observations (px)."""

    frames: tuple
    points: np.ndarray
    multi_ray_points: np.ndarray
    spread: np.ndarray
    angle_sigma: np.ndarray
    position_sigma: np.ndarray
    image_rms: np.ndarray

    def rows(self) -> list:
        """One dict per frame (the report's ``frame_quality``)."""
        return [{"name": n, "points": int(p), "multi_ray_points": int(r), "spread": round(float(s), 4),
                 "angle_sigma_deg": float(a), "position_sigma_m": float(q), "image_rms_px": float(v)}
                for n, p, r, s, a, q, v in zip(self.frames, self.points, self.multi_ray_points, self.spread,
                                                self.angle_sigma, self.position_sigma, self.image_rms)]


def _hull_fraction(px: np.ndarray, area: float) -> float:
    """Area of the convex hull of ``px`` ``(k, 2)`` over ``area``; 0 for fewer than 3 points."""
    import cv2
    if len(px) < 3:
        return 0.0
    hull = cv2.convexHull(px.astype(np.float32))
    return float(cv2.contourArea(hull)) / area


def frame_quality(result, block) -> FrameQuality:
    """:class:`FrameQuality` of every frame of the adjusted ``block`` (module docstring)."""
    m = len(block.frames)
    used = result.status == "used"
    f, p = block.obs_frame[used], block.obs_point[used]
    rays = np.bincount(p, minlength=len(block.point_ids))
    w, h = block.camera.image_size
    points = np.zeros(m, int)
    multi = np.zeros(m, int)
    spread = np.zeros(m)
    rms = np.full(m, np.nan)
    for j in range(m):
        sel = f == j
        pts = np.unique(p[sel])
        points[j] = len(pts)
        multi[j] = int(np.count_nonzero(rays[pts] >= 3))
        spread[j] = _hull_fraction(block.obs_pixel[used][sel], float(w * h))
        if sel.any():
            rms[j] = float(np.sqrt(np.nanmean(result.residuals[used][sel] ** 2)))
    s0 = float(result.sigma0)
    sig = np.asarray(result.eo_sigma, float) * (max(s0, 1.0) / s0 if s0 > 0 else 1.0)
    return FrameQuality(tuple(block.frames), points, multi, spread, np.max(sig[:, 3:], axis=1),
                        np.max(sig[:, :3], axis=1), rms)


def undetermined_frames(q: FrameQuality, *, min_points: int = MIN_POINTS, min_spread: float = MIN_SPREAD,
                        max_angle_sigma: float = MAX_ANGLE_SIGMA, angle_prior=None) -> dict:
    """``{frame: reason}`` of the frames that fail a test of the module docstring (empty: all determined).

    ``angle_prior`` ``(m,)`` bool marks frames whose angles have a prior (INS, gimbal, autopilot): for them an
    angle σ above the limit alone is not a failure — the images hold the frame (points and spread pass), its
    absolute attitude is as good as the prior (a strip of a few frames cannot fix its own roll); see
    :func:`prior_held_frames`."""
    out = {}
    prior = np.zeros(len(q.frames), bool) if angle_prior is None else np.asarray(angle_prior, bool)
    for j, name in enumerate(q.frames):
        why = []
        if q.points[j] < min_points:
            why.append(f"{q.points[j]} points (needs {min_points})")
        if q.spread[j] < min_spread:
            why.append(f"points cover {100 * q.spread[j]:.1f}% of the frame (needs {100 * min_spread:.0f}%)")
        if not np.isfinite(q.angle_sigma[j]):  # never held by a prior: the adjustment has no covariance for it
            why.append("no angle σ (the normal equations are singular there: near-parallel rays or no datum)")
        elif not q.angle_sigma[j] <= max_angle_sigma and (why or not prior[j]):
            why.append(f"angle σ {q.angle_sigma[j]:.3g}° (limit {max_angle_sigma:g}°)")
        if why:
            out[name] = ", ".join(why)
    return out


def prior_held_frames(q: FrameQuality, max_angle_sigma: float = MAX_ANGLE_SIGMA) -> dict:
    """``{frame: angle σ}`` of the frames whose angle σ exceeds the limit (held by their attitude prior when
    :func:`undetermined_frames` let them pass): reported, never silent."""
    return {n: float(a) for n, a in zip(q.frames, q.angle_sigma) if not a <= max_angle_sigma}
