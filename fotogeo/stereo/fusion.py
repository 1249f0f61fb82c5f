"""Points of several stereo pairs onto one north-up grid.

The grid: ``width x height`` cells of ``resolution`` map units, its top-left corner at ``(x0, y0)``; the cell of a
point ``(X, Y)`` is ``col = floor((X − x0) / res)``, ``row = floor((y0 − Y) / res)``.

Per pair (:class:`PairLayer`), the **rasterisation**: a cell's height is the mean of the pair's points in its 3 x 3
neighbourhood, each cell's points weighted by ``exp(−d² / 2σ²)`` with ``d`` the distance between the cell centres
in cells and σ = :data:`SPLAT_SIGMA` (own cell 1, side 0.14, corner 0.02: a Gaussian splat of radius one cell,
as CARS rasterises its points). A cell without a point of its own gets a height only when at least
:data:`SPLAT_MIN_CELLS` cells of its neighbourhood hold points: where the grid is as fine as the points (a
satellite product resampled finer than its ground sample distance, a slope turned away from a view) single cells
fall between points, and those are gaps of the sampling, not unmeasured surface; a hole wider than that stays NaN
(its border cells get one cell's reach at most). Across the pairs
(:class:`Fusion`, pair by pair: 4 bytes per cell and pair once a pair is done; :func:`fuse`), per cell:

* **height** — the median of the pairs' heights (one pair: its height), NaN where no pair has one;
* **count** — how many pairs gave a height;
* **spread** — the standard deviation of all points' heights in the cell, pooled over the pairs and weighted as
  the rasterisation weighs them (``sqrt(Σwz²/Σw − (Σwz/Σw)²)``): the surface's roughness and the matching noise
  at once.

:func:`remove_speckles` then drops small islands of heights (fewer than ``max_cells`` cells connected by steps of at
most ``max_step``): isolated mismatches, which a cell seen by one pair cannot outvote. Holes stay NaN;
:func:`fill_holes` fills them only when asked (OpenCV's Telea inpainting, 2004, on the heights, inside the
convex hull of the heights and, as ``gdal_fillnodata -md`` does, no farther than a maximum distance in cells from
the nearest height: the Euclidean distance between cell centres) and returns the mask of what it filled.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class GridSpec:
    """A north-up grid: top-left corner ``(x0, y0)``, cell size, ``width`` columns, ``height`` rows."""
    x0: float
    y0: float
    resolution: float
    width: int
    height: int

    def cells(self, XY) -> tuple:
        """``(flat cell index, inside)`` of points ``(N, 2)``."""
        XY = np.asarray(XY, float)
        with np.errstate(invalid="ignore"):
            col = np.floor((XY[:, 0] - self.x0) / self.resolution)
            row = np.floor((self.y0 - XY[:, 1]) / self.resolution)
            inside = (col >= 0) & (col < self.width) & (row >= 0) & (row < self.height)
        idx = np.where(inside, row * self.width + col, 0).astype(np.int64)
        return idx, inside

    def sub(self, r0: int, c0: int, rows: int, cols: int) -> "GridSpec":
        """The ``rows x cols`` cells from row ``r0``, column ``c0`` as a grid of their own."""
        return GridSpec(self.x0 + c0 * self.resolution, self.y0 - r0 * self.resolution, self.resolution, cols, rows)

    def tiles(self, size: int, margin: int = 0):
        """Yield ``(core, expanded)`` windows ``(r0, c0, rows, cols)`` covering the grid in tiles of at most
        ``size`` cells a side, each expanded by ``margin`` cells (clipped to the grid)."""
        for r0 in range(0, self.height, size):
            for c0 in range(0, self.width, size):
                rows, cols = min(size, self.height - r0), min(size, self.width - c0)
                R0, C0 = max(0, r0 - margin), max(0, c0 - margin)
                R1, C1 = min(self.height, r0 + rows + margin), min(self.width, c0 + cols + margin)
                yield (r0, c0, rows, cols), (R0, C0, R1 - R0, C1 - C0)

    def centres(self) -> tuple:
        """Cell centres ``(X (width,), Y (height,))``."""
        return (self.x0 + (np.arange(self.width) + 0.5) * self.resolution,
                self.y0 - (np.arange(self.height) + 0.5) * self.resolution)


#: the Gaussian weights' standard deviation (cells) of the rasterisation (module docstring)
SPLAT_SIGMA = 0.5
#: a cell without a point of its own gets a height when at least this many cells of its 3 x 3 neighbourhood hold one
SPLAT_MIN_CELLS = 4
#: squared distances (cells) from the centre of a 3 x 3 neighbourhood
_RING2 = np.array([[2.0, 1.0, 2.0], [1.0, 0.0, 1.0], [2.0, 1.0, 2.0]])


class PairLayer:
    """Sums of one pair's points per cell: count, Σz, Σz²."""

    def __init__(self, grid: GridSpec):
        self.grid = grid
        n = grid.width * grid.height
        self.n = np.zeros(n, np.int32)
        self.s = np.zeros(n, np.float64)
        self.s2 = np.zeros(n, np.float64)

    def add(self, XYZ) -> int:
        """Add points ``(N, 3)`` (NaN rows ignored); returns how many fell on the grid."""
        XYZ = np.asarray(XYZ, float)
        ok = np.isfinite(XYZ).all(axis=1)
        idx, inside = self.grid.cells(XYZ[:, :2])
        ok &= inside
        idx, z = idx[ok], XYZ[ok, 2]
        n = len(self.n)
        self.n += np.bincount(idx, minlength=n).astype(np.int32)
        self.s += np.bincount(idx, weights=z, minlength=n)
        self.s2 += np.bincount(idx, weights=z * z, minlength=n)
        return int(ok.sum())

    def mean(self) -> np.ndarray:
        """The pair's height per cell ``(height, width)`` float32 (module docstring, *rasterisation*), NaN where
        neither the cell nor enough of its neighbours hold a point."""
        shape = (self.grid.height, self.grid.width)
        n = self.n.reshape(shape)
        with np.errstate(invalid="ignore", divide="ignore"):
            m = np.where(reached(n), splat(self.s.reshape(shape)) / splat(n), np.nan)
        return m.astype(np.float32)


