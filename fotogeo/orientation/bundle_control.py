"""Control points seen by the images alone: the honest measure of how well a block fits its control (array layer).

In the adjustment a control point is held near its given coordinates by their weight: with a
σ of 0.5 m against 6 m image pixels its adjusted position stays within millimetres of the given
one whatever the images say, so ``adjusted − given`` (the weighted residual) measures the
weighting, not the fit. Here every control point is placed by its rays alone, through the
adjusted orientations and camera: the least-squares intersection of its used rays (the point
nearest to all of them) when they meet at more than :data:`MIN_ANGLE_DEG`, else its single ray
cut at the given height — which gives X, Y but no Z error. ``images − given`` is then an error
in metres like a check point's (a check point is exactly such a point, adjusted without its
coordinates), only not independent of the orientation it helped to fix.
"""
from __future__ import annotations

import numpy as np

from . import bundle_jacobian as bj

#: the smallest angle between two rays of a point for a 3-D intersection (degrees)
MIN_ANGLE_DEG = 2.0


def world_rays(result, frame: np.ndarray, pixel: np.ndarray):
    """``(centres (n, 3), unit directions (n, 3))`` of the rays of ``pixel`` ``(n, 2)`` in the frames
    ``frame`` ``(n,)`` through the adjusted camera, distortion and orientations of ``result``."""
    cam = result.camera
    interior = np.array([cam.focal_length, *cam.principal_point,
                         *(result.distortion.get(k, 0.0) for k in bj.INTERIOR_NAMES[3:])], dtype=np.float64)
    rays = bj.undistort_rays(np.asarray(pixel, np.float64), interior, bj.pixel_scale(cam))
    pinhole = rays @ cam.K[:2].T
    C, D = np.zeros((len(frame), 3)), np.zeros((len(frame), 3))
    for j in np.unique(frame):
        at = frame == j
        eo = result.eo[j]
        C[at] = eo.centre
        D[at] = cam.rays(pinhole[at]) @ eo.rotation_cv.T
    return C, D / np.linalg.norm(D, axis=1, keepdims=True)


def intersect(C: np.ndarray, D: np.ndarray) -> np.ndarray:
    """The point nearest (least squares) to the lines ``C + λ D`` (unit ``D``).

    >>> C, D = np.array([[0.0, 0, 10], [10, 0, 10]]), np.array([[0.0, 0, -1], [-0.8, 0, -0.6]])
    >>> (intersect(C, D).round(6) + 0.0).tolist()
    [0.0, 0.0, 2.5]
    """
    P = np.eye(3)[None] - D[:, :, None] * D[:, None, :]
    return np.linalg.solve(P.sum(axis=0), np.einsum("nab,nb->a", P, C))


def images_only_errors(result, block) -> np.ndarray:
    """``(P, 3)``: for every control point (final role ``control``) its position from its used rays
    minus its given coordinates (module docstring; Z NaN for a point cut at its given height); NaN rows
    elsewhere."""
    out = np.full((len(block.point_ids), 3), np.nan)
    used = result.status == "used"
    for j in np.flatnonzero(result.roles == "control"):
        sel = used & (block.obs_point == j)
        if not sel.any():
            continue
        C, D = world_rays(result, block.obs_frame[sel], block.obs_pixel[sel])
        given = block.point_xyz[j]
        if len(D) > 1 and _widest_angle(D) > MIN_ANGLE_DEG:
            out[j] = intersect(C, D) - given
        else:
            lam = (given[2] - C[:, 2]) / D[:, 2]
            xy = (C + lam[:, None] * D)[:, :2].mean(axis=0)
            out[j, :2] = xy - given[:2]
    return out


def _widest_angle(D: np.ndarray) -> float:
    """The largest angle between two of the unit directions ``D`` (degrees)."""
    c = np.clip(D @ D.T, -1.0, 1.0)
    return float(np.degrees(np.arccos(c.min())))


def rmse(d: np.ndarray) -> dict:
    """RMSE per axis of the errors ``d`` ``(n, 3)`` (NaN entries left out per axis), planimetric
    ``√(RMSE_X² + RMSE_Y²)``, the largest planimetric and height errors; ``{"n": 0}`` without rows."""
    d = d[np.isfinite(d[:, :2]).all(axis=1)] if len(d) else d
    if len(d) == 0:
        return {"n": 0}
    z = d[np.isfinite(d[:, 2]), 2]
    r = np.sqrt(np.mean(d[:, :2] ** 2, axis=0))
    rz = float(np.sqrt(np.mean(z ** 2))) if len(z) else float("nan")
    return {"n": int(len(d)), "n_z": int(len(z)), "rmse_x_m": float(r[0]), "rmse_y_m": float(r[1]), "rmse_z_m": rz,
            "rmse_planimetric_m": float(np.hypot(r[0], r[1])),
            "max_planimetric_m": float(np.max(np.hypot(d[:, 0], d[:, 1]))),
            "max_z_m": float(np.max(np.abs(z))) if len(z) else float("nan")}
