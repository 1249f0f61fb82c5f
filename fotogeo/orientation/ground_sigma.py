"""Predicted planimetric precision of the ground points an adjusted frame puts on a DEM (array layer).

An orthophoto cell at ground point ``P = (X, Y, h(X, Y))`` shows image pixel ``x = x(P; q)`` of a frame, the
collinearity of :mod:`fotogeo.orientation.bundle_jacobian` with the frame's parameters
``q = (X0, Y0, Z0, δθ, interior)``: the projection centre (m), the rotation increment ``δθ`` about the OpenCV
camera axes (rad; ``R ← R·exp([δθ]×)``) and the free interior parameters. If ``q`` is off by ``δq`` and the DEM
by ``ε`` (its height error at ``P``), the same image content lies at ``P + δP`` with the ray still through the
pixel and ``δP`` on the surface ``Z = h(X, Y) + ε``::

    0 = J_P δP + J_q δq,   δP = T δXY + (0, 0, ε)ᵀ,   T = [[1, 0], [0, 1], [h_X, h_Y]]
    δXY = −B⁻¹ (J_q δq + J_Z ε),   B = J_P T   (2 × 2)

with ``J_P = ∂x/∂P`` (2 × 3, ``J_Z`` its third column), ``J_q = ∂x/∂q`` the bundle adjustment's own analytic
Jacobians. First-order propagation (the ray–DEM intersection linearised at ``P``) gives the planimetric
covariance and σ::

    Σ_XY = B⁻¹ (J_q Σ_q J_qᵀ + σ_h² J_Z J_Zᵀ) B⁻ᵀ,   σ_P = √(Σ_XX + Σ_YY)

``Σ_q`` is the adjustment's ``σ₀² S⁻¹`` block of the frame (and of the free interior parameters, with their
cross-covariance); ``σ_h`` the DEM's height σ, uncorrelated with the orientation. The DEM term is the height
error mapped through the ray's slope: the ray direction ``d = C − P`` keeps the pixel, ``J_P d = 0``, so on flat
ground ``−B⁻¹ J_Z = d_XY / d_Z`` and the term is ``σ_h · tan(off-nadir angle)``
(``σ_h |d_XY| / (d_Z − ∇h·d_XY)`` on a slope). ``σ_P`` is comparable with the planimetric RMSE of check points, ``√(RMSE_X² + RMSE_Y²)``
(:mod:`fotogeo.orientation.bundle_result`). First-order error propagation as in Mikhail, Bethel & McGlone (2001).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bundle_jacobian as bj

#: ground points per vectorised chunk (the Jacobians are ``(n, 2, 26)``: ~10 MB per 25 000 points)
CHUNK = 25_000


@dataclass(frozen=True)
class FrameCovariance:
    """The covariance of one frame's orientation (module docstring): ``eo`` ``(6, 6)`` in the order
    X0, Y0, Z0 (m), δθ (rad); with self-calibration ``interior`` ``(k, k)`` of the parameters named ``free``
    (:data:`~fotogeo.orientation.bundle_jacobian.INTERIOR_NAMES`) and ``cross`` ``(6, k)``."""
    eo: np.ndarray
    free: tuple = ()
    interior: np.ndarray | None = None
    cross: np.ndarray | None = None

    def matrix(self) -> np.ndarray:
        """``Σ_q`` of ``q = (X0, Y0, Z0, δθ, free interior)``."""
        if not self.free:
            return np.asarray(self.eo, float)
        return np.block([[self.eo, self.cross], [np.asarray(self.cross).T, self.interior]])

    def columns(self) -> list:
        """Indices of ``q``'s interior parameters in :data:`~fotogeo.orientation.bundle_jacobian.INTERIOR_NAMES`."""
        return [bj.INTERIOR_NAMES.index(k) for k in self.free]


def planimetric_covariance(rotation_cv, centre, interior, scale, P, gradient, cov: FrameCovariance,
                           dem_sigma: float = 0.0) -> np.ndarray:
    """``Σ_XY`` ``(N, 2, 2)`` (m²) of ground points ``P`` ``(N, 3)`` on a surface of gradient ``(N, 2)``
    ``(h_X, h_Y)`` seen by the frame ``(rotation_cv, centre, interior, scale)`` (the arguments of
    :func:`~fotogeo.orientation.bundle_jacobian.project_with_jacobians`; module docstring). NaN where the
    point is behind the camera or the ray grazes the surface."""
    J_P, inner = image_terms(rotation_cv, centre, interior, scale, P, cov, dem_sigma)
    return surface_covariance(J_P, inner, gradient)


def image_terms(rotation_cv, centre, interior, scale, P, cov: FrameCovariance, dem_sigma: float = 0.0) -> tuple:
    """``(J_P (N, 2, 3), J_q Σ_q J_qᵀ + σ_h² J_Z J_Zᵀ (N, 2, 2))`` at ground points ``P`` (module docstring): what
    does not depend on the surface's slope; ``J_P`` NaN behind the camera."""
    P = np.asarray(P, np.float64).reshape(-1, 3)
    J_P, inner = np.full((len(P), 2, 3), np.nan), np.full((len(P), 2, 2), np.nan)
    S, cols = cov.matrix(), cov.columns()
    for s in range(0, len(P), CHUNK):
        J_P[s:s + CHUNK], inner[s:s + CHUNK] = _terms(rotation_cv, centre, interior, scale, P[s:s + CHUNK], S, cols,
                                                      dem_sigma)
    return J_P, inner