def splat(a) -> np.ndarray:
    """``a`` (per-cell sums) summed over each cell's 3 x 3 neighbourhood with the rasterisation's Gaussian weights
    (module docstring), float64."""
    w = np.exp(-_RING2 / (2.0 * SPLAT_SIGMA ** 2))
    return cv2.filter2D(np.asarray(a, np.float64), -1, w, borderType=cv2.BORDER_CONSTANT)


def reached(n) -> np.ndarray:
    """Cells that get a height from the point counts ``n`` (per cell): their own points, or points in at least
    :data:`SPLAT_MIN_CELLS` cells of their 3 x 3 neighbourhood."""
    held = cv2.filter2D((np.asarray(n) > 0).astype(np.float32), -1, np.ones((3, 3), np.float32),
                        borderType=cv2.BORDER_CONSTANT)
    return (np.asarray(n) > 0) | (held >= SPLAT_MIN_CELLS)


class Fusion:
    """The pairs' layers as they come (:meth:`add`): each pair's mean heights kept as float32 (4 bytes per cell
    and pair), the points' counts and sums pooled in one set; :meth:`result` gives :func:`fuse`'s bands."""

    def __init__(self, grid: GridSpec):
        self.grid, self.means = grid, []
        n = grid.width * grid.height
        self.n, self.s, self.s2 = np.zeros(n, np.int64), np.zeros(n), np.zeros(n)

    def add(self, layer: PairLayer) -> None:
        self.means.append(layer.mean())
        self.n += layer.n
        self.s += layer.s
        self.s2 += layer.s2

    def result(self, rows_per_block: int = 512) -> tuple:
        """``(height, count, spread)`` (module docstring), the median taken in blocks of rows."""
        shape = (self.grid.height, self.grid.width)
        height, count = np.full(shape, np.nan, np.float32), np.zeros(shape, np.int16)
        for r0 in range(0, shape[0], rows_per_block):
            block = np.stack([m[r0:r0 + rows_per_block] for m in self.means]) if self.means else None
            if block is None:
                break
            count[r0:r0 + rows_per_block] = np.isfinite(block).sum(axis=0)
            height[r0:r0 + rows_per_block] = nan_median(block)
        n, s, s2 = (splat(a.reshape(shape)) for a in (self.n, self.s, self.s2))
        with np.errstate(invalid="ignore", divide="ignore"):
            var = np.maximum(s2 / n - (s / n) ** 2, 0.0)
        spread = np.where(np.isfinite(height), np.sqrt(var), np.nan).astype(np.float32)
        return height, count, spread


