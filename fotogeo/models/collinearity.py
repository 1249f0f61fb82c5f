"""Space resection: the collinearity equations with known interior orientation.

Ground ``(X, Y, Z)`` -> pixel ``(col, row)`` through a pinhole camera (see
:mod:`fotogeo.geometry.camera` for the equations and the PATB angle convention)::

    (x, y, z) = (R(ω, φ, κ)·diag(1, −1, −1))ᵀ (X − C),   col = fx x/z + ppx,   row = fy y/z + ppy

The 6 exterior-orientation unknowns ``C = (X0, Y0, Z0)``, ``ω, φ, κ`` (degrees) are estimated
from ≥ 4 GCPs by Levenberg–Marquardt on the weighted image error Σ w |pixel − f(X)|² (a step is taken
only when it lowers the error with every point in front of the camera), with the rotation updated
multiplicatively (``R ← R·exp([δθ]×)``), starting from the 3-D DLT
(:class:`~fotogeo.models.spatial.DLT`, ≥ 6 points, not coplanar) decomposed with the known
calibration matrix ``K``: ``K⁻¹ P[:, :3] ∝ (R·D)ᵀ`` (nearest rotation by SVD), ``C = −P[:, :3]⁻¹
P[:, 3]``, or from OpenCV's ``solvePnP`` (SQPnP, Terzakis & Lourakis 2020), whichever has the smaller
weighted image error with every point in front of the camera. The DLT's 11 parameters are poorly
determined on nearly flat ground seen obliquely (±8 m of relief 80 m below a camera tilted 30°: its start
120 px off; the undamped Gauss-Newton from it put points behind the camera, the damped one converges),
where SQPnP, which needs no relief, starts within 2 px; with fewer than 6 points only SQPnP starts.

The interior orientation is fixed: it is the fit option ``camera`` (a
:class:`~fotogeo.geometry.camera.FrameCamera`) of :meth:`Collinearity.estimate`, which every
generic fit passes on (``fit_options={"camera": camera}`` of :func:`~fotogeo.models.ransac`,
or ``Collinearity.options_from(camera=camera)``). ``params`` holds the 6 unknowns (X0, Y0,
Z0 in map units; ω, φ, κ in degrees) followed by the 7 fixed interior values (f, sensor w, h,
image w, h, ppx, ppy), so :func:`~fotogeo.models.base.model_from_dict` restores the model;
``n_params`` counts the 6 unknowns. The normalisations are the identity (the resection is
computed in map units relative to the points' centroid).

``info``: ``sigma0`` = sqrt(vᵀPv / (2n − 6)) (px), ``std`` (standard deviations of the 6
unknowns, σ0²·(JᵀPJ)⁻¹, in map units and degrees; NaN for an unknown the points leave undetermined, by the
bundle's rule, :mod:`fotogeo.models.precision`), ``cond`` (of the scaled Jacobian),
``iterations``, ``init`` ("dlt" or "pnp").
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import InputError, ModelError
from ..geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame, angles_patb, nearest_rotation
from ..geometry.dem import is_height_source
from .base import Normalisation, check_pairs, register_model
from .precision import determined_sqrt, ridge_inverse
from .spatial import DLT, FittedModel

_D = np.diag([1.0, -1.0, -1.0])


def _rodrigues(v: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(v))
    if th < 1e-15:
        return np.eye(3)
    k = v / th
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * Kx + (1 - math.cos(th)) * Kx @ Kx


@register_model
class Collinearity(FittedModel):
    name = "collinearity"
    n_params = 6
    min_points = 4
    src_dims = 3
    fit_options = {"camera": "the interior orientation: give the camera (focal length, sensor and image "
                             "size), e.g. --camera interior_orientation.yaml"}

    # -- geometry ------------------------------------------------------------------------------
    @property
    def frame(self) -> OrientedFrame:
        p = self.params
        cam = FrameCamera(p[6], (p[7], p[8]), (int(p[9]), int(p[10])), (p[11], p[12]))
        return OrientedFrame(cam, ExteriorOrientation(*p[:6]))

    @property
    def projection_centre(self) -> np.ndarray:
        """The camera's projection centre ``(X, Y, Z)``."""
        return self.frame.eo.centre

    def _apply(self, s):  # identity normalisations: s are map coordinates
        return self.frame.world_to_pixel(s)

    def inverse(self, dst, heights=None, **_):
        """Pixels -> ground at fixed ``heights`` (a number or one per point) or on a DEM (exact ray
        intersection, :meth:`~fotogeo.geometry.camera.OrientedFrame.pixel_to_world`)."""
        if heights is None:
            raise InputError("collinearity: the inverse needs the height: pass heights= (a number, one per "
                             "point, or a DEM)")
        if is_height_source(heights):
            return self.frame.pixel_to_world(dst, heights)
        return self.frame.pixel_to_world_at(dst, heights)

    # -- estimation -------------------------------------------------------------------------
    @classmethod
    def estimate(cls, src, dst, weights=None, *, camera: FrameCamera | None = None,
                 iterations: int = 30):
        """Space resection from GCPs ``src`` (X, Y, Z) -> ``dst`` (col, row); see the module doc."""
        if camera is None:
            raise InputError("collinearity needs the interior orientation: pass camera= (a FrameCamera), "
                             "e.g. fit_options={'camera': camera} through ransac or fit_orientation")
        src, dst, w = check_pairs(cls, src, dst, weights)
        use = w > 0
        ctr = Normalisation.of(src[use]).offset
        s = src - ctr  # local coordinates for conditioning
        K = np.array([[camera.fx, 0, camera.principal_point[0]], [0, camera.fy, camera.principal_point[1]],
                      [0, 0, 1.0]])
        C, Rcv, init = cls._start(s[use], dst[use], w[use], K)
        C, Rcv, info = cls._levenberg_marquardt(s, dst, w, K, C, Rcv, iterations)
        ang = angles_patb(Rcv @ _D)
        fixed = [camera.focal_length, *camera.sensor_size, *camera.image_size, *camera.principal_point]
        params = np.array([*(C + ctr), *ang, *fixed], dtype=np.float64)
        ident3 = Normalisation(np.zeros(3), np.ones(3))
        ident2 = Normalisation(np.zeros(2), np.ones(2))
        info.update(init=init, n_points=int(np.count_nonzero(use)))
        model = cls(params, ident3, ident2, info)
        model._warn_if_ill_posed()
        return model

    @classmethod
    def _start(cls, s, d, w, K):
        """``(C, R, "dlt" or "pnp")``: the start that reprojects the points better (module docstring)."""
        starts = {}
        try:
            if len(s) < DLT.min_points:
                raise ModelError("too few points for the DLT start")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                starts["dlt"] = cls._decompose(DLT.estimate(s, d, w).world_matrix(), K)
        except ModelError:
            pass
        try:
            starts["pnp"] = cls._pnp(s, d, K)
        except ModelError:
            if not starts:
                raise
        cost = {k: cls._start_cost(s, d, w, K, *v) for k, v in starts.items()}
        best = min(cost, key=cost.get)
        return (*starts[best], best)

    @classmethod
    def _start_cost(cls, s, d, w, K, C, Rcv) -> float:
        """Σ w |pixel − f(X)|² of a start; infinite when a point lies behind its camera."""
        px, c = cls._project(s, K, C, Rcv)
        return float(np.sum(w * np.sum((d - px) ** 2, axis=1))) if np.all(c[:, 2] > 0) else math.inf

    @staticmethod
    def _decompose(P, K):
        M = np.linalg.solve(K, P[:, :3])
        if np.linalg.det(M) < 0:
            M, P = -M, -P
        if np.linalg.cond(M) > 1e9:
            raise ModelError("degenerate DLT")
        Rt = nearest_rotation(M)  # (R·D)ᵀ
        C = -np.linalg.solve(P[:, :3], P[:, 3])
        return C, Rt.T

    @staticmethod
    def _pnp(s, d, K):
        import cv2

        flags = cv2.SOLVEPNP_SQPNP if len(s) >= 3 else cv2.SOLVEPNP_ITERATIVE
        # K and d share the corner convention, so no half-pixel shift is needed here
        try:
            ok, rvec, tvec = cv2.solvePnP(s.astype(np.float64), d.astype(np.float64), K, None, flags=flags)
        except cv2.error:
            ok = False
        if not ok:
            raise ModelError("collinearity: no initial exterior orientation found (solvePnP failed); "
                             "check that the GCP ground and pixel coordinates correspond")
        Rt, _ = cv2.Rodrigues(rvec)
        Rt = Rt.astype(np.float64)
        return -Rt.T @ tvec.reshape(3), Rt.T

    @staticmethod
    def _project(s, K, C, Rcv):
        c = (s - C) @ Rcv
        return np.column_stack([K[0, 0] * c[:, 0] / c[:, 2] + K[0, 2], K[1, 1] * c[:, 1] / c[:, 2] + K[1, 2]]), c

    @classmethod
    def _jacobian(cls, s, K, C, Rcv, scale):
        """∂pixels/∂(C / scale, δθ) by central differences (the rotation perturbed as ``R·exp([δθ]×)``)."""
        h, cols = 1e-6, []
        for k in range(6):
            e = np.zeros(6)
            e[k] = h
            pm = [cls._project(s, K, C + sgn * e[:3] * scale, Rcv @ _rodrigues(sgn * e[3:]))[0].reshape(-1)
                  for sgn in (1, -1)]
            cols.append((pm[0] - pm[1]) / (2 * h))
        return np.column_stack(cols)

    @classmethod
    def _levenberg_marquardt(cls, s, d, w, K, C, Rcv, iterations):
        """Levenberg–Marquardt (Levenberg 1944, Marquardt 1963) on Σ w |pixel − f(X)|²: the step solves
        ``(JᵀPJ + λ·diag(JᵀPJ)) δ = JᵀP r`` and is taken only when it lowers the cost with every point in front of
        the camera; λ ÷ 10 after a step taken, × 10 after one refused (λ starts at 1e-3: near the minimum the steps
        are Gauss–Newton's). Undamped, a start 120 px off (a DLT over flat ground seen 30° off nadir) put points
        behind the camera."""
        sw = np.sqrt(np.repeat(w, 2))
        scale = float(np.median(np.linalg.norm(s - C, axis=1)))  # distance: balances position and angle
        cost = cls._start_cost(s, d, w, K, C, Rcv)
        if not math.isfinite(cost):
            raise ModelError("collinearity: GCPs fall behind the camera of the start (DLT or SQPnP); "
                             "check the points (ground/pixel order, units)")
        lam, it, J = 1e-3, 0, None
        for it in range(1, iterations + 1):
            px, _ = cls._project(s, K, C, Rcv)
            J = cls._jacobian(s, K, C, Rcv, scale)
            Jw, rw = J * sw[:, None], (d - px).reshape(-1) * sw
            N, g = Jw.T @ Jw, Jw.T @ rw
            while lam < 1e12:
                step = np.linalg.lstsq(N + lam * np.diag(np.diag(N)), g, rcond=None)[0]
                C1, R1 = C + step[:3] * scale, Rcv @ _rodrigues(step[3:])
                cost1 = cls._start_cost(s, d, w, K, C1, R1)
                if cost1 <= cost:
                    break
                lam *= 10.0
            else:
                break  # no step lowers the cost: converged
            C, Rcv, lam, done = C1, R1, max(lam / 10.0, 1e-12), cost - cost1 <= 1e-15 * cost
            cost = cost1
            if np.max(np.abs(step)) < 1e-12 or done:
                break
        px, _ = cls._project(s, K, C, Rcv)
        v = (d - px).reshape(-1)
        dof = max(1, len(v) - 6 - int(np.sum(w == 0)) * 2)
        sigma0 = float(np.sqrt(np.sum(np.repeat(w, 2) * v ** 2) / dof))
        Jw = J * sw[:, None]
        sv = np.linalg.svd(Jw, compute_uv=False)
        info = {"sigma0": sigma0, "cond": float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf"),
                "iterations": it}
        N = Jw.T @ Jw
        q = np.diag(ridge_inverse(N))
        std = determined_sqrt(q, q * np.diag(N)) * sigma0  # NaN: undetermined, the bundle's rule
        info["std"] = [*(std[:3] * scale), *np.degrees(std[3:])]  # rotation std about camera axes
        return C, Rcv, info

    def to_dict(self) -> dict:
        d = super().to_dict()
        d["params_names"] = ["X0", "Y0", "Z0", "omega", "phi", "kappa", "focal_length", "sensor_w",
                             "sensor_h", "image_w", "image_h", "ppx", "ppy"]
        return d

