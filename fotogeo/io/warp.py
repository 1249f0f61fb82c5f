"""Window-by-window resampling of a source raster onto a map grid through any inverse mapping.

For every output window, the centres of its pixels (corner convention, see
:mod:`fotogeo.pixels`) are mapped to output map coordinates with the output geotransform,
then to *source pixel* coordinates by ``inverse_map`` (map XY → source col/row). Only the
source window that those coordinates touch (plus a margin for the interpolation kernel)
is read, and ``cv2.remap`` samples it; memory therefore stays bounded by the block size
whatever the raster sizes. Nearest neighbour takes GDAL's source pixel, computed in float64
(:mod:`fotogeo.io.warp_gdal`; float32 positions, a mapping's interpolated ones, are taken as they are), and hands
OpenCV exact integer maps: with :class:`~fotogeo.io.warp_gdal.GeotransformInverse` the output equals
``gdalwarp -r near -et 0``'s. Source nodata (mask) and positions outside the source become the output nodata value.
Results go to a tiled, DEFLATE-compressed GeoTIFF with overviews.

Speed: the windows are computed by a pool of threads (``cv2.remap``, numpy and GDAL's reads release the GIL), each
with its own handle on the source, at most two windows per thread in flight; the calling thread writes them in order
(so the file is the same whatever the thread count), GDAL compresses the tiles (the GTiff ``NUM_THREADS`` creation
option: :func:`compress_threads`, half as many as resample) and builds the overviews with ``GDAL_NUM_THREADS``. A
window's pixels depend only on its position in the grid, never on the thread count: outputs are pixel-identical to
the one-thread run. A source small enough is read once, pixel-interleaved, and the windows are views of it
(:func:`fotogeo.io.warp_source.whole_source`); the overviews are built before the file is closed.
:func:`fotogeo.io.warp_tiles.warp_tiled` splits a large grid into tiles written by tasks (threads or Dask workers).
"""
from __future__ import annotations

import dataclasses
import math
import os
import warnings
from contextlib import nullcontext
from dataclasses import dataclass

import cv2
import numpy as np
import rasterio
from rasterio.enums import MaskFlags, Resampling
from rasterio.windows import Window

from ..errors import FotogeoWarning
from ..options import RESAMPLINGS
from ..pixels import HALF
from ..progress import Progress
from .compression import overview_env
from .raster import GDAL_CACHE_BYTES, geotiff_profile, ropen
from .warp_gdal import GeotransformInverse, centres_to_map, nearest_pixels_xy, nearest_source_pixels  # noqa: F401
from .warp_levels import reduced_plan
from .warp_source import CV_DTYPES as _CV_DTYPES
from .warp_source import in_order, opencv_threads, remapped_validity, source_handles, validity, whole_source

#: the OpenCV flag of each name of :data:`fotogeo.options.RESAMPLINGS` (a KeyError on import if one lacks a flag)
RESAMPLING = {n: {"nearest": cv2.INTER_NEAREST, "bilinear": cv2.INTER_LINEAR, "cubic": cv2.INTER_CUBIC}[n]
              for n in RESAMPLINGS}
_MARGIN = {"nearest": 1, "bilinear": 2, "cubic": 3}
_INT16_MAX = 32767
OVERVIEW_MIN = 256  #: smallest overview's short side, px (orthority's; docs/benchmarks/products.md says why)
#: environment variable bounding fotogeo's resampling threads (the batch sets it to 1 in its tasks)
THREADS_ENV = "FOTOGEO_NUM_THREADS"


def default_threads() -> int:
    """Threads for resampling: ``$FOTOGEO_NUM_THREADS`` if set, else the CPUs this process may use."""
    given = os.environ.get(THREADS_ENV, "").strip()
    if given.isdigit() and int(given) > 0:
        return int(given)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def grid_covering(XY, res: float):
    """North-up grid of pixel size ``res`` covering points ``XY`` (N, 2), its edges snapped to
    multiples of ``res`` (like ``gdalwarp -tap``): ``(transform, width, height)``."""
    from affine import Affine
    XY = np.asarray(XY, float)
    x0, y0 = np.floor(XY.min(axis=0) / res) * res
    x1, y1 = np.ceil(XY.max(axis=0) / res) * res
    return Affine(res, 0, x0, 0, -res, y1), int(round((x1 - x0) / res)), int(round((y1 - y0) / res))


