"""Window-by-window resampling of a source raster onto a map grid through any inverse mapping.

For every output window, the centres of its pixels (corner convention, see
:mod:`fotogeo.pixels`) are mapped to output map coordinates with the output geotransform,
then to *source pixel* coordinates by ``inverse_map`` (map XY → source col/row). Only the
source window that those coordinates touch (plus a margin for the interpolation kernel)
is read, and ``cv2.remap`` samples it; memory therefore stays bounded by the block size
whatever the raster sizes. Source nodata (mask) and positions outside the source become
the output nodata value. Results go to a tiled, DEFLATE-compressed GeoTIFF with overviews.
"""
from __future__ import annotations

import math
import warnings

import cv2
import numpy as np
from rasterio.enums import Resampling
from rasterio.windows import Window

from ..errors import FotogeoWarning
from ..options import RESAMPLINGS
from ..pixels import pixel_centres, pixel_to_map, to_centre
from ..progress import Progress
from .raster import gdal_env, geotiff_profile, ropen

#: the OpenCV flag of each name of :data:`fotogeo.options.RESAMPLINGS` (a KeyError on import if one lacks a flag)
RESAMPLING = {n: {"nearest": cv2.INTER_NEAREST, "bilinear": cv2.INTER_LINEAR, "cubic": cv2.INTER_CUBIC}[n]
              for n in RESAMPLINGS}
_MARGIN = {"nearest": 1, "bilinear": 2, "cubic": 3}
_CV_DTYPES = {"uint8", "uint16", "int16", "float32", "float64"}


def grid_covering(XY, res: float):
    """North-up grid of pixel size ``res`` covering points ``XY`` (N, 2), its edges snapped to
    multiples of ``res`` (like ``gdalwarp -tap``): ``(transform, width, height)``."""
    from affine import Affine
    XY = np.asarray(XY, float)
    x0, y0 = np.floor(XY.min(axis=0) / res) * res
    x1, y1 = np.ceil(XY.max(axis=0) / res) * res
    return Affine(res, 0, x0, 0, -res, y1), int(round((x1 - x0) / res)), int(round((y1 - y0) / res))


def default_nodata(nodata, dtype):
    """The output nodata: the source's if set; else one no valid value of ``dtype`` can take
    by accident — NaN for floating point, the most negative value for signed integers (a
    source without nodata rarely reaches it; a valid pixel that does is counted and warned
    about) — and 0 for unsigned integers (GDAL's usual choice for a warped image).

    >>> default_nodata(None, "float32"), default_nodata(None, "int16"), default_nodata(None, "uint8")
    (nan, -32768, 0)
    >>> default_nodata(255, "uint8")
    255
    """
    if nodata is not None:
        return nodata
    kind = np.dtype(dtype).kind
    if kind == "f":
        return float("nan")
    return int(np.iinfo(dtype).min) if kind == "i" else 0


