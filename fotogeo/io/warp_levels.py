"""Reading the source of a warp at a reduced level when the output samples it coarsely.

When every output cell spans at least ``f`` source pixels in every direction, sampling the full-resolution source
at the cells' centres (bilinear or cubic) only picks points out of it: the decoding of the skipped pixels is wasted
and the result aliases. The source's own reduced level ``1/f`` is then read instead — a JPEG's DCT-scaled decoding
(GDAL's implicit overviews at 1/2, 1/4, 1/8: the inverse DCT of each 8 x 8 block's low frequencies, about a
``f x f`` box filter, at a fraction of the decoding time) or the overviews a file carries — and sampled at the same
positions scaled by ``1/f``. Convention: (0, 0) is the top-left corner of the top-left pixel; reduced pixel ``i``
covers source pixels ``[f·i, f·(i+1))``, so a source position ``x`` is ``x / f`` in the reduced image, exactly
(which holds when the source's width and height are multiples of ``f``: other levels are not used). This is the
choice ``gdalwarp`` makes by default (``-ovr AUTO``: the level not coarser than the output).

**Rule** (:func:`reduction_factor`): over a 33 x 33 lattice of output cells whose centres fall in the source,
the output cell's size in source pixels along its narrowest direction — the smaller singular value of the 2 x 2
Jacobian of (column, row) of the output → (x, y) of the source, by finite differences of one cell — is ``s``; the
level read is the largest power-of-two factor ``f ≤ 1.01·s_min`` the file has (``f ≥ 2``; the 1 % is GDAL's own
tolerance when it picks an overview for a non-nearest read, ``GDAL_OVERVIEW_OVERSAMPLING_THRESHOLD``). Only for interpolating
resamplings (nearest neighbour keeps the source's own values), sources without nodata or mask (a reduced level
mixes valid and invalid pixels at their boundary), and levels of exactly ``(width / f, height / f)`` pixels
(a JPEG's EXIF thumbnail, also listed as an overview, is not one).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..pixels import HALF
from .raster import ropen

#: the output lattice :func:`reduction_factor` samples (cells per side)
LATTICE = 33
#: a level may be this much coarser than the output's narrowest cell (GDAL's tolerance, module docstring)
TOLERANCE = 1.01


class ReducedMapping:
    """``inverse_map`` (map XY → source pixel, corner convention) followed by ``/ factor``: the position in the
    source's level ``1/factor`` (module docstring); has ``grid`` when ``inverse_map`` has."""

    def __init__(self, inverse_map, factor: int):
        self.inverse_map, self.factor = inverse_map, float(factor)
        if hasattr(inverse_map, "grid"):
            self.grid = self._grid

    def __call__(self, XY) -> np.ndarray:
        return np.asarray(self.inverse_map(XY), np.float64) / self.factor

    def _grid(self, transform, r0: int, c0: int, h: int, w: int) -> np.ndarray:
        g = np.asarray(self.inverse_map.grid(transform, r0, c0, h, w))
        if g.dtype == np.float32:  # interpolated positions (fotogeo.geometry.lattice.bilinear32): kept so
            return np.divide(g, np.float32(self.factor), out=g)
        return np.asarray(g, np.float64) / self.factor


def cell_scale(inverse_map, transform, width: int, height: int, src_width: int, src_height: int,
               n: int = LATTICE):
    """The smallest size in source pixels of an output cell along its narrowest direction over an ``n x n``
    lattice of the grid's cells whose centres map into the source (module docstring); None when none does."""
    rows = np.unique(np.linspace(0, height - 1, n).round())
    cols = np.unique(np.linspace(0, width - 1, n).round())
    r, c = (g.ravel() for g in np.meshgrid(rows, cols, indexing="ij"))
    cells = np.concatenate([np.column_stack([c, r]), np.column_stack([c + 1, r]), np.column_stack([c, r + 1])])
    t = transform
    x, y = cells[:, 0] + HALF, cells[:, 1] + HALF
    XY = np.column_stack([t.a * x + t.b * y + t.c, t.d * x + t.e * y + t.f])
    p = np.asarray(inverse_map(XY), np.float64).reshape(3, -1, 2)
    jac = np.stack([p[1] - p[0], p[2] - p[0]], axis=-1)  # (N, 2, 2): columns d/dcol, d/drow
    inside = np.isfinite(p).all(axis=(0, 2)) & (p[0, :, 0] >= 0) & (p[0, :, 0] <= src_width) \
        & (p[0, :, 1] >= 0) & (p[0, :, 1] <= src_height)
    if not inside.any():
        return None
    return float(np.linalg.svd(jac[inside], compute_uv=False)[:, -1].min())


def reduction_factor(src, plan, width: int, height: int):
    """``(factor, overview level index)`` of the level of the open source ``src`` to read for ``plan`` on a
    ``width x height`` grid (module docstring); None when the full resolution is read."""
    if plan.resampling == "nearest" or not plan.all_valid:
        return None
    levels = [(f, i) for i, f in enumerate(src.overviews(1))
              if f >= 2 and f & (f - 1) == 0 and src.width % f == 0 and src.height % f == 0]
    if not levels:
        return None
    scale = cell_scale(plan.inverse_map, plan.transform, width, height, src.width, src.height)
    usable = [(f, i) for f, i in levels if scale is not None and f <= TOLERANCE * scale]
    return max(usable) if usable else None


def reduced_plan(src_path, src, plan, width: int, height: int):
    """``plan`` reading the level of :func:`reduction_factor` (its ``level``, dimensions and mapping scaled), or
    ``plan`` itself when the full resolution is read or the level's size is not ``(width / f, height / f)``."""
    chosen = reduction_factor(src, plan, width, height)
    if chosen is None:
        return plan
    f, index = chosen
    with ropen(src_path, overview_level=index) as lvl:
        size = (lvl.width, lvl.height)
    if size != (src.width // f, src.height // f):
        return plan
    return dataclasses.replace(plan, inverse_map=ReducedMapping(plan.inverse_map, f), src_width=size[0],
                               src_height=size[1], level=index, factor=f)