def default_nodata(nodata, dtype):
    """The output nodata: the source's if set; else one no valid value of ``dtype`` can take by accident — NaN for
    floats, the most negative value for signed integers (a source without nodata rarely reaches it; a valid pixel
    that does is counted and warned about) — and 0 for unsigned integers (GDAL's usual choice for a warped image).

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


@dataclass(frozen=True)
class Plan:
    """Everything a window needs besides the source handle: the output grid, the mapping, the
    resampling and the nodata rules (made once by :func:`make_plan`, shared by the threads)."""

    inverse_map: object
    transform: object
    resampling: str
    dtype: str
    count: int
    nodata: object
    src_nodata: object  # the override of the source's nodata (None: the file's mask)
    all_valid: bool  # the source has no nodata, mask or alpha: its mask is all 255, not read
    band_nodata: object  # the file's nodata value when its masks come from it (per band), else None
    src_width: int
    src_height: int
    pixels: object = None  # the whole source in memory (fotogeo.io.warp_source.whole_source), else None
    pixel_mask: object = None  # its validity mask (None: all valid)
    level: object = None  # the source's overview level read (fotogeo.io.warp_levels), None: full resolution
    factor: int = 1  # that level's reduction

    @property
    def floating(self) -> bool:
        return np.dtype(self.dtype).kind == "f"


def make_plan(src, inverse_map, transform, resampling="nearest", nodata=None, src_nodata=None) -> Plan:
    """The :class:`Plan` of resampling the open rasterio dataset ``src`` onto ``transform``."""
    dtype = src.dtypes[0]
    src_nd = src.nodata if src_nodata is None else src_nodata
    all_valid = src_nodata is None and all(f == [MaskFlags.all_valid] for f in src.mask_flag_enums)
    band_nodata = src.nodata if any(MaskFlags.nodata in f for f in src.mask_flag_enums) else None
    return Plan(inverse_map, transform, resampling, dtype, src.count,
                default_nodata(src_nd if nodata is None else nodata, dtype), src_nodata, all_valid,
                band_nodata, src.width, src.height)


def _source_window(src, plan: Plan, win: Window):
    """``(mask, data, interleaved)`` of a source window: the mask (:func:`~fotogeo.io.warp_source.validity`, None
    when all valid) and the pixels, a view of the whole source when it is in memory (then ``(h, w, bands)`` for
    2-4 bands, ``interleaved`` True), else read (``(bands, h, w)``)."""
    rows, cols = slice(win.row_off, win.row_off + win.height), slice(win.col_off, win.col_off + win.width)
    if plan.pixels is not None:
        mask = None if plan.pixel_mask is None else plan.pixel_mask[rows, cols]
        if plan.pixels.ndim == 3 and plan.pixels.shape[0] == 1 and plan.count == 1:
            return mask, plan.pixels[:, rows, cols], False
        return mask, plan.pixels[rows, cols], True
    data = src.read(window=win)
    mask = None if plan.all_valid else src.read_masks(window=win).max(axis=0)
    return (*validity(mask, data, plan), False)


def _nearest_maps(x, y, plan: Plan, h: int, w: int):
    """Source window and OpenCV maps holding the exact integer source pixels of the positions ``x``, ``y``
    (``(h, w)`` each; GDAL's rule, see :func:`nearest_source_pixels`): ``CV_16SC2`` maps (no rounding left to OpenCV)
    when the window fits in int16, else integer-valued float32 maps (exact below 2²⁴); and whether every position is
    inside the source (then the mask's remap is skipped where the window's mask is all valid). None when nothing is
    inside."""
    col, row, inside = nearest_pixels_xy(x.ravel(), y.ravel(), plan.src_width, plan.src_height)
    if not inside.any():
        return None
    # (numpy's masked reductions and copies are slow: np.where with a sentinel instead)
    c_lo, c_hi = int(np.where(inside, col, plan.src_width).min()), int(col.max()) + 1
    r_lo, r_hi = int(np.where(inside, row, plan.src_height).min()), int(row.max()) + 1
    win = Window(c_lo, r_lo, c_hi - c_lo, r_hi - r_lo)
    lc, lr = np.where(inside, col - c_lo, -1), np.where(inside, row - r_lo, -1)
    within = bool(inside.all())
    if max(c_hi - c_lo, r_hi - r_lo) <= _INT16_MAX:
        xy = np.empty((h * w, 2), np.int16)
        xy[:, 0], xy[:, 1] = lc, lr
        return win, xy.reshape(h, w, 2), None, within
    return win, lc.astype(np.float32).reshape(h, w), lr.astype(np.float32).reshape(h, w), within


def _interpolation_maps(x, y, plan: Plan, h: int, w: int):
    """Source window (the positions ``x``, ``y`` (``(h, w)`` each) plus the kernel's margin) and OpenCV maps (centre
    convention, computed in float64 and rounded to float32 in the same pass) for bilinear and cubic: converted once
    to OpenCV's fixed-point maps (``convertMaps``, the rounding ``remap`` applies to float maps itself) when the
    window fits in int16, so that the mask's and the bands' ``remap`` share them; and whether every position's
    kernel lies in the window (then the mask's remap, all 255, is skipped where the window's mask is all valid).
    None when nothing is inside."""
    margin = _MARGIN[plan.resampling]
    # a NaN or an infinity anywhere makes one of them non-finite
    x_lo, x_hi, y_lo, y_hi = x.min(), x.max(), y.min(), y.max()
    everywhere = bool(np.isfinite((x_lo, x_hi, y_lo, y_hi)).all())
    if not everywhere:
        fx, fy = np.isfinite(x), np.isfinite(y)
        both = fx & fy
        if not both.any():
            return None
        x_lo, x_hi, y_lo, y_hi = x[both].min(), x[both].max(), y[both].min(), y[both].max()
    c_lo = max(0, int(math.floor(x_lo)) - margin)
    c_hi = min(plan.src_width, int(math.ceil(x_hi)) + margin)
    r_lo = max(0, int(math.floor(y_lo)) - margin)
    r_hi = min(plan.src_height, int(math.ceil(y_hi)) + margin)
    if c_hi <= c_lo or r_hi <= r_lo:
        return None
    if not everywhere:
        x, y = np.where(fx, x, -1e6), np.where(fy, y, -1e6)
    # centre convention (OpenCV) in the window: x - (0.5 + c_lo), exact in float64, cast to float32 on output
    mx, my = np.empty((h, w), np.float32), np.empty((h, w), np.float32)
    np.subtract(x, HALF + c_lo, out=mx, casting="unsafe")
    np.subtract(y, HALF + r_lo, out=my, casting="unsafe")
    win = Window(c_lo, r_lo, c_hi - c_lo, r_hi - r_lo)
    # the mask's bilinear neighbours of every position in the window: x - c_lo - 0.5 in [0, width - 2] (the
    # float32 maps and OpenCV's 1/32-px fixed point round monotonically, so they stay in it); NaN ones are not
    within = everywhere and x_lo - HALF - c_lo >= 0 and x_hi - HALF - c_lo <= c_hi - c_lo - 2 \
        and y_lo - HALF - r_lo >= 0 and y_hi - HALF - r_lo <= r_hi - r_lo - 2
    if max(c_hi - c_lo, r_hi - r_lo) <= _INT16_MAX:
        return (win, *cv2.convertMaps(mx, my, cv2.CV_16SC2), within)
    return win, mx, my, within


def _positions(plan: Plan, r0: int, c0: int, h: int, w: int):
    """Source positions ``(x, y)`` (``(h, w)`` each, corner convention; float32 if interpolated, else float64) of the
    window's cell centres: the mapping's ``grid`` (``(2, h, w)`` or ``(h·w, 2)``) if it has one, else of the centres."""
    grid = getattr(plan.inverse_map, "grid", None)
    sp = np.asarray(grid(plan.transform, r0, c0, h, w) if grid is not None else
                    plan.inverse_map(centres_to_map(plan.transform, r0, c0, h, w)))
    sp = sp if sp.dtype == np.float32 else sp.astype(np.float64, copy=False)
    if sp.ndim == 3:
        return sp[0], sp[1]
    return sp[:, 0].reshape(h, w), sp[:, 1].reshape(h, w)


def resample_window(src, plan: Plan, r0: int, c0: int, h: int, w: int):
    """The ``h x w`` output window at row ``r0``, column ``c0`` of the grid: ``(array (count, h, w),
    valid pixel count, count of valid pixels equal to nodata)``. Depends only on the position.

    Nearest neighbour takes, for each output centre, the source pixel GDAL's warper takes
    (:func:`nearest_source_pixels`), so with :class:`GeotransformInverse` the pixels equal
    ``gdalwarp -r near -et 0``'s, exact half-pixel ties included."""
    out = np.full((plan.count, h, w), plan.nodata, dtype=plan.dtype)
    nearest = plan.resampling == "nearest"
    located = (_nearest_maps if nearest else _interpolation_maps)(*_positions(plan, r0, c0, h, w), plan, h, w)
    if located is None:
        return out, 0, 0
    win, map1, map2, within = located
    mask, data, interleaved = _source_window(src, plan, win)
    if within and (mask is None or mask.min() == 255):  # the mask's remap would be all 255
        good = None
    elif mask is None and map1.dtype == np.int16:  # all valid, fixed-point maps: only the edge's cells remapped
        good = remapped_validity(map1, map2, win.height, win.width)
    else:
        mask = np.full((win.height, win.width), 255, np.uint8) if mask is None else mask
        m = cv2.remap(mask, map1, map2, cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR,
                      borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        good = m > 0 if nearest else m >= 255
    interp = RESAMPLING[plan.resampling]
    work_dtype = plan.dtype if plan.dtype in _CV_DTYPES else "float64"
    per_band = nearest and plan.band_nodata is not None and plan.band_nodata != plan.nodata
    if 1 < plan.count <= 4 and work_dtype == plan.dtype:  # one call for all bands: OpenCV's per-channel
        stacked = cv2.remap(data if interleaved else np.ascontiguousarray(np.moveaxis(data, 0, -1)),  # arithmetic
                            map1, map2, interp, borderMode=cv2.BORDER_REPLICATE)                   # is the same
        bands = [stacked[..., b] for b in range(plan.count)] if per_band else []
        if not per_band:  # de-interleaved by OpenCV into the output's bands, then the invalid cells get nodata
            for b, part in enumerate(cv2.split(stacked, list(out))):
                if not np.may_share_memory(part, out[b]):  # OpenCV allocated its own
                    out[b] = part
            if good is not None:
                np.copyto(out, out.dtype.type(plan.nodata), where=~good)
    else:
        bands = [cv2.remap(data[b] if work_dtype == plan.dtype else data[b].astype(work_dtype), map1, map2, interp,
                           borderMode=cv2.BORDER_REPLICATE) for b in range(plan.count)]
    for b, res in enumerate(bands):
        if per_band:  # a band at the source's nodata is that band's nodata in the output (GDAL)
            res[res == plan.band_nodata] = plan.nodata
        np.copyto(out[b], res.astype(plan.dtype, copy=False), where=True if good is None else good)
    at_nodata = False if plan.floating else (out == plan.nodata).all(axis=0)  # valid cells at the nodata value
    valid = h * w if good is None else int(np.count_nonzero(good))
    return out, valid, int(np.count_nonzero(at_nodata if good is None else at_nodata & good))


def windows_of(height: int, width: int, block: int, r_off: int = 0, c_off: int = 0, rows=None, cols=None):
    """``(r0, c0, h, w)`` of the ``block``-sized windows of the region ``rows x cols`` at
    ``(r_off, c_off)`` of a ``height x width`` grid (the whole grid by default), row by row."""
    rows = height - r_off if rows is None else rows
    cols = width - c_off if cols is None else cols
    return [(r, c, min(block, r_off + rows - r), min(block, c_off + cols - c))
            for r in range(r_off, r_off + rows, block) for c in range(c_off, c_off + cols, block)]


def resampled_windows(src_path, plan: Plan, windows, threads: int):
    """Yield ``(window, (array, valid, collisions))`` for each of ``windows`` in order, computed by
    ``threads`` threads with at most two windows per thread in flight (memory stays bounded)."""
    threads = max(1, min(int(threads), len(windows) or 1))
    with source_handles(src_path, threads, held=plan.pixels is not None, level=plan.level) as handles:
        def job(win):
            src = handles.get()
            try:
                return resample_window(src, plan, *win)
            finally:
                handles.put(src)

        if threads == 1:
            for win in windows:
                yield win, job(win)
            return
        with opencv_threads(1):
            yield from in_order(job, windows, threads, "fotogeo-warp")


def compress_threads(threads: int) -> int:
    """GDAL's tile-compressing threads beside ``threads`` resampling ones: half as many, at least 1 (then the
    writing thread compresses each tile itself, while the pool resamples the next windows).

    The pool keeps every CPU busy and resampling a window costs more than compressing its tiles (DEFLATE level 1):
    half as many keep pace; more only add hand-offs and CPU time (measured in docs/benchmarks/products.md)."""
    return max(1, int(threads) // 2)


def write_env(threads: int, zlevel: int | None = None, compress: str = "deflate"):
    """GDAL settings of fotogeo's raster writes: a bounded block cache, ``threads`` threads for compressing tiles
    and computing overviews, the overviews' level (:func:`~fotogeo.io.compression.overview_env`). Sources are read
    with ``threads=1``: GDAL's decoding pool cost a TIFF of one-row strips 6x the CPU time (docs/benchmarks)."""
    extra = overview_env(compress, zlevel)
    return rasterio.Env(GDAL_CACHEMAX=GDAL_CACHE_BYTES, GDAL_NUM_THREADS=str(max(1, int(threads))), **extra)


def warp_to_grid(src_path, dst_path, inverse_map, *, crs, transform, width: int, height: int,
                 resampling: str = "nearest", nodata=None, src_nodata=None, block: int = 512,
                 progress: Progress | None = None, overviews: bool = True, threads: int | None = None,
                 zlevel: int | None = None, tags: dict | None = None, reduce: bool = False,
                 compress: str = "deflate") -> dict:
    """Resample ``src_path`` onto the grid (crs, transform, width, height) into ``dst_path``.

    ``inverse_map((N, 2) map XY) -> (N, 2)`` source pixel coordinates (corner convention); one
    that also has ``grid(transform, r0, c0, h, w)`` is asked that instead, for the same positions of a
    window's ``h x w`` cell centres (row by row), so that it can do per-row and per-column work once
    (orthorectification samples a north-up DEM that way). It is called from several threads at once
    (``threads``, default :func:`default_threads`), so it must not keep state between calls. ``src_nodata``
    overrides the source's own nodata value (a pixel is invalid when every band equals it). ``compress``: the file's
    compression (:mod:`fotogeo.io.compression`), ``zlevel`` its and its overviews' DEFLATE level (GDAL's 6 when
    None). ``tags``: GDAL metadata items of the file, written with it. ``reduce``: read the source's reduced level
    where the output samples it coarsely (:mod:`fotogeo.io.warp_levels`). Returns a small summary (valid pixel
    count, the level's ``source_factor``). ``dst_path`` is written in place: callers give a temporary path (see
    :class:`fotogeo.io.raster.AtomicOutputs`).
    """
    progress = progress or Progress()
    threads = default_threads() if threads is None else max(1, int(threads))
    windows = windows_of(height, width, block)
    with write_env(1), ropen(src_path) as src:  # GDAL decodes in the reading thread (write_env)
        plan = make_plan(src, inverse_map, transform, resampling, nodata, src_nodata)
        plan = reduced_plan(src_path, src, plan, width, height) if reduce else plan
        with ropen(src_path, overview_level=plan.level) if plan.level is not None else nullcontext(src) as lvl:
            whole = whole_source(lvl, plan)
        if whole is not None:
            plan = dataclasses.replace(plan, pixels=whole[0], pixel_mask=whole[1])
        colorinterp = src.colorinterp
    summary = write_windows(src_path, dst_path, plan, windows, crs=crs, width=width, height=height, threads=threads,
                            colorinterp=colorinterp, progress=progress, share=0.9 if overviews else 1.0,
                            zlevel=zlevel, overviews=overviews, tags=tags, compress=compress)
    progress(1.0, "resampled")
    if summary["nodata_collisions"] and np.dtype(plan.dtype).kind == "i":
        warnings.warn(f"{summary['nodata_collisions']} valid pixels of {src_path} equal the output nodata value "
                      f"{plan.nodata} and will read as nodata; give the source a nodata value outside its data",
                      FotogeoWarning, stacklevel=2)
    return {**summary, "source_factor": plan.factor} if reduce else summary


def write_windows(src_path, dst_path, plan: Plan, windows, *, crs, width, height, threads, colorinterp=None,
                  progress=None, share: float = 1.0, offset=(0, 0), zlevel: int | None = None,
                  overviews: bool = False, tags: dict | None = None, compress: str = "deflate") -> dict:
    """Write the ``windows`` of ``plan``'s grid into a new GeoTIFF ``dst_path`` of ``width x height`` whose pixel
    (0, 0) is the grid's ``offset`` = (row, col); the summary of :func:`warp_to_grid`. ``overviews``: built before
    the file is closed (:func:`add_overviews`), from the tiles GDAL still caches (the same values as from the file
    reopened, without decompressing what was just compressed); ``tags``: GDAL metadata written with the file."""
    progress = progress or Progress()
    r_off, c_off = offset
    profile = geotiff_profile(width=width, height=height, count=plan.count, dtype=plan.dtype,
                              crs=crs.to_wkt() if hasattr(crs, "to_wkt") else crs,
                              transform=plan.transform * plan.transform.translation(c_off, r_off) if any(offset)
                              else plan.transform,
                              nodata=plan.nodata, predictor=True, num_threads=str(compress_threads(threads)),
                              compress=compress, **({"zlevel": int(zlevel)} if zlevel else {}))
    valid = collisions = 0
    with write_env(1), ropen(dst_path, "w", **profile) as dst:  # compressing threads: the creation option
        try:
            dst.colorinterp = colorinterp
        except Exception:  # noqa: BLE001 - colour interpretation is cosmetic
            pass
        if tags:
            dst.update_tags(**tags)
        for k, ((r0, c0, h, w), (out, n_valid, n_coll)) in enumerate(resampled_windows(src_path, plan, windows,
                                                                                       threads)):
            dst.write(out, window=Window(c0 - c_off, r0 - r_off, w, h))
            valid += n_valid
            collisions += n_coll
            progress((k + 1) / len(windows) * share, f"resampling window {k + 1}/{len(windows)}")
        if overviews:
            with write_env(threads, zlevel, compress):
                add_overviews(dst, width, height, plan.resampling)
    nd = plan.nodata
    return {"valid_pixels": valid, "nodata": None if nd != nd else nd, "nodata_collisions": collisions}


def add_overviews(dst, width: int, height: int, resampling: str) -> None:
    """Internal overviews (nearest for nearest-neighbour outputs, else average) of an open GeoTIFF: factors 2..64 while
    the level keeps ≥ :data:`OVERVIEW_MIN` px on its short side (orthority's) or 4× that on its long side (over 4:1)."""
    factors = [f for f in (2, 4, 8, 16, 32, 64) if max(min(width, height), max(width, height) / 4) / f >= OVERVIEW_MIN]
    if factors:
        dst.build_overviews(factors, Resampling.nearest if resampling == "nearest" else Resampling.average)
        dst.update_tags(ns="rio_overview", resampling=resampling)
