"""The bundle adjustment's observation model and its analytic Jacobians (array layer).

One image observation ``a`` is the pixel ``(col, row)`` (GDAL corner convention) of ground
point ``i`` in frame ``j``. In the camera convention of :mod:`fotogeo.geometry.camera`, with
``R_j = R(ω, φ, κ)·diag(1, −1, −1)`` (OpenCV camera axes x right, y down, z forward → world)
and the projection centre ``C_j``, all in the block's local Cartesian frame::

    c = (x, y, z) = R_jᵀ (X_i − C_j)
    u = x / z,   v = y / z,   r² = u² + v²
    ρ  = 1 + k1 r² + k2 r⁴ + k3 r⁶                                    (radial)
    u' = u ρ + 2 p1 u v + p2 (r² + 2u²)                               (Brown (1971), the
    v' = v ρ + p1 (r² + 2v²) + 2 p2 u v                                OpenCV sign convention:
                                                                      :mod:`fotogeo.geometry.brown`)
    col = fx u' + ppx,   row = fy v' + ppy,   fx = f·w/sensor_w,  fy = f·h/sensor_h

The interior vector is ``(f, ppx, ppy, k1, k2, k3, p1, p2, b1 … b12)`` (:data:`INTERIOR_NAMES`):
``f`` in the camera file's unit (mm), the principal point in pixels (corner convention), the
distortion coefficients on the focal-length-normalised coordinates ``(u, v)`` of the
OpenCV camera axes (y down), then Ebner's (1976) additional parameters
(:mod:`fotogeo.orientation.bundle_ebner`): with them the pixel is
``col = x + ppx + Δx(ξ, η)``, ``row = y + ppy + Δy(ξ, η)``, ``(x, y) = (fx u', fy v')``,
``(ξ, η) = (x / (w/2), y / (h/2))``, and every derivative through ``(x, y)`` is multiplied by
``E = I + ∂(Δx, Δy)/∂(x, y)``. An interior vector of 8 (no additional parameters) is accepted
everywhere and means ``b = 0``.

The rotation is updated multiplicatively, ``R_j ← R_j·exp([δθ]×)`` (``δθ`` about the camera
axes, radians), as in :mod:`fotogeo.models.collinearity`, so that
``∂c/∂δθ = [c]×`` (``c ↦ c × δθ``), ``∂c/∂C = −R_jᵀ``, ``∂c/∂X = R_jᵀ``. With
``A = diag(fx, fy)·∂(u', v')/∂(u, v)·∂(u, v)/∂c`` (2×3 per observation)::

    ∂pixel/∂X_i = A R_jᵀ,   ∂pixel/∂C_j = −A R_jᵀ,   ∂pixel/∂δθ_j = A [c]×

and for the interior: ``∂/∂f = (u'·w/sensor_w, v'·h/sensor_h)``, ``∂/∂ppx = (1, 0)``,
``∂/∂ppy = (0, 1)``, ``∂/∂k_n = (fx u r²ⁿ, fy v r²ⁿ)``, ``∂/∂p1 = (2 fx u v, fy (r² + 2v²))``,
``∂/∂p2 = (fx (r² + 2u²), 2 fy u v)``. Everything is vectorised over the observations
(Triggs et al. (2000), "Bundle adjustment — a modern synthesis", §3–4).
"""
from __future__ import annotations

import numpy as np

from ..geometry import brown
from ..options import EBNER_PARAMETERS, INTERIOR_PARAMETERS
from . import bundle_ebner

INTERIOR_NAMES = INTERIOR_PARAMETERS + EBNER_PARAMETERS  # the one list of their names (fotogeo.options)
N_PHYSICAL = len(INTERIOR_PARAMETERS)

D_CV = np.diag([1.0, -1.0, -1.0])


