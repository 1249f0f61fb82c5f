"""Area-based co-registration, pass by pass, on strips handed out by a source.

A *strip source* is any callable ``source(row0, row1, col0, col1, field) -> (reference,
target)`` returning two float32 arrays of the pixel block ``[row0:row1, col0:col1]`` of the
target's grid (NaN outside the images and at nodata), the target deformed by ``field``
(``target(p + D(p))``, :func:`deform`) when ``field`` is not None. :class:`ArraySource` serves
arrays in memory; ``fotogeo.tools.coreg.tool`` reads files window by window. So this module
holds the method and no file I/O, and memory is bounded by one strip.

:func:`coregister_strips` runs ``iterations`` passes over the window grid
(:mod:`fotogeo.coreg.grid`):

1. pass 1 measures each window's shift ``d`` on the undeformed target
   (:func:`fotogeo.coreg.windows.match_windows`);
2. the outlier filters (:mod:`fotogeo.coreg.filter`) keep the reliable windows and give
   the global model; :func:`fotogeo.coreg.field.fit_field` makes the field ``D``;
3. pass k > 1 measures the remaining shift ``δ`` on the target deformed by the previous
   field, where a window's content moves nearly rigidly (iterative window deformation, as in
   particle image velocimetry, Scarano 2002); the window's match is then
   ``q = p + δ + D(p + δ)`` and steps 2–3 repeat.

Too few reliable windows raise :class:`fotogeo.errors.MatchingError` (never a wild field).
"""
from __future__ import annotations

from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field as dc_field, replace

import time

import cv2
import numpy as np

from ..errors import MatchingError
from ..matching.status import SHIFT_BEYOND_WINDOW
from ..models import get_model
from ..pixels import to_centre
from .field import DisplacementField, fit_field
from .filter import Filtered, reject_outliers
from .grid import WindowGrid
from .windows import WindowShifts, match_windows, strip_margin

#: the window disagrees with the smooth field through the others (robust spline, fotogeo.coreg.field)
OUTLIER_FIELD = "outlier: field"
#: pixels read beyond the displaced positions of a block (cubic support and rounding)
PAD = 4
#: the smoothing of the fields of passes before the last, times ``smoothing``: a window averages
#: the shift over its area, so detail of the field finer than a window, fitted in an early pass,
#: cannot be measured again (and corrected) in the next one
EARLY_STIFFNESS = 10.0


@dataclass(frozen=True)
class CoregOptions:
    """The method's settings (see :func:`fotogeo.tools.coreg.tool.coregister` for each)."""

    grid_spacing: int = 64
    window: int = 128
    representation: str = "orientation"
    lsm_representation: str | None = None
    iterations: int = 2
    smoothing: float = 1.0
    model: str = "affine"
    ransac_threshold: float = 3.0
    neighbour_radius: int = 1
    neighbour_tolerance: float = 1.0
    min_coverage: float = 0.5
    min_peak_ratio: float = 1.5
    min_correlation: float = 0.2
    max_shift: float = 5.0
    min_windows: int = 10
    field_step: int = 16
    seed: int = 0
    workers: int = 1
    strip_pixels: int = 2_000_000


@dataclass(frozen=True)
class Coregistration:
    """``field``; ``windows`` (the last pass, shifts composed: target = reference + shift);
    ``filtered`` (statuses after the outlier filters, residuals to the global model);
    ``first`` (pass 1's raw shifts, the misregistration before correction); ``passes``;
    ``delta`` (N, 2) the shifts the last pass measured on the deformed target (the residual of
    the previous pass's field; equal to ``windows.shift`` with one pass)."""

    field: DisplacementField
    windows: WindowShifts
    filtered: Filtered
    first: WindowShifts
    passes: int
    delta: np.ndarray
    timings: dict = dc_field(default_factory=dict)

    @property
    def reliable(self) -> np.ndarray:
        return self.filtered.status == "ok"


