"""A constant collar connected to the border: the outside of a turned scene or a scanned map stored without a
nodata tag (arrays in, arrays out).

``gdalwarp`` without ``-dstnodata``, a scanner or an image editor fills the outside of the valid area with
0, 0, 0 (or 255, 255, 255) and tags nothing: read as data, the collar enters the seamlines, the balancing and the
blend of a mosaic as black (or white) image. :func:`border_collar` finds it: the cells whose every band equals
0 (or the type's maximum), in the connected regions (8-connectivity) of such cells that touch the image border.
A dark (or saturated) area inside the image is kept: only what reaches the border is a collar. A region is taken
as a collar when it holds at least :data:`MIN_SHARE` of the image's cells, so that a few black pixels on an edge
(a shadow, a dark roof) stay data, and when it is what a warp or a scan leaves around a valid area: the rest of
the image, the data, must be convex (a turned rectangle, a map sheet, a quadrilateral footprint) — at most
:data:`MAX_IN_HULL` of the region's cells lie inside the data's convex hull (its edge's staircase left out). A
saturated cloud or snowfield (or a black lake) reaching the edge bites into the image: the data around it is not
convex, and it stays data.
"""
from __future__ import annotations

import numpy as np

#: the least share of the image's cells a border-connected constant region must cover to be taken as a collar
MIN_SHARE = 0.001
#: the largest share of a collar's cells that may lie inside the convex hull of the data (less its edge's pixels)
MAX_IN_HULL = 0.05


def collar_values(dtype) -> tuple:
    """The fill values a collar of ``dtype`` pixels may have: 0 and, for whole numbers, the type's maximum."""
    kind = np.dtype(dtype).kind
    return (0, np.iinfo(dtype).max) if kind in "iu" else (0,)


def border_values(strips, values) -> list:
    """The ``values`` some cell of the border ``strips`` (each ``(count, …)``: the image's one-pixel edges) holds
    in every band: the only fill values a collar can have (:func:`border_collar` needs the whole image)."""
    return [v for v in values if any((np.asarray(s) == v).all(axis=0).any() for s in strips)]


def border_collar(bands: np.ndarray, values=(0, 255)) -> tuple:
    """``(mask, value)``: the cells ``(h, w)`` of the collar of ``bands`` ``(count, h, w)`` (module docstring) and
    its fill value, or ``(None, None)`` when it has none."""
    from scipy import ndimage
    for value in values:
        same = (bands == value).all(axis=0)
        edge = np.concatenate([same[0], same[-1], same[:, 0], same[:, -1]])
        if not edge.any():
            continue
        labels, _ = ndimage.label(same, structure=np.ones((3, 3), bool))
        touching = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
        mask = np.isin(labels, touching[touching > 0])
        if mask.mean() >= MIN_SHARE and _data_convex(mask):
            return mask, value
    return None, None


def _data_convex(collar: np.ndarray) -> bool:
    """Whether the cells outside ``collar`` are convex: at most :data:`MAX_IN_HULL` of the collar's cells lie
    inside their convex hull eroded by one cell (the rasterised edge's staircase is not a bite)."""
    import cv2
    data = (~collar).astype(np.uint8)
    contours, _ = cv2.findContours(data, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if not contours:
        return True  # no data at all: the whole image is the collar
    hull = np.zeros(collar.shape, np.uint8)
    cv2.fillConvexPoly(hull, cv2.convexHull(np.concatenate(contours)), 1)
    inside = cv2.erode(hull, np.ones((3, 3), np.uint8)).astype(bool) & collar
    return inside.sum() <= MAX_IN_HULL * collar.sum()
