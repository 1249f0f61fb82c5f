"""The nodata value of a mosaic (:func:`output_nodata`): never one a data value of its orthophotos holds.

* Every orthophoto carries the same nodata value: the mosaic keeps it (no valid pixel holds it).
* Otherwise (no nodata value, masks or alpha bands, collars taken as nodata, different values) the values the
  orthophotos' valid pixels hold are counted (:func:`values_used`, one read of each in strips, stopping once every
  value is seen) and the nodata is a value none of them holds, in the order of
  :func:`fotogeo.io.warp.default_nodata` (one rule: 0 for unsigned types, GDAL's usual choice for a warped image;
  the type's minimum for signed ones, so an int16 height mosaic does not get 0, sea level), else the type's
  largest, else the smallest unused one; NaN for floating-point data. Types wider than 16 bits are checked for
  those two values only. A nodata value is preferred to a mask band because the mask hides the uncovered area
  from the display only: QGIS 3.22.16 (GDAL 3.6.2) shows an internal mask as band 4 "Alpha" and its default
  renderer draws the masked cells transparent, but tools reading band values (the raster calculator, statistics)
  still take them as data.
* When every value of the type occurs (an 8-bit image using all 256 grey levels), no nodata is possible: the mosaic
  has none and marks its valid area in an internal mask band (GDAL's per-dataset mask, as ``gdal_translate -mask``
  writes; GDAL's masked reads and ``gdalwarp`` honour it).

A blended or balanced value that lands on the nodata is moved one step off it
(:func:`fotogeo.tools.ortho.mosaic_tiles.off_nodata`) and counted in the result.
"""
from __future__ import annotations

import numpy as np

#: integer types whose every value is counted (wider ones: the two values of :func:`output_nodata` only)
COUNTED_BITS = 16


def shared_nodata(nodatas):
    """The orthophotos' nodata value when they all carry the same one (NaN equal to NaN), else None."""
    nodatas = list(nodatas)
    first = nodatas[0]
    if first is None or any(n is None or not (n == first or (n != n and first != first)) for n in nodatas):
        return None
    return first


def _valid_strips(paths, rows: int):
    """``(share read, valid values)`` of each strip of ``rows`` rows of the rasters ``paths``, all bands, read
    through fotogeo's reader (GDAL's masks: nodata, mask bands, alpha)."""
    from rasterio.windows import Window

    from ...io.raster import gdal_env, ropen
    total = max(1, len(paths))
    with gdal_env():
        for done, p in enumerate(paths):
            with ropen(p) as ds:
                for r0 in range(0, ds.height, rows):
                    a = ds.read(window=Window(0, r0, ds.width, min(rows, ds.height - r0)), masked=True)
                    yield (done + min(r0 + rows, ds.height) / ds.height) / total, a.compressed()


def values_used(paths, dtype, rows: int = 512, progress=None) -> np.ndarray:
    """Per value of the integer ``dtype`` (at most :data:`COUNTED_BITS` bits), in the order of ``value − min``,
    whether a valid pixel of any band of the rasters ``paths`` holds it (GDAL's masks: nodata, mask bands,
    alpha). One read in strips of ``rows`` rows through fotogeo's reader, counted on the raw type
    (``np.bincount``; a signed value ``v`` is counted at ``v − min``, its two's complement with the sign bit
    flipped, so nothing is widened); it stops as soon as every value is used. ``progress``: a
    :class:`~fotogeo.progress.Progress` told the share of rows read."""
    dtype = np.dtype(dtype)
    unsigned = np.dtype(f"u{dtype.itemsize}")
    flip = unsigned.type(1 << (8 * dtype.itemsize - 1)) if dtype.kind == "i" else unsigned.type(0)
    used = np.zeros(1 << (8 * dtype.itemsize), bool)
    for share, a in _valid_strips(paths, rows):
        v = np.ascontiguousarray(a.astype(dtype, copy=False)).view(unsigned) ^ flip
        used |= np.bincount(v, minlength=len(used)) > 0
        if used.all():
            return used
        if progress is not None:
            progress(share)
    return used


def _occurring(paths, values, rows: int = 512) -> set:
    """Which of the ``values`` a valid pixel of any band of the rasters ``paths`` holds (types too wide to count
    every value: :data:`COUNTED_BITS`); one read in strips, stopping when all occur."""
    seen = set()
    for _, a in _valid_strips(paths, rows):
        seen |= {v for v in values if v not in seen and np.any(a == v)}
        if len(seen) == len(values):
            return seen
    return seen


def output_nodata(paths, infos, progress=None) -> tuple:
    """``(nodata or None, why)`` of the mosaic of the rasters ``paths`` described by ``infos`` (module
    docstring)."""
    from ...io.warp import default_nodata
    shared = shared_nodata(i.nodata for i in infos)
    if shared is not None:
        return shared, "the orthophotos' nodata value"
    dtype = np.dtype(infos[0].dtype)
    if dtype.kind == "f":
        return float("nan"), "NaN (floating-point data)"
    info = np.iinfo(dtype)
    first = [default_nodata(None, dtype), int(info.max)]  # one rule with fotogeo.io.warp, then the other end
    if dtype.itemsize * 8 > COUNTED_BITS:
        seen = _occurring(paths, first)  # one pass over the inputs, not one per candidate
        free = [v for v in first if v not in seen]
        return (free[0], "a value no data pixel holds") if free else \
            (None, f"a mask band (the {dtype.name} values {first[0]} and {first[1]} both occur in the data)")
    used = values_used(paths, dtype, progress=progress)
    lo = int(info.min)
    free = [v for v in first if not used[v - lo]] or [int(i) + lo for i in np.flatnonzero(~used)[:1]]
    if free:
        return free[0], "a value no data pixel holds"
    return None, f"a mask band (every {dtype.name} value occurs in the data)"
