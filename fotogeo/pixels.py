"""The pixel-coordinate convention of fotogeo — written once, here.

Pixel coordinates are ``(col, row)`` = ``(x, y)`` float64 arrays of shape ``(N, 2)``.
Everywhere fotogeo reads, writes or returns them they follow GDAL/QGIS (the *corner*
convention): ``(0, 0)`` is the top-left corner of the top-left pixel, whose centre is
``(0.5, 0.5)``; pixel ``[row, col]`` of an array covers ``[col, col+1) x [row, row+1)``.
A GDAL geotransform / rasterio ``Affine`` maps these coordinates straight to map
coordinates: ``X, Y = transform * (col, row)``.

OpenCV (``cv2.remap``, ``cv2.KeyPoint``) and most papers put the centre of the top-left
pixel at ``(0, 0)`` (the *centre* convention). Only two functions cross that boundary:
:func:`to_centre` before handing coordinates to OpenCV-style array indexing, and
:func:`from_centre` for coordinates coming back. Nothing else adds or subtracts 0.5.

Arrays are band-first ``(bands, rows, cols)``.
"""
from __future__ import annotations

import numpy as np

from .errors import InputError

#: Offset between the two conventions: corner = centre + HALF.
HALF = 0.5


def as_points(xy, dims: int = 2, name: str = "points") -> np.ndarray:
    """Return ``xy`` as a float64 ``(N, dims)`` array, or raise :class:`InputError`."""
    a = np.asarray(xy, dtype=np.float64)
    if a.ndim == 1 and a.size == dims:
        a = a.reshape(1, dims)
    if a.ndim != 2 or a.shape[1] != dims:
        raise InputError(f"{name} must have shape (N, {dims}); got {a.shape}")
    return a


def to_centre(xy) -> np.ndarray:
    """GDAL corner convention -> centre convention (OpenCV, array indices).

    >>> to_centre([[0.5, 0.5]]).tolist()
    [[0.0, 0.0]]
    """
    return np.asarray(xy, dtype=np.float64) - HALF


def from_centre(xy) -> np.ndarray:
    """Centre convention (OpenCV, array indices) -> GDAL corner convention.

    >>> from_centre([[0.0, 0.0]]).tolist()
    [[0.5, 0.5]]
    """
    return np.asarray(xy, dtype=np.float64) + HALF


def pixel_centres(cols: int, rows: int, col_off: float = 0.0, row_off: float = 0.0):
    """Corner-convention coordinates of the centres of a ``rows x cols`` window.

    Returns two float64 arrays ``(x, y)`` of shape ``(rows, cols)``.
    """
    x = col_off + HALF + np.arange(cols, dtype=np.float64)
    y = row_off + HALF + np.arange(rows, dtype=np.float64)
    return np.meshgrid(x, y)


def pixel_to_map(transform, xy) -> np.ndarray:
    """Map coordinates of corner-convention pixel coordinates through an affine geotransform.

    ``transform`` is a rasterio/affine ``Affine`` (a, b, c, d, e, f): X = a*col + b*row + c,
    Y = d*col + e*row + f. With 10 m pixels, (0, 0) is the raster's top-left corner and
    (0.5, 0.5) the centre of its top-left pixel:

    >>> from affine import Affine
    >>> t = Affine(10.0, 0.0, 500000.0, 0.0, -10.0, 4200000.0)
    >>> pixel_to_map(t, [[0, 0], [0.5, 0.5], [2, 1]]).tolist()
    [[500000.0, 4200000.0], [500005.0, 4199995.0], [500020.0, 4199990.0]]
    >>> to_centre(map_to_pixel(t, [[500005.0, 4199995.0]])).tolist()  # array index [0, 0]
    [[0.0, 0.0]]
    """
    p = as_points(xy)
    t = transform
    return np.column_stack([t.a * p[:, 0] + t.b * p[:, 1] + t.c, t.d * p[:, 0] + t.e * p[:, 1] + t.f])


def map_to_pixel(transform, XY) -> np.ndarray:
    """Inverse of :func:`pixel_to_map`."""
    return pixel_to_map(~transform, XY)


def outline(width: float, height: float, n: int = 33) -> np.ndarray:
    """Points along the border of a ``width x height`` image, ``(4 n, 2)``, corner convention.

    The four edges in turn — top (left to right), right (down), bottom (right to left), left
    (up) — each with ``n`` evenly spaced points including both corners, so the polygon runs
    clockwise on the screen from the top-left corner ``(0, 0)``.

    >>> outline(4, 2, 3)[:6].tolist()
    [[0.0, 0.0], [2.0, 0.0], [4.0, 0.0], [4.0, 0.0], [4.0, 1.0], [4.0, 2.0]]
    """
    t = np.linspace(0, 1, n)
    w, h = width, height
    return np.concatenate([np.column_stack([t * w, 0 * t]), np.column_stack([w + 0 * t, t * h]),
                           np.column_stack([(1 - t) * w, h + 0 * t]), np.column_stack([0 * t, (1 - t) * h])])
