"""Checks, the local frame, first point coordinates and the active problem of a block (array layer).

*Local frame*: the mean approximate projection centre ``O`` is subtracted from every map
coordinate (``X_local = X_map − O``); the map CRS must be projected and metric, since the
collinearity equations hold in a Cartesian frame (a geographic CRS is refused; the Earth's
curvature over a block of a few km is left to the projection, as usual in aerial
triangulation in a map projection).

*First point coordinates* (Hartley & Zisserman 2003, the midpoint method generalised): each
tie point is placed where the sum of squared distances to its rays is least,
``X = (Σ (I − d dᵀ))⁻¹ Σ (I − d dᵀ) C`` with the unit ray directions ``d`` of its
observations (distortion removed); control points start at their given coordinates.

*Active problem*: the observations not culled, of points with ≥ 2 such observations
(control points: ≥ 1), sorted by point, with their weights ``1/σ²``.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, ModelError
from . import bundle_jacobian as bj
from .bundle_lm import Problem
from .bundle_normals import make_structure


def local_frame(block):
    """``(origin (3,), R (m, 3, 3), C (m, 3))``: OpenCV-axis rotations and local centres."""
    C = np.array([[e.X, e.Y, e.Z] for e in block.eo], dtype=np.float64)
    origin = C.mean(axis=0)
    R = np.stack([e.rotation_cv for e in block.eo])
    return origin, R, C - origin


def _counts(block, active):
    return np.bincount(block.obs_point[active], minlength=len(block.point_ids))


def active_points(block, active) -> np.ndarray:
    """Points kept: control with ≥ 1 active observation, others with ≥ 2."""
    n = _counts(block, active)
    return np.where(block.role == "control", n >= 1, n >= 2)


def check_block(block, opts) -> None:
    """Refuse a block that cannot be adjusted, naming what is wrong and the fix."""
    from .bundle_types import ROLES
    from .bundle_jacobian import INTERIOR_NAMES
    m, n, P = len(block.frames), len(block.obs_frame), len(block.point_ids)
    if len(block.eo) != m or m < 2:
        raise InputError(f"bundle adjustment needs ≥ 2 frames and one exterior orientation per frame; got "
                         f"{m} frames and {len(block.eo)} orientations")
    if block.obs_pixel.shape != (n, 2) or len(block.obs_point) != n or not np.isfinite(block.obs_pixel).all():
        raise InputError("image observations: obs_frame, obs_point (n,) and obs_pixel (n, 2) must match and be finite")
    if n and (block.obs_frame.min() < 0 or block.obs_frame.max() >= m or block.obs_point.min() < 0
              or block.obs_point.max() >= P):
        raise InputError("image observations refer to frames or points that do not exist")
    bad = sorted(set(map(str, block.role)) - set(ROLES))
    if bad:
        raise InputError(f"point roles must be one of {ROLES}; got {bad}")
    unknown = sorted(set(opts.self_calibration) - set(INTERIOR_NAMES))
    if unknown:
        raise InputError(f"self_calibration: unknown parameters {unknown}; choose from {INTERIOR_NAMES}")
    if block.crs is not None:
        from ..crs import parse_crs, require_projected
        require_projected(parse_crs(block.crs), "bundle adjustment map CRS")
    known = block.role != "tie"
    if not np.isfinite(block.point_xyz[known]).all():
        raise InputError("control and check points need finite X, Y, Z")
    ctrl = block.role == "control"
    if not (block.point_sigma[ctrl] > 0).all():
        raise InputError("control points need a σ > 0 for X, Y and Z")
    _check_datum(block, np.ones(n, bool), opts)
    check_frames(block, np.ones(n, bool), InputError)


def _check_datum(block, active, opts):
    n_ctrl = int(np.count_nonzero(active_points(block, active) & (block.role == "control")))
    if n_ctrl < 3 and not (eo_weights(opts.eo_sigma, len(block.frames))[:, :3] > 1e-9).any():
        raise InputError(f"the block has {n_ctrl} control point(s) seen in a frame; the datum needs at least 3 "
                         f"(not on one line), or priors on the approximate projection centres "
                         f"(eo_sigma_position, e.g. GNSS/INS centres)", option="eo_sigma_position")


def lonely_frames(block, active=None) -> list:
    """The frames not reached by points of the block (fewer than 3 observations, or no point other frames
    see too and fewer than 3 control observations)."""
    active = np.ones(len(block.obs_frame), bool) if active is None else active
    keep = active & active_points(block, active)[block.obs_point]
    per_frame = np.bincount(block.obs_frame[keep], minlength=len(block.frames))
    tie = keep & (block.role[block.obs_point] != "control")
    tie_frame = np.bincount(block.obs_frame[tie], minlength=len(block.frames))
    ctrl_frame = per_frame - tie_frame
    return [block.frames[j] for j in range(len(block.frames))
            if per_frame[j] < 3 or (tie_frame[j] == 0 and ctrl_frame[j] < 3)]


def check_frames(block, active, error=InputError) -> None:
    """Every frame must be reached by points of the block (:func:`lonely_frames`); the message names the
    frames that are not."""
    lonely = lonely_frames(block, active)
    if lonely:
        err = error(f"frame(s) {', '.join(map(repr, lonely[:10]))} reached by no tie point (or fewer than 3 "
                    f"observations): they do not overlap the block or matching found nothing there; remove them "
                    f"or add tie points")
        err.frames = tuple(lonely)  # for a caller that may leave them out (triangulate --undetermined drop)
        raise err


def initial_points(block, origin, R, C, interior) -> np.ndarray:
    """First local coordinates of every point (module docstring); NaN where no two rays meet."""
    P = len(block.point_ids)
    scale = bj.pixel_scale(block.camera)
    d = bj.undistort_rays(block.obs_pixel, interior, scale)
    d = np.einsum("nij,nj->ni", R[block.obs_frame], d)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    M = np.eye(3) - d[:, :, None] * d[:, None, :]
    A = np.zeros((P, 3, 3))
    b = np.zeros((P, 3))
    np.add.at(A, block.obs_point, M)
    np.add.at(b, block.obs_point, np.einsum("nij,nj->ni", M, C[block.obs_frame]))
    X = np.full((P, 3), np.nan)
    ok = np.linalg.cond(A) < 1e8
    X[ok] = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    ctrl = block.role == "control"
    X[ctrl] = block.point_xyz[ctrl] - origin
    return X


def build_problem(block, active, free_interior, origin, eo_sigma) -> Problem:
    """The :class:`~fotogeo.orientation.bundle_lm.Problem` of the active observations."""
    pts = active_points(block, active)
    keep = active & pts[block.obs_point]
    check_frames(block, keep, ModelError)
    point_ids = np.flatnonzero(pts)
    compact = np.full(len(block.point_ids), -1)
    compact[point_ids] = np.arange(len(point_ids))
    obs = np.flatnonzero(keep)
    obs = obs[np.lexsort((block.obs_frame[obs], compact[block.obs_point[obs]]))]  # by point, then frame
    st = make_structure(block.obs_frame[obs], compact[block.obs_point[obs]], len(block.frames), len(point_ids),
                        free_interior)
    sigma = np.ones(len(block.obs_frame)) if block.obs_sigma is None else np.asarray(block.obs_sigma, float)
    ctrl = block.role[point_ids] == "control"
    ctrl_w = np.where(ctrl[:, None], 1.0 / np.maximum(block.point_sigma[point_ids], 1e-12) ** 2, 0.0)
    ctrl_xyz = np.where(ctrl[:, None], block.point_xyz[point_ids] - origin, 0.0)
    m = len(block.frames)
    R0 = np.stack([e.rotation_cv for e in block.eo])
    C0 = np.array([[e.X, e.Y, e.Z] for e in block.eo]) - origin
    eo_w = eo_weights(eo_sigma, m)
    return Problem(st, block.obs_pixel[obs], 1.0 / sigma[obs] ** 2, obs, point_ids, ctrl_w, ctrl_xyz, eo_w, C0,
                   R0, bj.pixel_scale(block.camera))


def eo_weights(eo_sigma, m: int) -> np.ndarray:
    """``(m, 6)`` weights of the priors on the approximate orientation: ``eo_sigma`` None (free), a pair
    ``(σ position m, σ angles °)`` for every frame, or an ``(m, 6)`` array of σ per frame and parameter
    ``(X0, Y0, Z0 m, ω, φ, κ °)`` where ``inf`` or NaN leaves the parameter free."""
    if eo_sigma is None:
        return np.zeros((m, 6))
    s = np.asarray(eo_sigma, dtype=np.float64)
    if s.ndim == 1:
        s = np.tile(np.repeat(s[:2], 3), (m, 1))
    if s.shape != (m, 6):
        raise InputError(f"eo_sigma: expected (σ position, σ angle) or one row of 6 σ per frame ({m}); got {s.shape}")
    s = s.copy()
    s[:, 3:] = np.radians(s[:, 3:])
    with np.errstate(divide="ignore"):
        w = np.where(np.isfinite(s) & (s > 0), 1.0 / np.where(s > 0, s, 1.0) ** 2, 0.0)
    return w
