"""A constant collar connected to the border: the outside of a turned scene or a scanned map stored without a
nodata tag (arrays in, arrays out).

``gdalwarp`` without ``-dstnodata``, a scanner or an image editor fills the outside of the valid area with
0, 0, 0 (or 255, 255, 255) and tags nothing: read as data, the collar enters the seamlines, the balancing and the
blend of a mosaic as black (or white) image. :func:`border_collar` finds it: the cells whose every band equals
0 (or the type's maximum), in the connected regions (8-connectivity) of such cells that touch the image border.
A dark (or saturated) area inside the image is kept: only what reaches the border is a collar. A region is taken
as a collar when it holds at least :data:`MIN_SHARE` of the image's cells, so that a few black pixels on an edge
(a shadow, a dark roof) stay data.
"""
from __future__ import annotations

import numpy as np

#: the least share of the image's cells a border-connected constant region must cover to be taken as a collar
MIN_SHARE = 0.001


def collar_values(dtype) -> tuple:
    """The fill values a collar of ``dtype`` pixels may have: 0 and, for whole numbers, the type's maximum."""
    kind = np.dtype(dtype).kind
    return (0, np.iinfo(dtype).max) if kind in "iu" else (0,)


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
        if mask.mean() >= MIN_SHARE:
            return mask, value
    return None, None
