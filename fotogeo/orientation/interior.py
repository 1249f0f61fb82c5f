"""Interior orientation of scanned film frames: pixel → photo coordinates from measured fiducials.

The scan pixel ``(col, row)`` (GDAL corner convention) maps to photo coordinates ``(x, y)`` in mm
(x right, y up, the calibration report's frame) by

* ``affine`` (6 parameters: two scales, skew, rotation, shift; ≥ 3 marks, the usual choice:
  scanner and film deformation are close to affine) —
  ``x = a0 + a1·col + a2·row``, ``y = b0 + b1·col + b2·row``;
* ``projective`` (8 parameters; ≥ 4 marks): a film plane tilted on the scanner —
  ``x = (a0 + a1·col + a2·row) / (1 + c1·col + c2·row)``, ``y = (b0 + b1·col + b2·row) / (1 + c1·col + c2·row)``,

fitted by least squares on the marks found (the one model protocol, :mod:`fotogeo.models`). The
residual of a mark is in scan pixels: the report's photo coordinates mapped back into the scan
minus the measured position. ``matrix`` is the 3x3 homogeneous matrix of pixel → photo
(its first two rows are the 2x3 affine); the scan pixel size is ``√|det|`` of its linear part
and the scan rotation the angle of its first column (clockwise on screen, 0 = the photo's x
axis along the scan's rows).

A *standard frame* (:func:`standard_frame_maps`) is the photo resampled on a grid of square
pixels ``q`` mm centred on the principal point: output pixel ``(c, r)`` (corner convention) is the
photo point ``x = ppx − W/2 + c·q``, ``y = ppy + H/2 − r·q``, so a pinhole camera with the
calibrated focal length, sensor ``W x H`` mm and the principal point at the image centre
describes it exactly (what ``orient`` and ``triangulate`` read).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..models import get_model

INTERIOR_MODELS = ("affine", "projective")


@dataclass(frozen=True)
class InteriorOrientation:
    """The fitted pixel → photo transform and its residuals (module docstring)."""

    model: str
    matrix: np.ndarray  # (3, 3) homogeneous pixel (corner) -> photo mm
    ids: tuple
    pixel: np.ndarray  # (N, 2) measured marks
    photo: np.ndarray  # (N, 2) the report's photo coordinates, mm
    residual_px: np.ndarray  # (N, 2) predicted - measured, scan pixels

    def to_photo(self, pixel) -> np.ndarray:
        """Photo coordinates (mm) of scan pixels ``(N, 2)``."""
        return _apply(self.matrix, pixel)

    def to_pixel(self, photo) -> np.ndarray:
        """Scan pixels of photo coordinates ``(N, 2)`` mm."""
        return _apply(np.linalg.inv(self.matrix), photo)

    @property
    def pixel_size_mm(self) -> float:
        return float(np.sqrt(abs(np.linalg.det(self.matrix[:2, :2]))))

    @property
    def rotation_deg(self) -> float:
        """Scan rotation, clockwise on screen: the angle of the photo x axis in the scan (0 … 360)."""
        inv = np.linalg.inv(self.matrix[:2, :2])
        return float(np.degrees(np.arctan2(inv[1, 0], inv[0, 0])) % 360.0)

    @property
    def residual_lengths(self) -> np.ndarray:
        return np.hypot(*self.residual_px.T)

    @property
    def rms_px(self) -> float:
        return float(np.sqrt(np.mean(self.residual_lengths ** 2)))

    def pixel_to_photo_list(self) -> list:
        """The 2x3 affine (``affine``) or the 3x3 matrix (``projective``) as nested lists."""
        return (self.matrix[:2] if self.model == "affine" else self.matrix).tolist()


def _apply(M, pts) -> np.ndarray:
    p = np.asarray(pts, float).reshape(-1, 2)
    h = np.column_stack([p, np.ones(len(p))]) @ M.T
    return h[:, :2] / h[:, 2:]


def fit_interior(ids, pixel, photo, model: str = "affine") -> InteriorOrientation:
    """Fit ``model`` (module docstring) to the marks ``ids`` measured at ``pixel`` with report
    coordinates ``photo``; raises :class:`ModelError` when there are too few marks."""
    if model not in INTERIOR_MODELS:
        raise ModelError(f"interior orientation model {model!r} unknown; choose {' or '.join(INTERIOR_MODELS)}")
    pixel, photo = np.asarray(pixel, float), np.asarray(photo, float)
    m = get_model(model).estimate(pixel, photo)
    M = m.world_matrix()
    M = M / M[2, 2]
    back = _apply(np.linalg.inv(M), photo)
    return InteriorOrientation(model, M, tuple(ids), pixel, photo, back - pixel)


def standard_frame_maps(io: InteriorOrientation, frame_mm, principal_point_mm, pixel_mm: float):
    """``(map_x, map_y)`` for ``cv2.remap`` (scan pixel-centre coordinates of every output pixel
    centre) of the standard frame (module docstring) and its size ``(cols, rows)``."""
    W, H = frame_mm
    cols, rows = int(round(W / pixel_mm)), int(round(H / pixel_mm))
    c = (np.arange(cols) + 0.5) * pixel_mm
    r = (np.arange(rows) + 0.5) * pixel_mm
    X = principal_point_mm[0] - cols * pixel_mm / 2.0 + c
    Y = principal_point_mm[1] + rows * pixel_mm / 2.0 - r
    XX, YY = np.meshgrid(X, Y)
    scan = io.to_pixel(np.column_stack([XX.ravel(), YY.ravel()])) - 0.5  # corner -> OpenCV centre convention
    return (scan[:, 0].reshape(rows, cols).astype(np.float32), scan[:, 1].reshape(rows, cols).astype(np.float32),
            (cols, rows))
