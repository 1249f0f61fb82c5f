"""Exact epipolar rectification of two oriented frame cameras (Fusiello, Trucco & Verri 2000).

Both cameras are turned about their projection centres ``C1``, ``C2`` into one common orientation ``R``
(columns: rectified camera axes x right, y down, z forward, in world coordinates)::

    x = (C2 − C1) / |C2 − C1|,   y = ẑ × x / |ẑ × x|,   z = x × y

with ``ẑ`` the mean of the two optical axes. A world point ``P`` then has the same rectified row in both images
and its normalised coordinates differ along x only: ``xn1 − xn2 = |C2 − C1| / z`` (``z`` its depth along the
rectified axis). The rectified pixels are ``u = f·xn + cx_i``, ``v = f·yn + cy`` (GDAL corner convention: the
centre of the top-left pixel at (0.5, 0.5)); the disparity OpenCV's matchers measure is ``d = u1 − u2``.

The rectified image is resampled by following each rectified pixel's ray into the original image through the
camera's own ground → image model (``forward``): the lens distortion is removed exactly as the model states it,
whatever its parameters. ``cv2.remap`` takes centre-convention maps (corner − 0.5). The model is followed
exactly at every ``MAP_STEP``-th rectified pixel (nodes at multiples of ``MAP_STEP`` in the whole rectified
image, so that a window's map is the window of the whole map) and the maps between the nodes are interpolated
by Keys's (1981) cubic convolution (``a = −½``, third-order accurate): the maps are smooth (a homography composed
with the lens distortion). Where a node's ray misses the image, the window is followed exactly pixel by pixel.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import ModelError
from ..pixels import HALF, outline

#: the spacing (rectified pixels) of the nodes where the resampling maps follow the camera model exactly
MAP_STEP = 8
#: the rectified image's pixels a pair may have (both images), a guard before anything is allocated
MAX_RECTIFIED_PIXELS = 200_000_000


@dataclass(frozen=True)
class FrameView:
    """What rectification needs of one oriented frame: its projection centre ``(3,)``, its rotation ``(3, 3)``
    (OpenCV camera axes → world), focal length in pixels, image size ``(w, h)``, ``forward`` (world ``(N, 3)``
    → pixel ``(N, 2)``, distortion included) and ``rays`` (pixel ``(N, 2)`` → world ray directions ``(N, 3)``,
    distortion removed)."""
    name: str
    centre: np.ndarray
    rotation: np.ndarray
    focal: float
    size: tuple
    forward: Callable
    rays: Callable

    @property
    def axis(self) -> np.ndarray:
        """The optical axis (unit vector, world)."""
        return self.rotation[:, 2] / np.linalg.norm(self.rotation[:, 2])


def _unit(v) -> np.ndarray:
    return np.asarray(v, float) / np.linalg.norm(v)


def common_rotation(c1, c2, axis1, axis2) -> np.ndarray:
    """The rectified rotation ``R`` of the module docstring (columns x, y, z in world coordinates)."""
    x = _unit(np.asarray(c2, float) - np.asarray(c1, float))
    zm = _unit(_unit(axis1) + _unit(axis2))
    y = np.cross(zm, x)
    if np.linalg.norm(y) < 1e-6:
        raise ModelError("the base line points along the viewing direction: the pair cannot be rectified")
    y = _unit(y)
    return np.column_stack([x, y, np.cross(x, y)])


def epipole_angle(view: FrameView, other: FrameView) -> float:
    """Angle (degrees) between ``view``'s optical axis and the base line towards ``other`` (or away from it):
    below half the field of view the epipole lies inside the image and no rectification keeps the image whole."""
    b = _unit(other.centre - view.centre)
    return math.degrees(math.acos(min(1.0, abs(float(b @ view.axis)))))


@dataclass(frozen=True)
class RectifiedPair:
    """The common geometry of a rectified pair (module docstring): rotation ``R``, focal length ``f`` (rectified
    pixels), the column offsets ``cx = (cx1, cx2)``, the row offset ``cy``, the common size ``(w, h)`` and the two
    projection centres."""
    rotation: np.ndarray
    focal: float
    cx: tuple
    cy: float
    size: tuple
    centres: tuple

    @property
    def base(self) -> float:
        return float(np.linalg.norm(self.centres[1] - self.centres[0]))

    def rays(self, u, v, i: int) -> np.ndarray:
        """World ray directions ``(N, 3)`` of rectified pixels ``(u, v)`` of image ``i`` (0 or 1)."""
        u, v = np.asarray(u, float).ravel(), np.asarray(v, float).ravel()
        xn = (u - self.cx[i]) / self.focal
        yn = (v - self.cy) / self.focal
        return np.column_stack([xn, yn, np.ones_like(xn)]) @ self.rotation.T

    def project(self, XYZ, i: int) -> np.ndarray:
        """Rectified pixels ``(N, 2)`` of world points in image ``i`` (NaN behind the camera)."""
        c = (np.asarray(XYZ, float) - self.centres[i]) @ self.rotation
        with np.errstate(invalid="ignore", divide="ignore"):
            px = np.column_stack([self.focal * c[:, 0] / c[:, 2] + self.cx[i], self.focal * c[:, 1] / c[:, 2] + self.cy])
        px[c[:, 2] <= 0] = np.nan
        return px

    def disparity(self, XYZ) -> np.ndarray:
        """``d = u1 − u2`` of world points ``(N, 3)``."""
        return self.project(XYZ, 0)[:, 0] - self.project(XYZ, 1)[:, 0]

    def scaled(self, s: float) -> "RectifiedPair":
        """The same pair on a grid ``s`` times as fine (``s < 1``: coarser): rectified pixels ``u' = s·u``."""
        w, h = self.size
        return RectifiedPair(self.rotation, self.focal * s, (self.cx[0] * s, self.cx[1] * s), self.cy * s,
                             (max(1, int(math.ceil(w * s))), max(1, int(math.ceil(h * s)))), self.centres)

    def maps(self, view: FrameView, i: int, r0: int, r1: int, c0: int = 0, c1: int | None = None) -> tuple:
        """``(map_x, map_y)`` float32 ``(r1 − r0, c1 − c0)`` for ``cv2.remap`` (centre convention, pixels of the
        whole source image) of rows ``r0:r1`` and columns ``c0:c1`` (default: all) of rectified image ``i``;
        pixels whose ray misses the image get −1 (outside)."""
        c1 = self.size[0] if c1 is None else c1
        g = MAP_STEP
        ka, kb, la, lb = c0 // g - 1, -(-c1 // g) + 2, r0 // g - 1, -(-r1 // g) + 2  # nodes around the window
        nx, ny = self._exact_maps(view, i, np.arange(la, lb + 1) * g, np.arange(ka, kb + 1) * g)
        if not (np.isfinite(nx).all() and np.isfinite(ny).all()):
            mx, my = self._exact_maps(view, i, np.arange(r0, r1), np.arange(c0, c1))
        else:
            wx, kx = _keys_weights(np.arange(c0, c1) / g - ka)
            wy, ky = _keys_weights(np.arange(r0, r1) / g - la)
            mx, my = (_separable(n, wx, kx, wy, ky) for n in (nx, ny))
        mx, my = np.where(np.isfinite(mx), mx, -1.0), np.where(np.isfinite(my), my, -1.0)
        return mx.astype(np.float32), my.astype(np.float32)

    def _exact_maps(self, view: FrameView, i: int, rows, cols) -> tuple:
        """The maps of :meth:`maps` (float64, NaN where a ray misses) at rectified pixels ``rows`` x ``cols``,
        each through the camera model."""
        u, v = np.meshgrid(np.asarray(cols) + HALF, np.asarray(rows) + HALF)
        px = view.forward(self.centres[i] + 1000.0 * self.rays(u, v, i)) - HALF
        px[~np.isfinite(px).all(axis=1)] = np.nan
        return px[:, 0].reshape(u.shape), px[:, 1].reshape(u.shape)