def rodrigues(v: np.ndarray) -> np.ndarray:
    """Rotation matrices ``exp([v]×)`` for rotation vectors ``v`` ``(m, 3)`` (radians) → ``(m, 3, 3)``."""
    v = np.atleast_2d(np.asarray(v, dtype=np.float64))
    th = np.linalg.norm(v, axis=1)
    safe = np.where(th > 1e-15, th, 1.0)
    k = v / safe[:, None]
    K = np.zeros((len(v), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    s, c = np.sin(th)[:, None, None], (1 - np.cos(th))[:, None, None]
    R = np.eye(3) + s * K + c * (K @ K)
    R[th <= 1e-15] = np.eye(3)
    return R


def log_rotation(R: np.ndarray) -> np.ndarray:
    """Rotation vectors of rotation matrices ``(m, 3, 3)`` (inverse of :func:`rodrigues`, |θ| < π)."""
    R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
    cos = np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)
    th = np.arccos(cos)
    w = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=1)
    scale = np.where(th > 1e-12, th / (2 * np.sin(np.maximum(th, 1e-12))), 0.5)
    return w * scale[:, None]


def pixel_scale(camera) -> np.ndarray:
    """``(w/sensor_w, h/sensor_h, w/2, h/2)``: pixels per unit of focal length (``fx = f·scale[0]``)
    and the half image size (the unit of Ebner's coordinates)."""
    w, h = camera.image_size
    return np.array([w / camera.sensor_size[0], h / camera.sensor_size[1], w / 2.0, h / 2.0])


def _ebner(interior):
    """The additional parameters ``b`` ``(12,)`` of an interior vector, or None when all are 0."""
    b = np.asarray(interior[N_PHYSICAL:], dtype=np.float64)
    return b if b.size and np.any(b != 0) else None


def camera_coordinates(R, C, X, frame, point) -> np.ndarray:
    """``c = R_jᵀ (X_i − C_j)`` per observation ``(n, 3)`` (OpenCV camera axes, z forward)."""
    d = X[point] - C[frame]
    return (d[:, None, :] @ R[frame])[:, 0]


def _distort(c, interior, scale):
    z = c[:, 2]
    u, v = c[:, 0] / z, c[:, 1] / z
    r2, rho, ud, vd = brown.distort(u, v, interior[3:N_PHYSICAL])
    return u, v, r2, rho, ud, vd


def project(R, C, X, frame, point, interior, scale) -> np.ndarray:
    """Pixels ``(n, 2)`` (corner convention) of the observations (module docstring)."""
    return project_camera(camera_coordinates(R, C, X, frame, point), interior, scale)


def project_camera(c, interior, scale) -> np.ndarray:
    """Pixels ``(n, 2)`` of camera-axis points ``c`` ``(n, 3)`` (distortion, focal length, principal point)."""
    _, _, _, _, ud, vd = _distort(c, interior, scale)
    f, ppx, ppy = interior[:3]
    x, y = f * scale[0] * ud, f * scale[1] * vd
    b = _ebner(interior)
    if b is not None:
        dx, dy = bundle_ebner.corrections(b, x / scale[2], y / scale[3])
        x, y = x + dx, y + dy
    return np.column_stack([x + ppx, y + ppy])


