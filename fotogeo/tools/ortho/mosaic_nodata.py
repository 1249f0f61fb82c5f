"""The nodata value of a mosaic (:func:`output_nodata`): never one a data value of its orthophotos holds.

* Every orthophoto carries the same nodata value: the mosaic keeps it (no valid pixel holds it).
* Otherwise (no nodata value, masks or alpha bands, collars taken as nodata, different values) the values the
  orthophotos' valid pixels hold are counted (:func:`values_used`, one read of each, window by window) and the
  nodata is a value none of them holds: 0 (GDAL's usual choice for a warped image) when unused, else the type's
  largest, else the smallest unused one; NaN for floating-point data. A nodata value keeps the uncovered area
  nodata in QGIS too (the raster provider of QGIS 3.22 reads a GDAL mask band's masked cells as data).
* When every value of the type occurs (an 8-bit image using all 256 grey levels), no nodata is possible: the mosaic
  has none and marks its valid area in an internal mask band (GDAL's per-dataset mask, as ``gdal_translate -mask``
  writes; GDAL's masked reads and ``gdalwarp`` honour it).

A blended or balanced value that lands on the nodata is moved one step off it
(:func:`fotogeo.tools.ortho.mosaic_tiles.off_nodata`) and counted in the result.
"""
from __future__ import annotations

import numpy as np

#: integer types whose every value is counted (larger ones are checked by range)
COUNTED_BITS = 16


def shared_nodata(nodatas):
    """The orthophotos' nodata value when they all carry the same one (NaN equal to NaN), else None."""
    nodatas = list(nodatas)
    first = nodatas[0]
    if first is None or any(n is None or not (n == first or (n != n and first != first)) for n in nodatas):
        return None
    return first


def values_used(paths, dtype, rows: int = 512) -> np.ndarray:
    """Per value of the integer ``dtype`` (offset by its minimum; at most :data:`COUNTED_BITS` bits) whether a
    valid pixel of any band of the rasters ``paths`` holds it (GDAL's masks: nodata, mask bands, alpha)."""
    import rasterio
    from rasterio.windows import Window
    info = np.iinfo(dtype)
    used = np.zeros(int(info.max) - int(info.min) + 1, bool)
    for p in paths:
        with rasterio.open(p) as ds:
            for r0 in range(0, ds.height, rows):
                a = ds.read(window=Window(0, r0, ds.width, min(rows, ds.height - r0)), masked=True)
                v = a.compressed().astype(np.int64) - int(info.min)
                used[np.unique(v)] = True
    return used


def output_nodata(paths, infos) -> tuple:
    """``(nodata or None, why)`` of the mosaic of the rasters ``paths`` described by ``infos`` (module
    docstring)."""
    shared = shared_nodata(i.nodata for i in infos)
    if shared is not None:
        return shared, "the orthophotos' nodata value"
    dtype = np.dtype(infos[0].dtype)
    if dtype.kind == "f":
        return float("nan"), "NaN (floating-point data)"
    if dtype.itemsize * 8 > COUNTED_BITS:
        return None, f"a mask band ({dtype.name} values not counted)"
    used = values_used(paths, dtype)
    lo = int(np.iinfo(dtype).min)
    for v in (0, int(np.iinfo(dtype).max)):
        if lo <= v and not used[v - lo]:
            return v, "a value no data pixel holds"
    free = np.flatnonzero(~used)
    if len(free):
        return int(free[0]) + lo, "a value no data pixel holds"
    return None, f"a mask band (every {dtype.name} value occurs in the data)"