def nan_median(stack) -> np.ndarray:
    """The median over axis 0 of ``stack`` ``(K, rows, cols)`` without its NaNs (the two middle values' mean for an
    even count; NaN where all are NaN): ``np.nanmedian``'s values, from one sort (NaN sorts last) instead of its
    cell-by-cell path."""
    stack = np.asarray(stack)
    if len(stack) == 1:
        return stack[0].copy()
    srt = np.sort(stack, axis=0)
    n = np.isfinite(srt).sum(axis=0)
    lo = np.take_along_axis(srt, (np.maximum(n - 1, 0) // 2)[None], axis=0)[0]
    hi = np.take_along_axis(srt, (n // 2)[None], axis=0)[0]
    with np.errstate(invalid="ignore"):
        out = np.where(n % 2 == 1, lo, (lo + hi) / 2)
    out[n == 0] = np.nan
    return out.astype(stack.dtype, copy=False)


def fuse(layers) -> tuple:
    """``(height, count, spread)`` ``(rows, cols)`` of the :class:`PairLayer` s (module docstring)."""
    layers = list(layers)
    f = Fusion(layers[0].grid)
    for ly in layers:
        f.add(ly)
    return f.result()


def remove_speckles(height, max_cells: int, max_step: float) -> tuple:
    """``(heights, removed)``: ``height`` without its islands (module docstring; OpenCV's ``filterSpeckles`` on the
    heights quantised to int16), ``removed`` the number of cells set to NaN."""
    valid = np.isfinite(height)
    if not valid.any():
        return height, 0
    lo, hi = float(np.nanmin(height)), float(np.nanmax(height))
    step = max((hi - lo) / 60000.0, max_step / 32000.0, 1e-4)  # max_step in steps fits int16: flat tiles kept
    q = np.full(height.shape, -32768, np.int16)
    q[valid] = np.round((height[valid] - lo) / step - 30000).astype(np.int16)
    cv2.filterSpeckles(q, -32768, int(max_cells), max(1, int(round(max_step / step))))
    gone = valid & (q == -32768)
    out = height.copy()
    out[gone] = np.nan
    return out, int(gone.sum())


def fill_holes(height, radius: int = 8, everywhere: bool = False, max_distance: float | None = None) -> tuple:
    """``(filled heights, mask)``: the NaN cells of ``height`` inside the convex hull of its valid cells (all of
    them with ``everywhere``) and at most ``max_distance`` cells from the nearest valid cell (Euclidean, between
    cell centres; None: any distance) filled by Telea inpainting (``radius`` cells), ``mask`` uint8 1 where
    filled; the cells beyond stay NaN."""
    valid = np.isfinite(height)
    if valid.all() or not valid.any():
        return height.copy(), np.zeros(height.shape, np.uint8)
    holes = ~valid
    if max_distance is not None:  # the exact Euclidean distance to the nearest valid cell (OpenCV's precise mask)
        near = cv2.distanceTransform(holes.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        holes &= near <= max_distance + 1e-4
    if not everywhere:
        hull = np.zeros(height.shape, np.uint8)
        rc = np.column_stack(np.nonzero(valid))[:, ::-1].astype(np.int32)
        cv2.fillConvexPoly(hull, cv2.convexHull(rc), 1)
        holes &= hull.astype(bool)
    known = height
    if (~valid & ~holes).any():  # the cells left unfilled take a nearest height (OpenCV's labels: the valid cells in
        # raster order), never read as 0, the lowest; kept out of Telea's mask, whose cost grows with its area
        _, near = cv2.distanceTransformWithLabels((~valid).astype(np.uint8), cv2.DIST_L2, 5,
                                                  labelType=cv2.DIST_LABEL_PIXEL)
        known = height[valid][near - 1]
    lo, hi = float(np.nanmin(height)), float(np.nanmax(height))
    span = max(hi - lo, 1e-6)
    norm = np.nan_to_num((known - lo) / span).astype(np.float32)  # the holes: 0, under the mask
    # in 16 bits: OpenCV 4.11's Telea on float32 extrapolates far beyond the data (ramp 0.5-9.9 m: filled -8.8-18.4)
    filled = cv2.inpaint((norm * 65535).astype(np.uint16), holes.astype(np.uint8), radius,
                         cv2.INPAINT_TELEA) / 65535 * span + lo
    out = np.where(holes, filled, height).astype(np.float32)
    return out, holes.astype(np.uint8)
