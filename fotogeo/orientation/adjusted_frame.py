"""An adjusted frame as a ground → image model: the bundle adjustment's collinearity with Brown's distortion
(:mod:`fotogeo.orientation.bundle_jacobian`), in the model protocol the orthophoto and the georeference use
(``forward``, ``inverse``, ``src_dims = 3``).

The inverse (pixel → ground) removes the distortion by the fixed-point iteration of
:func:`~fotogeo.orientation.bundle_jacobian.undistort_rays`, then intersects the pinhole ray.
"""
from __future__ import annotations

import numpy as np

from ..geometry.camera import OrientedFrame
from ..geometry.dem import is_height_source
from ..pixels import as_points
from . import bundle_jacobian as bj


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
        """:meth:`forward` of the grid points ``(X[col], Y[row], Z[row, col])`` (``Z`` ``(len(Y), len(X))``),
        row by row ``(N, 2)``: the camera coordinates ``c_k = Σ M_ik (P_i − C_i)`` (``M`` = ``R·D``) are built
        from one term per column, one per row and one per point; a camera without distortion skips Brown's
        terms."""
        M, C = self.frame.eo.rotation_cv, self.frame.eo.centre
        dx, dy = np.asarray(X, float) - C[0], np.asarray(Y, float) - C[1]
        Z = np.asarray(Z, float)
        c = []
        for k in range(3):  # in place: c_k = M_2k·Z + (M_0k·dx − M_2k·Z0) per column + M_1k·dy per row
            v = np.multiply(Z, M[2, k])
            v += (dx * M[0, k] - C[2] * M[2, k])[None, :]
            v += (dy * M[1, k])[:, None]
            c.append(v)
        behind = (c[2] <= 0).ravel()
        with np.errstate(invalid="ignore", divide="ignore"):
            if np.any(self.interior[3:]):
                px = bj.project_camera(np.column_stack([v.ravel() for v in c]), self.interior, self.scale)
            else:  # pinhole: col = f·sx·x/z + ppx, row = f·sy·y/z + ppy
                f, ppx, ppy = self.interior[:3]
                px = np.empty((c[0].size, 2))
                for k, (s, pp) in enumerate(((f * self.scale[0], ppx), (f * self.scale[1], ppy))):
                    np.divide(c[k], c[2], out=c[k])
                    c[k] *= s
                    c[k] += pp
                    px[:, k] = c[k].ravel()
        if behind.any():
            px[behind] = np.nan
        return px

    def inverse(self, pixel, heights=None, **_) -> np.ndarray:
        rays = bj.undistort_rays(as_points(pixel, 2, "pixels"), self.interior, self.scale)
        pinhole = rays @ self.frame.camera.K[:2].T
        if is_height_source(heights):
            return self.frame.pixel_to_world(pinhole, heights)
        return self.frame.pixel_to_world_at(pinhole, heights)
