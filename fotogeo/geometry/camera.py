"""Frame (pinhole) cameras, exterior orientation and the ray-DEM intersection.

Interior orientation (:class:`FrameCamera`): focal length ``f`` and sensor size
``(sensor_w, sensor_h)`` in the same unit (mm), image size ``(w, h)`` in pixels, principal
point ``(ppx, ppy)`` in pixels in the GDAL *corner* convention (see :mod:`fotogeo.pixels`;
an undisplaced principal point is the image centre ``(w/2, h/2)``). Focal lengths in pixels:
``fx = f·w/sensor_w``, ``fy = f·h/sensor_h``.

Exterior orientation (:class:`ExteriorOrientation`): projection centre ``C = (X0, Y0, Z0)``
and angles ``ω, φ, κ`` (degrees) in the "PATB" convention:
``R = Rx(ω)·Ry(φ)·Rz(κ)`` rotates camera axes to world axes, camera axes x right, y up,
z backwards (the camera looks along its −z). With ``D = diag(1, −1, −1)`` (to OpenCV camera
axes x right, y down, z forward)::

    (x, y, z) = (R·D)ᵀ (X − C)
    col = fx·x/z + ppx,   row = fy·y/z + ppy          (GDAL corner convention)

which is the data README's ``col = fx·x/z + (w−1)/2`` (centre convention) plus 0.5
(:func:`fotogeo.pixels.from_centre`). The inverse maps a pixel to the ray
``X(λ) = C + λ·R·D·((col−ppx)/fx, (row−ppy)/fy, 1)``, λ > 0, and
:meth:`OrientedFrame.pixel_to_world` intersects it with a DEM.

NGI data readers: :func:`read_interior_orientation` (the orthority-style YAML, read
through PyYAML), :func:`read_exterior_orientation` (``name X Y Z omega phi kappa``
lines) and :func:`load_ngi_frame`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ModelError
from ..pixels import as_points
from .dem import as_height_source

_D = np.diag([1.0, -1.0, -1.0])


def rotation_patb(omega: float, phi: float, kappa: float) -> np.ndarray:
    """``R = Rx(ω)·Ry(φ)·Rz(κ)`` (angles in degrees; camera axes -> world axes).

    ``Rx(a) = [[1,0,0],[0,cos a,−sin a],[0,sin a,cos a]]``, ``Ry``, ``Rz`` likewise
    (counter-clockwise rotations of the vector about the axis).
    """
    o, p, k = np.radians([omega, phi, kappa])
    Rx = np.array([[1, 0, 0], [0, math.cos(o), -math.sin(o)], [0, math.sin(o), math.cos(o)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(k), -math.sin(k), 0], [math.sin(k), math.cos(k), 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def angles_patb(R: np.ndarray) -> tuple[float, float, float]:
    """Inverse of :func:`rotation_patb`: (ω, φ, κ) in degrees, φ in [−90°, 90°]."""
    R = np.asarray(R, dtype=np.float64)
    phi = math.asin(max(-1.0, min(1.0, R[0, 2])))
    omega = math.atan2(-R[1, 2], R[2, 2])
    kappa = math.atan2(-R[0, 1], R[0, 0])
    return math.degrees(omega), math.degrees(phi), math.degrees(kappa)


def nearest_rotation(M) -> np.ndarray:
    """The rotation closest to the square matrix ``M`` in the Frobenius norm: ``argmin ‖R − M‖_F`` over
    ``R`` with ``RᵀR = I`` and ``det R = +1``.

    With ``M = U S Vᵀ`` (SVD), ``R = U diag(1, …, 1, det(U Vᵀ)) Vᵀ``: the maximiser of ``trace(Rᵀ M)``
    (Kabsch 1976; Horn 1987 reaches the same rotation by unit quaternions). The sign on the last axis turns a
    reflection (``det(U Vᵀ) = −1``) into a rotation, so a reflected or noisy input still gives ``det R = +1``.
    Used both to orthonormalise a nearly orthogonal matrix (``M`` itself) and to solve Wahba's (1965) problem
    ``min Σ |R dᵢ − uᵢ|²`` (``M = Σ uᵢ dᵢᵀ``). The rotation is unique when ``M`` has rank ≥ ``n − 1``
    (and its two smallest singular values differ when ``det M < 0``).
    """
    M = np.asarray(M, dtype=np.float64)
    if M.ndim != 2 or M.shape[0] != M.shape[1] or not np.isfinite(M).all():
        raise InputError(f"nearest_rotation: M must be a finite square matrix; got shape {M.shape}")
    U, _, Vt = np.linalg.svd(M)
    U[:, -1] *= 1.0 if np.linalg.det(U @ Vt) >= 0 else -1.0
    return U @ Vt


@dataclass(frozen=True)
class FrameCamera:
    """Pinhole interior orientation (see the module docstring for the equations)."""

    focal_length: float
    sensor_size: tuple[float, float]
    image_size: tuple[int, int]
    principal_point: tuple[float, float] | None = None

    def __post_init__(self):
        if not (self.focal_length > 0 and min(self.sensor_size) > 0 and min(self.image_size) > 0):
            raise InputError("FrameCamera: focal length, sensor size and image size must be positive; "
                             f"got f={self.focal_length}, sensor={self.sensor_size}, image={self.image_size}")
        if self.principal_point is None:
            w, h = self.image_size
            object.__setattr__(self, "principal_point", (w / 2.0, h / 2.0))

    @property
    def fx(self) -> float:
        return self.focal_length * self.image_size[0] / self.sensor_size[0]

    @property
    def fy(self) -> float:
        return self.focal_length * self.image_size[1] / self.sensor_size[1]

    @property
    def K(self) -> np.ndarray:
        """3x3 calibration matrix mapping OpenCV camera axes to corner-convention pixels."""
        return np.array([[self.fx, 0, self.principal_point[0]], [0, self.fy, self.principal_point[1]],
                         [0, 0, 1.0]])

    def project(self, xyz_cv: np.ndarray) -> np.ndarray:
        """OpenCV camera-axis points ``(N, 3)`` (z forward) -> pixels ``(N, 2)`` (corner)."""
        z = xyz_cv[:, 2]
        return np.column_stack([self.fx * xyz_cv[:, 0] / z + self.principal_point[0],
                                self.fy * xyz_cv[:, 1] / z + self.principal_point[1]])

    def rays(self, xy) -> np.ndarray:
        """Pixels ``(N, 2)`` (corner) -> ray directions in OpenCV camera axes, ``z = 1``."""
        p = as_points(xy)
        return np.column_stack([(p[:, 0] - self.principal_point[0]) / self.fx,
                                (p[:, 1] - self.principal_point[1]) / self.fy, np.ones(len(p))])


@dataclass(frozen=True)
class ExteriorOrientation:
    """Projection centre (X, Y, Z) and PATB angles ω, φ, κ in degrees."""

    X: float
    Y: float
    Z: float
    omega: float
    phi: float
    kappa: float

    @property
    def centre(self) -> np.ndarray:
        return np.array([self.X, self.Y, self.Z], dtype=np.float64)

    @property
    def rotation(self) -> np.ndarray:
        """PATB ``R`` (camera axes x right, y up, z backwards -> world axes)."""
        return rotation_patb(self.omega, self.phi, self.kappa)

    @property
    def rotation_cv(self) -> np.ndarray:
        """``R·diag(1, −1, −1)``: OpenCV camera axes (x right, y down, z forward) -> world."""
        return self.rotation @ _D


@dataclass(frozen=True)
class OrientedFrame:
    """A frame camera with its exterior orientation: the full ground <-> image geometry."""

    camera: FrameCamera
    eo: ExteriorOrientation
    name: str = ""

    def world_to_camera(self, XYZ) -> np.ndarray:
        """World points ``(N, 3)`` -> OpenCV camera axes ``(N, 3)`` (z > 0 in front)."""
        P = as_points(XYZ, 3, "world points")
        return (P - self.eo.centre) @ self.eo.rotation_cv

    def world_to_pixel(self, XYZ) -> np.ndarray:
        """World points ``(N, 3)`` -> pixels ``(N, 2)`` (GDAL corner convention).

        Points behind the camera (z ≤ 0) get NaN.
        """
        c = self.world_to_camera(XYZ)
        px = self.camera.project(c)
        px[c[:, 2] <= 0] = np.nan
        return px

    def pixel_to_world_at(self, xy, Z) -> np.ndarray:
        """Pixels ``(N, 2)`` -> world points ``(N, 3)`` on the planes of heights ``Z`` (scalar or (N,))."""
        C, d = self._rays(xy)
        Z = np.broadcast_to(np.asarray(Z, dtype=np.float64), (len(d),))
        lam = (Z - C[2]) / d[:, 2]
        P = C + lam[:, None] * d
        P[lam <= 0] = np.nan
        return P

    def _rays(self, xy):
        d = self.camera.rays(xy) @ self.eo.rotation_cv.T  # world directions, λ > 0 forward
        return self.eo.centre, d

    def pixel_to_world(self, xy, dem, *, tol: float = 1e-6, max_iterations: int = 60) -> np.ndarray:
        """Intersect the rays of pixels ``xy`` ``(N, 2)`` with ``dem``; world points ``(N, 3)``.

        ``dem`` is a :class:`fotogeo.geometry.dem.Dem`, any ``XY -> heights`` sampler, or a constant
        height. The ray is parametrised by its height: ``P(Z) = C + (Z − Z0)/d_z · d``, and
        ``f(Z) = Z − h(P_xy(Z))`` is solved by a safeguarded Newton iteration (``f'`` from the
        bilinear DEM gradient) inside the bracket ``[min DEM − 1, max DEM + 1]``, bisecting
        whenever a Newton step leaves the bracket (vectorised over all points; stops at
        ``|ΔZ| < tol`` map units). Where the ray crosses the terrain more than once (occlusion)
        the result is one of the crossings, not necessarily the visible one. Rays that leave
        the DEM, or never reach it, give NaN.
        """
        src = as_height_source(dem)
        C, d = self._rays(xy)
        n = len(d)
        if hasattr(src, "z_range"):
            zlo, zhi = src.z_range
        else:
            h0 = src.heights_and_gradient(self.pixel_to_world_at(xy, 0.0)[:, :2])[0]
            if not np.isfinite(h0).any():
                return np.full((n, 3), np.nan)
            zlo, zhi = float(np.nanmin(h0)) - 1000.0, float(np.nanmax(h0)) + 1000.0
            zhi = min(zhi, C[2] - 1e-3)  # unknown relief: search below the camera only
        if zhi >= C[2]:
            raise ModelError(f"frame {self.name!r}: the DEM reaches {zhi:.1f}, above the projection "
                             f"centre Z = {C[2]:.1f}; check the DEM and the exterior orientation")
        lo = np.full(n, zlo - 1.0)
        hi = np.full(n, zhi + 1.0)
        dxy = d[:, :2] / d[:, 2:3]  # dP_xy / dZ
        zmean = float(np.nanmean(src.data)) if hasattr(src, "data") else 0.5 * (zlo + zhi)
        Z = np.full(n, zmean)
        last_valid = np.full(n, np.nan)  # last iterate at which the DEM had a height
        active = np.ones(n, bool)
        converged = np.zeros(n, bool)
        for _ in range(max_iterations):
            idx = np.flatnonzero(active)
            if idx.size == 0:
                break
            z = Z[idx]
            P = C[:2] + (z - C[2])[:, None] * dxy[idx]
            h, gx, gy = src.heights_and_gradient(P)
            f = z - h
            fp = 1.0 - (gx * dxy[idx, 0] + gy * dxy[idx, 1])
            lost = ~np.isfinite(h)
            above = f > 0
            hi[idx] = np.where(~lost & above, z, hi[idx])
            lo[idx] = np.where(~lost & ~above, z, lo[idx])
            with np.errstate(divide="ignore", invalid="ignore"):
                zn = z - f / fp
            bad = (~np.isfinite(zn) | (zn <= lo[idx]) | (zn >= hi[idx])) & (f != 0)  # f = 0: exact root
            zn = np.where(bad, 0.5 * (lo[idx] + hi[idx]), zn)
            # off the DEM: step back halfway towards the last iterate that was on it, and
            # exclude the off-DEM side from the bracket (the crossing is assumed nearer)
            lv = last_valid[idx]
            back = lost & np.isfinite(lv)
            hi[idx] = np.where(back & (z > lv), z, hi[idx])
            lo[idx] = np.where(back & (z < lv), z, lo[idx])
            zn = np.where(lost, 0.5 * (z + lv), zn)  # NaN when never on the DEM: gives up
            last_valid[idx] = np.where(lost, lv, z)
            Z[idx] = zn
            done = ~lost & (np.abs(zn - z) < tol)
            converged[idx] = done
            active[idx] = ~done & np.isfinite(zn) & (hi[idx] - lo[idx] > tol)
        Z[~converged] = np.nan
        P = np.column_stack([C[:2] + (Z - C[2])[:, None] * dxy, Z])
        P[~np.isfinite(Z) | (d[:, 2] >= 0)] = np.nan  # NaN also for rays not pointing down
        return P


# -- NGI / orthority-style files ------------------------------------------------------------