def deform(target_block, block_row0: int, block_col0: int, field: DisplacementField, row0: int, row1: int,
           col0: int, col1: int, interpolation=cv2.INTER_CUBIC, dxdy=None) -> np.ndarray:
    """``target(p + D(p))`` for the pixels ``p`` of ``[row0:row1, col0:col1]``, from
    ``target_block`` (float32, NaN = nodata) whose top-left pixel is ``(block_row0,
    block_col0)`` of the target; NaN where the support touches nodata or leaves the block.
    ``dxdy``: ``field.block(...)`` of these pixels when already computed."""
    dx, dy = field.block(row0, col0, row1 - row0, col1 - col0) if dxdy is None else dxdy
    mx, my = source_maps(dx, dy, row0 - block_row0, col0 - block_col0)
    bad = ~np.isfinite(target_block)
    src = np.where(bad, 0, target_block).astype(np.float32)
    out = cv2.remap(src, mx, my, interpolation, borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
    if bad.any():
        nb = cv2.remap(bad.astype(np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                       borderValue=1.0)
        out[nb > 0] = np.nan
    return out


def source_box(dx, dy, row0: int, col0: int):
    """``(row0, row1, col0, col1)`` of the source block that the pixels of a block with top-left
    pixel ``(row0, col0)``, displaced by ``(dx, dy)``, fall in (padded by ``PAD``)."""
    h, w = dx.shape
    return (int(np.floor(row0 + float(np.nanmin(dy)))) - PAD, int(np.ceil(row0 + h + float(np.nanmax(dy)))) + PAD,
            int(np.floor(col0 + float(np.nanmin(dx)))) - PAD, int(np.ceil(col0 + w + float(np.nanmax(dx)))) + PAD)


def source_maps(dx, dy, row_off: int, col_off: int):
    """``cv2.remap`` maps (centre convention, float32) of the pixels of a block displaced by
    ``(dx, dy)``, into a source array whose top-left pixel is ``(row_off, col_off)`` pixels
    above and left of the block's."""
    cols = (col_off + 0.5 + np.arange(dx.shape[1], dtype=np.float64))[None, :]
    rows = (row_off + 0.5 + np.arange(dx.shape[0], dtype=np.float64))[:, None]
    return to_centre(cols + dx).astype(np.float32), to_centre(rows + dy).astype(np.float32)


class ArraySource:
    """A strip source over two arrays on one grid (NaN = nodata), for tests and small images."""

    def __init__(self, reference, target):
        self.reference = np.asarray(reference, dtype=np.float32)
        self.target = np.asarray(target, dtype=np.float32)

    @staticmethod
    def _block(img, row0, row1, col0, col1):
        out = np.full((row1 - row0, col1 - col0), np.nan, np.float32)
        r0, c0 = max(row0, 0), max(col0, 0)
        r1, c1 = min(row1, img.shape[0]), min(col1, img.shape[1])
        if r1 > r0 and c1 > c0:
            out[r0 - row0:r1 - row0, c0 - col0:c1 - col0] = img[r0:r1, c0:c1]
        return out

    def __call__(self, row0, row1, col0, col1, field=None):
        ref = self._block(self.reference, row0, row1, col0, col1)
        if field is None:
            return ref, self._block(self.target, row0, row1, col0, col1)
        dx, dy = field.block(row0, col0, row1 - row0, col1 - col0)
        br0, br1, bc0, bc1 = source_box(dx, dy, row0, col0)
        block = self._block(self.target, br0, br1, bc0, bc1)
        return ref, deform(block, br0, bc0, field, row0, row1, col0, col1, dxdy=(dx, dy))


def measure(grid: WindowGrid, source, opts: CoregOptions, field: DisplacementField | None = None,
            progress=None) -> WindowShifts:
    """One pass over ``grid``: the windows' shifts on the target deformed by ``field`` (if given).

    Strips are matched by ``opts.workers`` threads (numpy, OpenCV and the FFTs release the
    GIL); the source must be safe to call from several threads (:class:`ArraySource` is,
    ``fotogeo.tools.coreg.files.RasterStrips`` locks its reads)."""
    m = strip_margin(opts.window, opts.max_shift)
    x0, x1 = int(grid.xy[:, 0].min()) - opts.window // 2 - m, int(grid.xy[:, 0].max()) + opts.window // 2 + m
    rows = max(1, (opts.strip_pixels // max(x1 - x0, 1) - opts.window - 2 * m) // grid.spacing + 1)
    strips = list(grid.strips(rows))

    def one(strip):
        sel, r0, r1 = strip
        ref, tgt = source(r0 - m, r1 + m, x0, x1, field)
        res = match_windows(ref, tgt, grid.xy[sel] - [x0, r0 - m], window=opts.window,
                            representation=opts.representation, min_coverage=opts.min_coverage,
                            min_peak_ratio=opts.min_peak_ratio, min_correlation=opts.min_correlation,
                            max_shift=opts.max_shift, lsm_representation=opts.lsm_representation)
        return replace(res, xy=grid.xy[sel], position=res.position + [x0, r0 - m])

    parts, pool = [], ThreadPoolExecutor(max(1, int(opts.workers)))
    try:
        for k, part in enumerate(pool.map(one, strips)):
            parts.append(part)
            if progress is not None:
                progress((k + 1) / len(strips), "matching windows")
    finally:  # a cancel (progress raised) drops the strips not started
        pool.shutdown(wait=True, cancel_futures=True)
    res = WindowShifts.concatenate(parts)
    order = np.argsort(np.concatenate([sel for sel, _, _ in strips]))
    return WindowShifts(*(getattr(res, f)[order] for f in WindowShifts.__dataclass_fields__))


def compose(windows: WindowShifts, field: DisplacementField | None) -> WindowShifts:
    """Shifts measured on the target deformed by ``field`` as shifts of the target itself:
    ``q = p + δ + D(p + δ)``, so ``shift = δ + D(p + δ)`` at ``p`` = ``position``."""
    if field is None:
        return windows
    ok = np.isfinite(windows.shift).all(axis=1)
    total = windows.shift.copy()
    total[ok] = windows.shift[ok] + field.at(windows.position[ok] + windows.shift[ok])
    return replace(windows, shift=total)


def status_counts(status) -> str:
    """``"120 nodata in window, 30 ambiguous"`` — the statuses by count, most frequent first."""
    return ", ".join(f"{n} {s}" for s, n in Counter(np.asarray(status).tolist()).most_common())


def refuse(windows: WindowShifts, status, opts: CoregOptions, why: str = "", size=None):
    """The one-line :class:`MatchingError` for too few reliable windows, with the options to try in the
    caller's words (command-line flags; the QGIS dialog shows its labels) and bounded by the image ``size``
    (width, height): a window is never suggested larger than the image."""
    n, valid, reliable = len(windows), int(windows.ok.sum()), int((np.asarray(status) == "ok").sum())
    need = max(opts.min_windows, get_model(opts.model).min_points + 2)
    raise MatchingError(
        f"co-registration refused: only {reliable} reliable windows of {n} ({valid} valid after phase correlation "
        f"and LSM; {status_counts(status)}){why}; at least {need} are needed — try "
        f"{', '.join(shift_hint(status, opts) + retry_hints(opts, size))}")


def shift_hint(status, opts: CoregOptions) -> list:
    """``[--max-shift hint]`` when most windows moved farther than ``--max-shift``: the georeferences disagree
    by more than it, which no window size, band or threshold changes (a target georeferenced 7.6 px off was
    told to try larger windows).

    >>> shift_hint(["shift beyond window"] * 3 + ["ambiguous"], CoregOptions(max_shift=5.0))
    ['a larger --max-shift (--max-shift 10, now 5: most windows moved farther; the georeferences disagree by more)']
    >>> shift_hint(["ambiguous"] * 3 + ["shift beyond window"], CoregOptions(max_shift=5.0))
    []
    """
    st = np.asarray(status)
    if st.size and 2 * int((st == SHIFT_BEYOND_WINDOW).sum()) > st.size:
        return [f"a larger --max-shift (--max-shift {2 * opts.max_shift:g}, now {opts.max_shift:g}: most windows "
                f"moved farther; the georeferences disagree by more)"]
    return []


def retry_hints(opts: CoregOptions, size=None) -> list:
    """What to try after a refusal, each option by its flag with a value that fits the image ``size``.

    >>> retry_hints(CoregOptions(window=512, grid_spacing=64), (448, 448))[0]
    'a window no larger than the image (--window 448, now 512)'
    >>> retry_hints(CoregOptions(window=128, grid_spacing=64), (448, 448))[0]
    'larger windows (--window 256)'
    """
    side = int(min(size)) - int(min(size)) % 2 if size else None
    if side is None or opts.window * 2 <= side:
        hints = [f"larger windows (--window {opts.window * 2})"]
    elif opts.window < side:
        hints = [f"larger windows (--window {side}, the image's size)"]
    elif opts.window > side:
        hints = [f"a window no larger than the image (--window {side}, now {opts.window})"]
    else:
        hints = []
    if opts.grid_spacing > 8:
        hints.append(f"a smaller grid spacing (--grid-spacing {max(8, opts.grid_spacing // 2)}, now {opts.grid_spacing})")
    return hints + ["another band", f"a lower --min-peak-ratio (now {opts.min_peak_ratio:g}) or --min-correlation (now "
                                    f"{opts.min_correlation:g})"]


def filter_and_fit(grid: WindowGrid, windows: WindowShifts, opts: CoregOptions, width: int, height: int):
    """The outlier filters and the field of one pass: ``(Filtered, DisplacementField)``."""
    need = max(opts.min_windows, get_model(opts.model).min_points + 2)
    if windows.ok.sum() < need:
        refuse(windows, windows.status, opts, size=(width, height))
    try:
        flt = reject_outliers(windows.position, windows.shift, windows.status, grid.index, grid.shape,
                              model=opts.model, threshold=opts.ransac_threshold, radius=opts.neighbour_radius,
                              tolerance=opts.neighbour_tolerance, seed=opts.seed)
    except MatchingError as e:
        refuse(windows, windows.status, opts, f" — {e}", size=(width, height))
    keep = flt.status == "ok"
    if keep.sum() < need:
        refuse(windows, flt.status, opts, size=(width, height))
    fld, w = fit_field(flt.model, windows.position[keep], windows.shift[keep], windows.reliability[keep],
                       width=width, height=height, spacing=grid.spacing, smoothing=opts.smoothing,
                       step=opts.field_step)
    status = flt.status.copy()
    status[np.nonzero(keep)[0][w <= 0]] = OUTLIER_FIELD
    return replace(flt, status=status), fld


def coregister_strips(grid: WindowGrid, source, width: int, height: int, opts: CoregOptions = CoregOptions(),
                      progress=None) -> Coregistration:
    """Every pass of the module docstring; ``progress(fraction, message)`` (optional)."""
    timings, fld, first = {}, None, None
    for k in range(max(1, int(opts.iterations))):
        t0 = time.perf_counter()
        sub = None if progress is None else (
            lambda f, m, k=k: progress((k + f) / opts.iterations, f"pass {k + 1}: {m}"))
        delta = measure(grid, source, opts, fld, sub)
        win = compose(delta, fld)
        first = win if first is None else first
        timings[f"pass {k + 1} matching"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        last = k == max(1, int(opts.iterations)) - 1
        stiff = opts if last else replace(opts, smoothing=opts.smoothing * EARLY_STIFFNESS)
        flt, fld = filter_and_fit(grid, win, stiff, width, height)
        timings[f"pass {k + 1} field"] = time.perf_counter() - t0
    return Coregistration(fld, win, flt, first, max(1, int(opts.iterations)), delta.shift, timings)