def warp_to_grid(src_path, dst_path, inverse_map, *, crs, transform, width: int, height: int,
                 resampling: str = "nearest", nodata=None, src_nodata=None, block: int = 512,
                 progress: Progress | None = None, overviews: bool = True) -> dict:
    """Resample ``src_path`` onto the grid (crs, transform, width, height) into ``dst_path``.

    ``inverse_map((N, 2) map XY) -> (N, 2)`` source pixel coordinates (corner convention).
    ``src_nodata`` overrides the source's own nodata value (a pixel is invalid when every band
    equals it). Returns a small summary (valid pixel count). ``dst_path`` is written in place: callers
    give a temporary path (see :class:`fotogeo.io.raster.AtomicOutputs`).
    """
    progress = progress or Progress()
    interp = RESAMPLING[resampling]
    margin = _MARGIN[resampling]
    valid_total = 0
    with gdal_env(), ropen(src_path) as src:
        dtype = src.dtypes[0]
        src_nd = src.nodata if src_nodata is None else src_nodata
        nodata = default_nodata(src_nd if nodata is None else nodata, dtype)
        floating = np.dtype(dtype).kind == "f"
        collisions = 0
        work_dtype = dtype if dtype in _CV_DTYPES else "float64"
        profile = geotiff_profile(width=width, height=height, count=src.count, dtype=dtype,
                                  crs=crs.to_wkt() if hasattr(crs, "to_wkt") else crs, transform=transform,
                                  nodata=nodata, predictor=True)
        colorinterp = src.colorinterp
        windows = [(r, c) for r in range(0, height, block) for c in range(0, width, block)]
        with ropen(dst_path, "w", **profile) as dst:
            try:
                dst.colorinterp = colorinterp
            except Exception:  # noqa: BLE001 - colour interpretation is cosmetic
                pass
            for k, (r0, c0) in enumerate(windows):
                h, w = min(block, height - r0), min(block, width - c0)
                x, y = pixel_centres(w, h, c0, r0)
                XY = pixel_to_map(transform, np.column_stack([x.ravel(), y.ravel()]))
                sp = inverse_map(XY)
                out = np.full((src.count, h, w), nodata, dtype=dtype)
                ok = np.isfinite(sp).all(axis=1)
                if ok.any():
                    cr = sp[ok]
                    c_lo = max(0, int(math.floor(cr[:, 0].min())) - margin)
                    c_hi = min(src.width, int(math.ceil(cr[:, 0].max())) + margin)
                    r_lo = max(0, int(math.floor(cr[:, 1].min())) - margin)
                    r_hi = min(src.height, int(math.ceil(cr[:, 1].max())) + margin)
                    if c_hi > c_lo and r_hi > r_lo:
                        win = Window(c_lo, r_lo, c_hi - c_lo, r_hi - r_lo)
                        data = src.read(window=win)
                        mask = src.read_masks(window=win).min(axis=0)
                        if src_nodata is not None:
                            mask[(data == src_nodata).all(axis=0)] = 0
                        if floating:  # NaN and ±inf are never data (nodata everywhere, as in fuse)
                            finite = np.isfinite(data)
                            mask[~finite.all(axis=0)] = 0
                            data = np.where(finite, data, 0)
                        local = to_centre(np.where(np.isfinite(sp), sp, -1e6)) - [c_lo, r_lo]
                        mx = local[:, 0].reshape(h, w).astype(np.float32)
                        my = local[:, 1].reshape(h, w).astype(np.float32)
                        m = cv2.remap(mask, mx, my, cv2.INTER_NEAREST if interp == cv2.INTER_NEAREST
                                      else cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
                        good = m >= 255 if interp != cv2.INTER_NEAREST else m > 0
                        for b in range(src.count):
                            band = data[b] if work_dtype == dtype else data[b].astype(work_dtype)
                            res = cv2.remap(band, mx, my, interp, borderMode=cv2.BORDER_REPLICATE)
                            out[b][good] = res[good].astype(dtype, copy=False)
                        valid_total += int(good.sum())
                        if not floating:
                            collisions += int((out[:, good] == nodata).all(axis=0).sum())
                dst.write(out, window=Window(c0, r0, w, h))
                progress((k + 1) / len(windows) * (0.9 if overviews else 1.0),
                         f"resampling window {k + 1}/{len(windows)}")
            if overviews:
                factors = [f for f in (2, 4, 8, 16, 32, 64) if min(width, height) / f >= 128]
                if factors:
                    dst.build_overviews(factors, Resampling.nearest if resampling == "nearest"
                                        else Resampling.average)
                    dst.update_tags(ns="rio_overview", resampling=resampling)
    progress(1.0, "resampled")
    if collisions and np.dtype(dtype).kind == "i":
        warnings.warn(f"{collisions} valid pixels of {src_path} equal the output nodata value {nodata} and will "
                      f"read as nodata; give the source a nodata value outside its data", FotogeoWarning,
                      stacklevel=2)
    return {"valid_pixels": valid_total, "nodata": None if nodata != nodata else nodata,
            "nodata_collisions": collisions}