def _terms(R, C, interior, scale, P, S, cols, dem_sigma):
    n = len(P)
    zero = np.zeros(n, np.intp)
    ebner = any(k >= bj.N_PHYSICAL for k in cols)  # Ebner's columns only when they are estimated
    _, J_eo, J_P, J_int, c = bj.project_with_jacobians(np.asarray(R, float)[None], np.asarray(C, float)[None], P,
                                                        zero, np.arange(n), np.asarray(interior, float), scale,
                                                        additional=ebner)
    J_q = np.concatenate([J_eo, J_int[:, :, cols]], axis=2) if cols else J_eo
    inner = J_q @ S @ J_q.transpose(0, 2, 1)
    if dem_sigma:
        Jz = J_P[:, :, 2]
        inner += dem_sigma ** 2 * Jz[:, :, None] * Jz[:, None, :]
    J_P[c[:, 2] <= 0] = np.nan
    return J_P, inner


def surface_covariance(J_P, inner, gradient) -> np.ndarray:
    """``Σ_XY = B⁻¹ inner B⁻ᵀ``, ``B = J_P T`` on a surface of gradient ``(N, 2)`` (module docstring); NaN where
    the ray grazes the surface (``B`` singular)."""
    g = np.asarray(gradient, np.float64).reshape(-1, 2)
    B = J_P[:, :, :2] + J_P[:, :, 2:3] * g[:, None, :]  # J_P T
    det = B[:, 0, 0] * B[:, 1, 1] - B[:, 0, 1] * B[:, 1, 0]
    with np.errstate(invalid="ignore"):
        ok = np.abs(det) > 1e-12 * np.abs(B).max(axis=(1, 2)) ** 2
    Binv = np.full_like(B, np.nan)
    Binv[ok, 0, 0], Binv[ok, 1, 1] = B[ok, 1, 1] / det[ok], B[ok, 0, 0] / det[ok]
    Binv[ok, 0, 1], Binv[ok, 1, 0] = -B[ok, 0, 1] / det[ok], -B[ok, 1, 0] / det[ok]
    return Binv @ inner @ Binv.transpose(0, 2, 1)


def planimetric_sigma(*args, **kwargs) -> np.ndarray:
    """``σ_P = √(Σ_XX + Σ_YY)`` ``(N,)`` (m) of :func:`planimetric_covariance`'s arguments."""
    cov = planimetric_covariance(*args, **kwargs)
    return np.sqrt(cov[:, 0, 0] + cov[:, 1, 1])


#: how the triangulation report's covariances read (``fotogeo triangulate`` report.json → ``fotogeo ortho
#: --uncertainty``)
COVARIANCE_NOTE = ("frames[].covariance: max(sigma0, 1)^2 (statistics.covariance_scale) times the inverse normal "
                   "matrix block, or, when an observation group's own sigma0 is larger (statistics.covariance_rule), "
                   "the inverse normal matrix with each group's weights divided by its variance component "
                   "squared (statistics.group_factors), at the orientations re-solved with those weights; "
                   "of X0, Y0, Z0 (m, map axes) "
                   "and the rotation increments about the OpenCV camera axes x right, y down, z forward (rad; "
                   "R <- R exp([d]x)); with self-calibration frames[].covariance_interior (6 x k) and "
                   "interior_covariance (k x k) of covariance_parameters")


def covariance_header(result) -> dict:
    """The report's note on its covariances and, with self-calibration, the interior block; nothing for a
    :class:`~fotogeo.orientation.bundle.BundleResult` without covariance."""
    if result.eo_covariance is None:
        return {}
    out = {"covariance_note": COVARIANCE_NOTE, "covariance_parameters": list(result.interior_free)}
    if result.interior_free:
        out["interior_covariance"] = np.asarray(result.interior_covariance).tolist()
    return out


def frame_covariance_entry(result, j: int) -> dict:
    """Frame ``j``'s report entries: ``covariance`` (6 x 6) and, with self-calibration, ``covariance_interior``
    (6 x k)."""
    if result.eo_covariance is None:
        return {}
    out = {"covariance": np.asarray(result.eo_covariance[j]).tolist()}
    if result.interior_free:
        out["covariance_interior"] = np.asarray(result.eo_interior_covariance[j]).tolist()
    return out


def covariances_from_report(rep: dict) -> dict:
    """name → :class:`FrameCovariance` of the frames of a triangulation report that carry one."""
    free = tuple(rep.get("covariance_parameters") or ())
    interior = np.asarray(rep["interior_covariance"], float) if free else None
    out = {}
    for f in rep.get("frames", []):
        if "covariance" in f:
            cross = np.asarray(f["covariance_interior"], float).reshape(6, len(free)) if free else None
            out[f["name"]] = FrameCovariance(np.asarray(f["covariance"], float).reshape(6, 6), free, interior, cross)
    return out
