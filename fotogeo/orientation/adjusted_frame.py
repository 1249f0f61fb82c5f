"""An adjusted frame as a ground → image model: the bundle adjustment's collinearity with Brown's distortion
(:mod:`fotogeo.orientation.bundle_jacobian`), in the model protocol the orthophoto and the georeference use
(``forward``, ``inverse``, ``src_dims = 3``).

The inverse (pixel → ground) removes the distortion by the fixed-point iteration of
:func:`~fotogeo.orientation.bundle_jacobian.undistort_rays`, then intersects the pinhole ray.
"""
from __future__ import annotations

import numpy as np

from ..geometry import brown
from ..geometry.camera import OrientedFrame
from ..geometry.dem import is_height_source
from ..pixels import as_points
from . import bundle_jacobian as bj

#: rows of a grid window computed together by :meth:`AdjustedFrame.forward_grid` (their temporaries fit in cache)
_ROWS = 32


def _pixels(c, interior, scale, col, row) -> None:
    """Pixels of the camera coordinates ``c`` (three arrays, overwritten) into ``col``, ``row``: pinhole, then Brown's
    radial and decentring terms where they are not 0 (:func:`fotogeo.geometry.brown.distort`)."""
    f, ppx, ppy = interior[:3]
    coeffs = interior[3:bj.N_PHYSICAL]
    fx, fy = f * scale[0], f * scale[1]
    behind = c[2] <= 0
    u, v = np.divide(c[0], c[2], out=c[0]), np.divide(c[1], c[2], out=c[1])
    if not any(coeffs):  # pinhole: col = fx·u + ppx, row = fy·v + ppy
        np.multiply(u, fx, out=col)
        np.multiply(v, fy, out=row)
    else:
        brown.distort(u, v, coeffs, out=(col, row))
        col *= fx
        row *= fy
    col += ppx
    row += ppy
    if behind.any():
        col[behind] = np.nan
        row[behind] = np.nan


class AdjustedFrame:
    """Ground ``(X, Y, Z)`` → pixel of one adjusted frame, distortion included (module docstring)."""

    src_dims = 3

    def __init__(self, camera, eo, distortion: dict, name: str = ""):
        self.frame = OrientedFrame(camera, eo, name)
        self.interior = np.array([camera.focal_length, *camera.principal_point,
                                  *(float(distortion.get(k, 0.0)) for k in bj.INTERIOR_NAMES[3:])])
        self.scale = bj.pixel_scale(camera)

    @property
    def projection_centre(self) -> np.ndarray:
        """The adjusted projection centre ``(X, Y, Z)``: every line of sight ends there
        (:mod:`fotogeo.geometry.occlusion`)."""
        return self.frame.eo.centre

    def forward(self, XYZ) -> np.ndarray:
        c = self.frame.world_to_camera(as_points(XYZ, 3, "ground points"))
        px = bj.project_camera(c, self.interior, self.scale)
        px[c[:, 2] <= 0] = np.nan
        return px

    def forward_grid(self, X, Y, Z) -> np.ndarray:
        """:meth:`forward` of the grid points ``(X[col], Y[row], Z[row, col])`` (``Z`` ``(len(Y), len(X))``) as two
        planes ``(2, len(Y), len(X))``: column, row. The camera coordinates ``c_k = Σ M_ik (P_i − C_i)`` (``M`` =
        ``R·D``) are built from one term per column, one per row and one per point, then ``u = c_0/c_2``,
        ``v = c_1/c_2`` and Brown's terms (:func:`~fotogeo.orientation.bundle_jacobian.project_camera`: radial
        ``ρ = 1 + k1 r² + k2 r⁴ + k3 r⁶``, decentring ``p1``, ``p2``), the same values to rounding; a block of rows
        at a time, so that the temporaries stay in the processor's cache. Points behind the camera are NaN."""
        M, C = self.frame.eo.rotation_cv, self.frame.eo.centre
        dx, dy = np.asarray(X, float) - C[0], np.asarray(Y, float) - C[1]
        Z = np.asarray(Z, float)
        if np.any(self.interior[bj.N_PHYSICAL:]):  # Ebner's additional parameters: the per-point model
            XX, YY = np.meshgrid(np.asarray(X, float), np.asarray(Y, float))
            px = self.forward(np.column_stack([XX.ravel(), YY.ravel(), Z.ravel()]))
            return np.stack([px[:, 0].reshape(Z.shape), px[:, 1].reshape(Z.shape)])
        col = [dx * M[0, k] - C[2] * M[2, k] for k in range(3)]  # c_k = M_2k·Z + (M_0k·dx − M_2k·Z0) + M_1k·dy
        row = [(dy * M[1, k])[:, None] for k in range(3)]
        out = np.empty((2, *Z.shape))
        for r0 in range(0, Z.shape[0], _ROWS):
            r1 = min(Z.shape[0], r0 + _ROWS)
            c = []
            for k in range(3):
                v = np.multiply(Z[r0:r1], M[2, k])
                v += col[k]
                v += row[k][r0:r1]
                c.append(v)
            with np.errstate(invalid="ignore", divide="ignore"):
                _pixels(c, self.interior, self.scale, out[0, r0:r1], out[1, r0:r1])
        return out

    def inverse(self, pixel, heights=None, **_) -> np.ndarray:
        rays = bj.undistort_rays(as_points(pixel, 2, "pixels"), self.interior, self.scale)
        pinhole = rays @ self.frame.camera.K[:2].T
        if is_height_source(heights):
            return self.frame.pixel_to_world(pinhole, heights)
        return self.frame.pixel_to_world_at(pinhole, heights)