def _keys_weights(t) -> tuple:
    """``(weights (4, N), k (N,))``: Keys's cubic convolution (``a = −½``) at node coordinates ``t``, the weights
    of nodes ``k − 1 … k + 2`` (``k = ⌊t⌋``)."""
    k = np.floor(t).astype(np.intp)
    f = t - k
    f2, f3 = f * f, f * f * f
    w = np.array([-0.5 * f3 + f2 - 0.5 * f, 1.5 * f3 - 2.5 * f2 + 1.0, -1.5 * f3 + 2.0 * f2 + 0.5 * f,
                  0.5 * f3 - 0.5 * f2])
    return w, k


def _separable(nodes, wx, kx, wy, ky) -> np.ndarray:
    """The node values interpolated along the rows, then the columns (weights of :func:`_keys_weights`)."""
    t = wx[0] * nodes[:, kx - 1] + wx[1] * nodes[:, kx] + wx[2] * nodes[:, kx + 1] + wx[3] * nodes[:, kx + 2]
    return (wy[0][:, None] * t[ky - 1] + wy[1][:, None] * t[ky] + wy[2][:, None] * t[ky + 1]
            + wy[3][:, None] * t[ky + 2])


def _normalised_outline(view: FrameView, R) -> np.ndarray:
    """The image outline's rectified normalised coordinates ``(N, 2)`` (rays behind the rectified camera
    dropped)."""
    d = view.rays(outline(*view.size, 17)) @ R
    d = d[d[:, 2] > 1e-9]
    return d[:, :2] / d[:, 2:3]


