"""The source side of :mod:`fotogeo.io.warp`'s windows: the validity mask of source pixels and, for a source small
enough, the whole source held in memory once.

**Mask** (:func:`validity`): a pixel is valid where any band's mask is (a nodata value is per band, as in GDAL's
warper: a dark RGB pixel with one channel at 0 stays), invalid where every band equals the override ``src_nodata``
or any band is NaN/±inf; floating data get 0 there (never data, as in fuse). None stands for "all valid".

**Remapped validity of an all-valid source** (:func:`remapped_validity`): the cells where ``cv2.remap`` of the
window's all-255 mask (zero outside it) gives 255 (bilinear) or more than 0 (nearest), computed without remapping
every cell. With OpenCV's fixed-point maps (``CV_16SC2`` integer pixel ``(i, j)``, and for bilinear a 1/32-px
fraction index), a bilinear cell reads the taps ``i..i+1``, ``j..j+1`` with integer weights summing to 1024 and
gives ``(255 · w_in + 512) >> 10``: 255 when all four taps are inside the window, 0 when none is; only the cells
whose taps straddle the window's edge (``i`` or ``j`` at −1 or at the last column or row) are remapped, by
OpenCV itself as a ``1 x N`` map (a cell's value depends on its own map entry alone), so the result is the full
remap's cell for cell. A nearest cell reads the one tap ``(i, j)``: inside or not.

**Threads**: :func:`source_handles` (one GDAL handle per thread) and :func:`in_order` (a bounded pool whose
results come back in order).

**Freed memory** (:func:`keep_freed_memory`, for a command-line process): every window allocates and frees
arrays of a few MB; glibc returns such blocks to the system when they are freed and the next window faults its
pages in again (a sixth of an orthophoto's CPU time, most of it in the kernel). Raising glibc's trim threshold
keeps them in the process for reuse.

**Whole source** (:func:`whole_source`): a source of at most :data:`WHOLE_SOURCE_BYTES` (pixels and mask) of an
OpenCV type with 1 to 4 bands is read once, pixel-interleaved (``(rows, cols, bands)``, the layout ``cv2.remap``
takes), its mask beside it; every window is then a view of it instead of a read and an interleaving copy of its
own (a JPEG is decoded once instead of once per thread and again for every window above the last one read). The
pixels are the windowed reads' (GDAL's), so the output does not change.
"""
from __future__ import annotations

import collections
import concurrent.futures as cf
import contextlib
import ctypes
import queue

import cv2
import numpy as np

from .raster import ropen

#: sources up to this size (bytes of pixels and mask) are read whole into memory by :func:`whole_source`
WHOLE_SOURCE_BYTES = 128 * 2 ** 20
CV_DTYPES = {"uint8", "uint16", "int16", "float32", "float64"}


def validity(mask, data, plan, axis: int = 0):
    """``(mask, data)`` of a source block (module docstring): ``mask`` the file's (uint8, bands already reduced) or
    None when the file has none; ``data`` with the bands along ``axis``. The mask is None when every pixel is valid
    and no rule applies."""
    if plan.src_nodata is not None:
        mask = np.full(data.shape[:axis] + data.shape[axis + 1:], 255, np.uint8) if mask is None else mask
        mask[(data == plan.src_nodata).all(axis=axis)] = 0
    if plan.floating:
        finite = np.isfinite(data)
        if not finite.all():
            mask = np.full(finite.shape[:axis] + finite.shape[axis + 1:], 255, np.uint8) if mask is None else mask
            mask[~finite.all(axis=axis)] = 0
            data = np.where(finite, data, 0)
    return mask, data


def whole_source(src, plan, budget: int = WHOLE_SOURCE_BYTES):
    """``(pixels, mask)`` of the open source ``src`` read whole (module docstring): ``pixels`` ``(rows, cols,
    bands)`` for 2-4 bands, ``(1, rows, cols)`` for one; ``mask`` None when all valid. None when the source is
    larger than ``budget`` or not of an OpenCV type (its windows are read one by one)."""
    h, w, n = plan.src_height, plan.src_width, plan.count
    size = h * w * (n * np.dtype(plan.dtype).itemsize + (0 if plan.all_valid else 1))
    if plan.dtype not in CV_DTYPES or n > 4 or size > budget:
        return None
    if n == 1:
        pixels = src.read()
    else:
        pixels = np.empty((h, w, n), plan.dtype)
        src.read(out=pixels.transpose(2, 0, 1))  # GDAL writes the bands interleaved
    mask = None if plan.all_valid else src.read_masks().max(axis=0)
    mask, pixels = validity(mask, pixels, plan, axis=0 if n == 1 else 2)
    if mask is not None and mask.min() == 255:
        mask = None
    return pixels, mask