def project_with_jacobians(R, C, X, frame, point, interior, scale, additional: bool = True):
    """Pixels ``(n, 2)``, ``J_eo`` ``(n, 2, 6)`` (columns ∂C, ∂δθ), ``J_point`` ``(n, 2, 3)``,
    ``J_interior`` ``(n, 2, 20)`` (:data:`INTERIOR_NAMES`; the columns of Ebner's parameters left 0
    unless ``additional``) and the camera coordinates ``(n, 3)``."""
    c = camera_coordinates(R, C, X, frame, point)
    u, v, r2, rho, ud, vd = _distort(c, interior, scale)
    f, ppx, ppy, k1, k2, k3, p1, p2 = interior[:N_PHYSICAL]
    fx, fy = f * scale[0], f * scale[1]
    n = len(c)
    g = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # dρ/d(r²)
    Jd = np.empty((n, 2, 2))  # ∂(u', v')/∂(u, v)
    Jd[:, 0, 0] = rho + 2 * u * u * g + 2 * p1 * v + 6 * p2 * u
    Jd[:, 0, 1] = 2 * u * v * g + 2 * p1 * u + 2 * p2 * v
    Jd[:, 1, 0] = 2 * u * v * g + 2 * p1 * u + 2 * p2 * v
    Jd[:, 1, 1] = rho + 2 * v * v * g + 6 * p1 * v + 2 * p2 * u
    iz = 1.0 / c[:, 2]
    A = np.empty((n, 2, 3))  # diag(fx, fy)·Jd·∂(u, v)/∂c, ∂(u, v)/∂c = [[1, 0, −u], [0, 1, −v]] / z
    for r, fr in ((0, fx), (1, fy)):
        A[:, r, 0] = fr * iz * Jd[:, r, 0]
        A[:, r, 1] = fr * iz * Jd[:, r, 1]
        A[:, r, 2] = -(A[:, r, 0] * u + A[:, r, 1] * v)
    Rj = R[frame]
    J_point = A @ Rj.transpose(0, 2, 1)  # A Rᵀ
    J_eo = np.concatenate([-J_point, np.cross(A, c[:, None, :])], axis=2)  # a [c]× = a × c (rows a of A)
    J_int = np.zeros((n, 2, len(INTERIOR_NAMES)))
    J_int[:, 0, 0], J_int[:, 1, 0] = ud * scale[0], vd * scale[1]
    J_int[:, 0, 1] = 1.0
    J_int[:, 1, 2] = 1.0
    for k, power in ((3, r2), (4, r2 * r2), (5, r2 * r2 * r2)):
        J_int[:, 0, k], J_int[:, 1, k] = fx * u * power, fy * v * power
    J_int[:, 0, 6], J_int[:, 1, 6] = 2 * fx * u * v, fy * (r2 + 2 * v * v)
    J_int[:, 0, 7], J_int[:, 1, 7] = fx * (r2 + 2 * u * u), 2 * fy * u * v
    pixel = np.column_stack([fx * ud + ppx, fy * vd + ppy])
    b = _ebner(interior)
    if len(scale) > 2 and (additional or b is not None):  # Ebner's terms, at ξ = x / (w/2), η = y / (h/2)
        xi, eta = fx * ud / scale[2], fy * vd / scale[3]
        gx, gy = bundle_ebner.terms(xi, eta)
        J_int[:, 0, N_PHYSICAL:], J_int[:, 1, N_PHYSICAL:] = gx, gy
        if b is not None:  # E = I + ∂Δ/∂(x, y) on every derivative through (x, y)
            E = bundle_ebner.derivatives(b, xi, eta) / scale[2:4][None, None, :]
            E[:, 0, 0] += 1.0
            E[:, 1, 1] += 1.0
            pixel += np.column_stack([gx @ b, gy @ b])
            J_eo, J_point = E @ J_eo, E @ J_point
            chain = [0, *range(3, N_PHYSICAL)]
            J_int[:, :, chain] = E @ J_int[:, :, chain]
    return pixel, J_eo, J_point, J_int, c


def undistort_rays(pixel, interior, scale, iterations: int = 8) -> np.ndarray:
    """Camera-axis ray directions ``(n, 3)`` (z = 1) of pixels, removing Ebner's corrections, then
    Brown's distortion, each by a fixed-point iteration (:func:`fotogeo.geometry.brown.undistort`: converges for
    moderate distortion)."""
    f, ppx, ppy = interior[:3]
    x, y = pixel[:, 0] - ppx, pixel[:, 1] - ppy
    b = _ebner(interior)
    if b is not None:
        x, y = bundle_ebner.remove(x, y, b, scale[2:4])
    u, v = brown.undistort(x / (f * scale[0]), y / (f * scale[1]), interior[3:N_PHYSICAL], iterations)
    return np.column_stack([u, v, np.ones(len(u))])
