"""Orthophotos with a constant collar and no nodata tag (issue 32), shared by ``tests/test_mosaic_collar.py`` and
``benchmarks/mosaic_collar_bench.py``: the valid area a rectangle turned inside a north-up raster, the outside one
value in every band (what ``gdalwarp`` without ``-dstnodata`` writes for a turned scene, or a scanned map)."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def turned_inside(h: int, w: int, angle: float, shrink: float) -> np.ndarray:
    """Cells of an ``h`` x ``w`` grid inside a rectangle turned by ``angle`` degrees about the centre and scaled
    by ``shrink`` so that its corners stay inside the grid."""
    rows, cols = np.mgrid[0:h, 0:w] + 0.5
    a = np.radians(angle)
    x, y = cols - w / 2, rows - h / 2
    u, v = np.cos(a) * x + np.sin(a) * y, -np.sin(a) * x + np.cos(a) * y
    return (np.abs(u) <= shrink * w / 2) & (np.abs(v) <= shrink * h / 2)


def write_untagged(path, bands, transform, crs) -> None:
    """``bands`` ``(count, h, w)`` uint8 as a GeoTIFF without a nodata tag."""
    import rasterio
    with rasterio.open(path, "w", driver="GTiff", width=bands.shape[2], height=bands.shape[1], count=bands.shape[0],
                       dtype="uint8", crs=crs, transform=transform) as ds:
        ds.write(bands)


def ngi_turned_pair(ortho: Path, folder: Path, angle: float, overlap: int, scale: int = 1):
    """Two inputs cut from the orthophoto ``ortho`` (each pixel repeated ``scale`` x ``scale`` times), overlapping
    by ``overlap`` columns (of the scaled grid), each valid inside a rectangle turned by ``angle`` (both alike: a
    seam must cross a collar), 0 in every band outside and no nodata tag. Returns ``(inputs, truth, cells some
    input covers where the truth is valid, the columns both cover)``."""
    import rasterio
    with rasterio.open(ortho) as ds:
        truth, valid = ds.read(), ds.read_masks(1) > 0  # its own outside (nodata 0) is a collar too once untagged
        t, crs = ds.transform * ds.transform.scale(1 / scale), ds.crs
    if scale > 1:
        truth = truth.repeat(scale, axis=1).repeat(scale, axis=2)
        valid = valid.repeat(scale, axis=0).repeat(scale, axis=1)
    h, w = truth.shape[1:]
    half = (w + overlap) // 2
    inputs, covers = [], np.zeros((h, w), bool)
    for k, c0 in enumerate((0, w - half)):
        part = truth[:, :, c0:c0 + half].copy()
        inside = turned_inside(h, half, angle, 0.72)
        part[:, ~inside] = 0
        write_untagged(folder / f"turned_{k}.tif", part, t * t.translation(c0, 0), crs)
        inputs.append(folder / f"turned_{k}.tif")
        covers[:, c0:c0 + half] |= inside
    both = np.zeros((h, w), bool)
    both[:, w - half:half] = True
    return inputs, truth, covers & valid, both