def remapped_validity(map1, map2, height: int, width: int):
    """Boolean ``(rows, cols)``: the cells of the fixed-point maps (``map1`` ``CV_16SC2``, ``map2`` the bilinear
    fraction indices or None for nearest) where ``cv2.remap`` of a ``height x width`` all-valid mask (255, zero
    outside: ``BORDER_CONSTANT``) is 255 (bilinear) or above 0 (nearest) — the same cells as that remap's
    (module docstring)."""
    if map2 is None:
        return cv2.inRange(map1, (0, 0), (width - 1, height - 1)) > 0
    inner = cv2.inRange(map1, (0, 0), (width - 2, height - 2))  # all four taps inside
    edge = np.flatnonzero(cv2.inRange(map1, (-1, -1), (width - 1, height - 1)) != inner)  # some of them
    good = inner > 0
    if edge.size:
        m = cv2.remap(np.full((height, width), 255, np.uint8), map1.reshape(-1, 2)[edge][None],
                      map2.reshape(-1)[edge][None], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        good.reshape(-1)[edge] = m[0] >= 255
    return good


@contextlib.contextmanager
def source_handles(path, n: int, held: bool = False, level=None):
    """A queue of ``n`` open handles on ``path`` (one per thread: a GDAL handle is not shared), on its overview
    ``level`` if not None; ``held``: the source is in memory (:func:`whole_source`), nothing is opened and the
    queue holds ``n`` Nones."""
    handles = queue.Queue()
    opened = []
    try:
        for _ in range(n):
            if held:
                handles.put(None)
                continue
            cm = ropen(path) if level is None else ropen(path, overview_level=level)
            opened.append(cm)
            handles.put(cm.__enter__())
        yield handles
    finally:
        for cm in opened:
            cm.__exit__(None, None, None)


def in_order(job, items, threads: int, name: str):
    """Yield ``(item, job(item))`` for each of ``items`` in order, ``job`` run by ``threads`` threads
    with at most two items per thread in flight (memory stays bounded). Leaving early (an error, a
    cancel, a closed generator) cancels what has not started and waits for what has."""
    pool = cf.ThreadPoolExecutor(max(1, threads), thread_name_prefix=name)
    try:
        pending, todo = collections.deque(), iter(items)
        for item in todo:
            pending.append((item, pool.submit(job, item)))
            if len(pending) >= 2 * max(1, threads):
                break
        while pending:
            item, fut = pending.popleft()
            nxt = next(todo, None)
            if nxt is not None:
                pending.append((nxt, pool.submit(job, nxt)))
            yield item, fut.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


#: :func:`keep_freed_memory`: glibc's ``M_TRIM_THRESHOLD`` and ``M_MMAP_THRESHOLD`` (its largest allowed value)
KEEP_FREED_BYTES, MMAP_THRESHOLD_BYTES = 64 * 2 ** 20, 32 * 2 ** 20


def keep_freed_memory() -> bool:
    """Let the process keep up to :data:`KEEP_FREED_BYTES` of freed memory and serve allocations below
    :data:`MMAP_THRESHOLD_BYTES` from its heap (glibc ``mallopt``; module docstring). A process-wide setting, for a
    command-line run (never called by the library itself); False where the C library has no ``mallopt``."""
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    m_trim_threshold, m_mmap_threshold = -1, -3
    return bool(mallopt(m_mmap_threshold, MMAP_THRESHOLD_BYTES)) & bool(mallopt(m_trim_threshold, KEEP_FREED_BYTES))


@contextlib.contextmanager
def opencv_threads(n: int):
    """OpenCV's own thread count set to ``n`` for the block (restored after): fotogeo's window threads each call
    ``cv2.remap``, whose inner parallel loop would only add its threads' spinning to theirs."""
    import cv2
    before = cv2.getNumThreads()
    cv2.setNumThreads(n)
    try:
        yield
    finally:
        cv2.setNumThreads(before)
