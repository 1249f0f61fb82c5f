"""Where a resampled pixel comes from, in GDAL's arithmetic, so that nearest-neighbour outputs of
:mod:`fotogeo.io.warp` equal ``gdalwarp -r near -et 0``'s pixel for pixel (issue 15).

GDAL's warper (``GDALWarpKernel``, gdalwarpkernel.cpp) maps the centre ``(i + 0.5, j + 0.5)`` of an
output pixel to map coordinates with ``GDALApplyGeoTransform``, then to source pixel coordinates
with the source's inverse geotransform (``GDALInvGeoTransform``), all in float64, and takes the
source pixel ``floor(x + 1e-10)`` (``GWKCheckAndComputeSrcOffsets``). A grid twice as coarse as its
source and aligned with it puts every output centre exactly on a source pixel corner: there the
last bit of each sum decides the pixel, so the sums are evaluated here in GDAL's order. Measured:
the same mapping through ``affine``'s own inverse picks another pixel for up to 99 % of such a
grid's pixels (tests/test_warp_gdal.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..pixels import HALF, pixel_centres, pixel_to_map  # noqa: F401 - pixel_* used by the doctests


def centres_to_map(t, r0: int, c0: int, h: int, w: int) -> np.ndarray:
    """Map coordinates ``(h * w, 2)`` of the pixel centres of a window, row by row, evaluated as
    GDAL's ``GDALApplyGeoTransform`` does — ``X = (c + col * a) + row * b`` and
    ``Y = (f + col * d) + row * e``, left to right in float64 — so that a centre falling exactly on
    a source pixel edge lands on the same side of it as in ``gdalwarp`` (the order of the sums
    decides the last bit). One row and one column are computed, then broadcast.

    >>> from affine import Affine
    >>> t = Affine(2.0, 0.5, 100.0, 0.25, -2.0, 50.0)
    >>> x, y = pixel_centres(3, 2, 4, 7)
    >>> bool(np.allclose(centres_to_map(t, 7, 4, 2, 3), pixel_to_map(t, np.column_stack([x.ravel(), y.ravel()]))))
    True
    """
    x = c0 + HALF + np.arange(w, dtype=np.float64)
    y = (r0 + HALF + np.arange(h, dtype=np.float64))[:, None]
    XY = np.empty((h, w, 2))
    np.add(t.c + x * t.a, y * t.b, out=XY[..., 0])
    np.add(t.f + x * t.d, y * t.e, out=XY[..., 1])
    return XY.reshape(h * w, 2)


def gdal_inverse_geotransform(t):
    """The inverse of the affine ``t`` (rasterio order a, b, c, d, e, f) computed as GDAL's
    ``GDALInvGeoTransform`` does (the north-up case by division, else by the adjoint over the
    determinant), as an ``Affine``: with it, source pixel coordinates equal GDAL's to the last bit.

    >>> from affine import Affine
    >>> gdal_inverse_geotransform(Affine(0.3, 0.0, 500000.0, 0.0, -0.3, 7000000.0)).c == -500000.0 / 0.3
    True
    """
    from affine import Affine
    if t.b == 0.0 and t.d == 0.0 and t.a != 0.0 and t.e != 0.0:
        return Affine(1.0 / t.a, 0.0, -t.c / t.a, 0.0, 1.0 / t.e, -t.f / t.e)
    det = t.a * t.e - t.b * t.d
    if abs(det) <= 1e-10 * max(abs(t.a), abs(t.b), abs(t.d), abs(t.e)) ** 2:
        raise ValueError(f"the geotransform {tuple(t)[:6]} cannot be inverted (its pixels have no area)")
    inv_det = 1.0 / det
    return Affine(t.e * inv_det, -t.b * inv_det, (t.b * t.f - t.c * t.e) * inv_det,
                  -t.d * inv_det, t.a * inv_det, (-t.a * t.f + t.c * t.d) * inv_det)


@dataclass(frozen=True)
class GeotransformInverse:
    """Map XY → source pixel (corner convention) of a source with the affine geotransform
    ``transform``, in GDAL's arithmetic (:func:`gdal_inverse_geotransform` applied as
    ``GDALApplyGeoTransform``): the ``inverse_map`` with which :func:`warp_to_grid` gives
    ``gdalwarp -et 0``'s pixels when source and grid share a CRS. Picklable (Dask tiles)."""

    transform: object

    def __call__(self, XY) -> np.ndarray:
        i = gdal_inverse_geotransform(self.transform)
        XY = np.asarray(XY, np.float64)
        out = np.empty_like(XY)
        for k, (c, a, b) in enumerate(((i.c, i.a, i.b), (i.f, i.d, i.e))):  # (c + X a) + Y b, as GDAL
            np.multiply(XY[:, 0], a, out=out[:, k])
            out[:, k] += c
            out[:, k] += XY[:, 1] * b
        return out


#: GDAL's tolerance when it takes the source pixel of a position (``GWKCheckAndComputeSrcOffsets``
#: in GDAL's gdalwarpkernel.cpp): a coordinate less than 1e-10 px below a pixel edge is in the next pixel
GDAL_EDGE_EPSILON = 1e-10


def nearest_source_pixels(sp, width: int, height: int):
    """Integer source pixel ``(col, row)`` of each position ``sp`` (N, 2) (corner convention), by
    GDAL's nearest-neighbour rule in float64: a position is inside when ``0 <= x`` and
    ``x + 1e-10 <= width`` (same for y), its pixel is ``floor(x + 1e-10)`` (the last one for
    ``x + 1e-10 == width``). Returns ``(col, row, inside)``; outside positions get -1.

    >>> sp = np.array([[2.0, 0.0], [2.0 - 1e-12, 0.5], [1.999, 3.0 - 1e-10], [1.0, 3.0], [-1e-12, 1.0],
    ...                [np.nan, 1.0]])
    >>> col, row, inside = nearest_source_pixels(sp, 3, 3)
    >>> col.tolist(), row.tolist(), inside.tolist()
    ([2, 2, 1, -1, -1, -1], [0, 0, 2, -1, -1, -1], [True, True, True, False, False, False])
    """
    return nearest_pixels_xy(sp[:, 0], sp[:, 1], width, height)


def nearest_pixels_xy(px, py, width: int, height: int):
    """:func:`nearest_source_pixels` of the positions' columns ``px`` and rows ``py`` (``(N,)`` each)."""
    x, y = px + GDAL_EDGE_EPSILON, py + GDAL_EDGE_EPSILON  # contiguous copies, floored in place
    with np.errstate(invalid="ignore"):
        inside = (px >= 0) & (py >= 0) & (x <= width) & (y <= height)
        col = np.where(inside, np.minimum(np.floor(x, out=x), width - 1.0, out=x), -1.0).astype(np.int32)
        row = np.where(inside, np.minimum(np.floor(y, out=y), height - 1.0, out=y), -1.0).astype(np.int32)
    return col, row, inside