def rectified_extent(view1: FrameView, view2: FrameView, scale: float = 1.0) -> tuple:
    """``(R, f, n1, n2, (y0, y1), (w, h))`` of :func:`rectify`: the common rotation, the rectified focal length,
    the two outlines' normalised coordinates, the common rows' normalised extent and the size in pixels (the rows
    both images cover, the wider image's columns). The one computation of the rectified size, for the pair choice
    too (:func:`fotogeo.tools.dsm.plan.forward_reason`); refused (:class:`ModelError`) when the frames share no
    epipolar line. The size grows like ``1 / sin²`` of the epipole's distance outside the image."""
    R = common_rotation(view1.centre, view2.centre, view1.axis, view2.axis)
    f = scale * 0.5 * (view1.focal + view2.focal)
    n1, n2 = _normalised_outline(view1, R), _normalised_outline(view2, R)
    if len(n1) < 3 or len(n2) < 3:
        raise ModelError(f"frames {view1.name!r} and {view2.name!r} look too far apart to be rectified together")
    y0, y1 = max(n1[:, 1].min(), n2[:, 1].min()), min(n1[:, 1].max(), n2[:, 1].max())
    if y1 <= y0:
        raise ModelError(f"frames {view1.name!r} and {view2.name!r} share no epipolar line: they do not overlap")
    widths = [(n[:, 0].max() - n[:, 0].min()) * f for n in (n1, n2)]
    return R, f, n1, n2, (y0, y1), (int(math.ceil(max(widths))), int(math.ceil((y1 - y0) * f)))


def rectify(view1: FrameView, view2: FrameView, scale: float = 1.0) -> RectifiedPair:
    """The :class:`RectifiedPair` of two frames (module docstring); ``scale`` the rectified focal length over the
    mean of the two (< 1: matched on a coarser grid). The rows are those both images cover, each image's
    columns its own extent (:func:`rectified_extent`); refused beyond :data:`MAX_RECTIFIED_PIXELS`."""
    R, f, n1, n2, (y0, _), (w, h) = rectified_extent(view1, view2, scale)
    if 2 * w * h > MAX_RECTIFIED_PIXELS:
        raise ModelError(f"frames {view1.name!r} and {view2.name!r}: the rectified pair would have {w} x {h} pixels; "
                         f"give a coarser --resolution")
    cx = (float(-n1[:, 0].min() * f), float(-n2[:, 0].min() * f))
    return RectifiedPair(R, f, cx, float(-y0 * f), (w, h), (np.asarray(view1.centre, float),
                                                            np.asarray(view2.centre, float)))
