"""Digital elevation models: a height array with its geotransform, sampled bilinearly.

A :class:`Dem` holds a float64 height array ``data[row, col]`` (NaN where there is no
height), the affine ``transform`` of its grid (rasterio ``Affine``; GDAL corner convention,
see :mod:`fotogeo.pixels`) and optionally its CRS. Heights are given at pixel *centres*.

Bilinear sampling at map point ``(X, Y)``: with ``(c, r) = to_centre(~transform * (X, Y))``
(array-index coordinates, the centre of ``data[0, 0]`` at (0, 0)), ``i = floor(r)``,
``j = floor(c)``, ``t = r - i``, ``u = c - j``::

    h = (1-t)(1-u) z[i, j] + (1-t) u z[i, j+1] + t (1-u) z[i+1, j] + t u z[i+1, j+1]

Points in the outer half pixel (between the outermost centres and the raster edge) take
the nearest edge value (the index is clamped); points outside the raster, or whose
neighbourhood touches a nodata cell, get NaN.

Heights reach the 3-D models as one ``heights`` argument (``model.inverse(dst, heights)``,
:class:`~fotogeo.geometry.georeference.Georeference`): ``None``, a number, an ``(N,)``
array (one per point), or a :class:`HeightSource` — anything with
``heights_and_gradient(XY)`` (a :class:`Dem`, a :class:`DemSampler`, a constant from
:func:`as_height_source`). Numbers and arrays are heights already; a height source is
sampled where the ground point turns out to be, so a model's inverse intersects the terrain.
A file becomes a :class:`Dem` through :func:`fotogeo.io.raster.read_dem` (the io layer imports this one, never
the other way round).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import InputError
from ..pixels import HALF, as_points, to_centre
from .height_sources import as_height_source, below  # noqa: F401 (their home before)
from .lattice import along, lattice

#: :meth:`DemSampler.heights_grid`: lattice step (cells) of the exactly transformed points, their error bound (DEM px)
GRID_STEP, GRID_TOL_PX = 64, 1e-3
#: rows of a window whose heights :meth:`DemSampler.heights_grid` computes at a time (~16 k cells of a 512-cell row)
_ROWS = 32
#: :meth:`Dem._quads`: the largest DEM (cells) whose cells' corners are kept as one array (4 x 8 bytes per cell)
QUAD_CELLS = 1 << 22


@runtime_checkable
class HeightSource(Protocol):
    """Terrain heights at map points: what a 3-D model's inverse intersects with.

    ``heights_and_gradient(XY)`` takes map points ``(N, 2)`` and returns ``(h, dh/dX, dh/dY)``,
    each ``(N,)``, NaN where there is no height. Optional: a ``z_range`` attribute ``(min, max)``
    bounding the heights (ray intersections then search that bracket) and a ``heights(XY)``
    method (a cheaper way to the heights alone).
    """

    def heights_and_gradient(self, XY) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


def is_height_source(heights) -> bool:
    """True for a terrain (anything :func:`as_height_source` wraps except a number); False for
    ``None``, numbers and arrays of heights. (``hasattr`` is what ``isinstance`` checks for the
    :class:`HeightSource` protocol, at a fraction of its cost: this runs for every model inverse.)"""
    return hasattr(heights, "heights_and_gradient") or hasattr(heights, "heights") or callable(heights)


def heights_at(heights, XY) -> np.ndarray:
    """Heights ``(N,)`` at map points ``XY`` ``(N, 2)`` for any ``heights`` argument (module doc):
    a number (broadcast), an ``(N,)`` array (as is) or a height source (sampled)."""
    n = len(XY)
    if heights is None:
        raise InputError("heights are needed here: give a number, one height per point or a DEM")
    if not is_height_source(heights):
        return np.broadcast_to(np.asarray(heights, dtype=np.float64), (n,))
    if hasattr(heights, "heights"):
        return np.asarray(heights.heights(XY), dtype=np.float64)
    if hasattr(heights, "heights_and_gradient"):  # a HeightSource
        return heights.heights_and_gradient(XY)[0]
    return np.asarray(heights(XY), dtype=np.float64).reshape(-1)  # a callable XY -> heights


@dataclass(frozen=True)
class Dem:
    """Heights ``data`` (rows, cols; float64, NaN = no height) on the grid ``transform``."""

    data: np.ndarray
    transform: object
    crs: object = None
    path: str | None = field(default=None, compare=False)

    def __post_init__(self):
        d = np.asarray(self.data, dtype=np.float64)
        if d.ndim != 2 or min(d.shape) < 2:
            raise InputError(f"DEM array must be 2-D with at least 2x2 cells; got shape {d.shape}")
        object.__setattr__(self, "data", d)

    @property
    def shape(self) -> tuple[int, int]:
        return self.data.shape

    @property
    def z_range(self) -> tuple[float, float]:
        """(min, max) of the valid heights."""
        return float(np.nanmin(self.data)), float(np.nanmax(self.data))

    def _inverse(self):
        """Coefficients (a, b, c, d, e, f) of the inverse geotransform (map -> corner pixels)."""
        t = self.transform
        det = t.a * t.e - t.b * t.d
        a, b, d, e = t.e / det, -t.b / det, -t.d / det, t.a / det
        return a, b, -a * t.c - b * t.f, d, e, -d * t.c - e * t.f

    def _index(self, XY):
        P = as_points(XY, 2, "DEM sample points")
        a, b, c0, d, e, f0 = self._inverse()
        return self._index_pixels(a * P[:, 0] + b * P[:, 1] + c0, d * P[:, 0] + e * P[:, 1] + f0)

    def _index_pixels(self, col, row):
        """:meth:`_index` of the DEM's own pixel coordinates ``(col, row)`` (corner convention), each ``(N,)``: the
        row and column ``(i, j)`` of each point's cell, its weights ``(t, u)`` and whether it lies on the DEM (a few
        passes over new arrays, the weights made in place: orthorectification asks it for every output cell)."""
        rows, cols = self.data.shape
        c, r = np.asarray(col, np.float64) - HALF, np.asarray(row, np.float64) - HALF  # to_centre
        if c.size and 0.0 <= min(c.min(), r.min()) and c.max() < cols - 1.0 and r.max() < rows - 1.0:
            # all strictly between the outer cell centres (a window inside the DEM; NaN fails the test): the
            # clipping and the last cell's index limit below would change nothing — the same values, fewer passes
            j, i = c.astype(np.intp), r.astype(np.intp)
            c -= j
            r -= i
            return i, j, r, c, np.ones(c.shape, bool)
        inside = (c >= -0.5) & (c <= cols - 0.5)
        inside &= r >= -0.5
        inside &= r <= rows - 0.5
        if not inside.all():
            c[~inside], r[~inside] = 0.0, 0.0
        np.clip(c, 0.0, cols - 1.0, out=c)
        np.clip(r, 0.0, rows - 1.0, out=r)
        j, i = c.astype(np.intp), r.astype(np.intp)  # truncation: the floor of these non-negative values
        np.minimum(j, cols - 2, out=j)
        np.minimum(i, rows - 2, out=i)
        c -= j
        r -= i
        return i, j, r, c, inside

    def heights(self, XY) -> np.ndarray:
        """Bilinear heights ``(N,)`` at map points ``XY`` ``(N, 2)``; NaN outside or at nodata (the
        value of :meth:`heights_and_gradient` without the gradient: resampling asks it per output cell)."""
        return self._bilinear(*self._index(XY))

    def heights_at_pixels(self, col, row) -> np.ndarray:
        """:meth:`heights` at the DEM's own pixel coordinates ``(col, row)`` (corner convention), each ``(N,)``."""
        return self._bilinear(*self._index_pixels(np.asarray(col, float), np.asarray(row, float)))

    def _bilinear(self, i, j, t, u, inside):
        """The module docstring's bilinear height at the cells ``(i, j)`` of :meth:`_index` (NaN where not inside),
        ``top + t (bottom − top)`` with ``top = z00 + u (z01 − z00)``; the four corners of every cell in one gather
        from :meth:`_quads` (or, for a large DEM, four from the flat array)."""
        z = self.data
        quads = self._quads()
        if quads is not None:
            q = quads.take(i * (z.shape[1] - 1) + j).view(np.float64).reshape(-1, 4)
            z00, z01, z10, z11 = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
        elif z.flags.c_contiguous:
            flat, k, n = z.reshape(-1), i * z.shape[1] + j, z.shape[1]
            z00, z01, z10, z11 = flat.take(k), flat.take(k + 1), flat.take(k + n), flat.take(k + n + 1)
        else:
            z00, z01, z10, z11 = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]
        top = z01 - z00
        top *= u
        top += z00
        h = z11 - z10
        h *= u
        h += z10
        h -= top
        h *= t
        h += top
        if not inside.all():
            h[~inside] = np.nan
        return h.reshape(np.shape(i))

    def _quads(self):
        """The four corners ``(z00, z01, z10, z11)`` of every cell (rows − 1, cols − 1) as one 32-byte element each,
        so that :meth:`_bilinear` gathers a cell with one index (~4x less CPU than four gathers); made once, for a
        DEM of at most :data:`QUAD_CELLS` cells (four times its memory), else None."""
        if self.data.size > QUAD_CELLS:
            return None
        q = self.__dict__.get("_quads_")
        if q is None:
            z = self.data
            q = np.stack([z[:-1, :-1], z[:-1, 1:], z[1:, :-1], z[1:, 1:]], axis=-1).reshape(-1, 4)
            q = np.ascontiguousarray(q).view(np.dtype((np.void, 32))).reshape(-1)
            self.__dict__["_quads_"] = q  # a cache, not a field (the dataclass is frozen)
        return q

    def heights_grid(self, X, Y):
        """Bilinear heights ``(len(Y), len(X))`` at the points of the grid ``X`` (columns) × ``Y`` (rows),
        the values :meth:`heights` gives at those points, computed with one index and weight per column and
        per row (a north-up DEM only: None for a rotated one). Orthorectification asks it per output window."""
        a, b, c0, d, e, f0 = self._inverse()
        if b != 0 or d != 0:
            return None
        rows, cols = self.data.shape
        j, u, in_c = _axis_weights(to_centre(np.column_stack([a * np.asarray(X, float) + c0,
                                                               np.zeros(len(X))]))[:, 0], cols)
        i, t, in_r = _axis_weights(to_centre(np.column_stack([np.zeros(len(Y)),
                                                               e * np.asarray(Y, float) + f0]))[:, 1], rows)
        lo = int(i.min()) if len(i) else 0
        z = self.data[lo:int(i.max()) + 2 if len(i) else 0]
        along = z[:, j] + u * (z[:, j + 1] - z[:, j])  # each DEM row needed, interpolated along the columns
        step = along[1:] - along[:-1]  # bottom − top of each pair of DEM rows (the same values as per cell)
        k = i - lo
        h = np.multiply(step[k], t[:, None]) if len(step) else np.zeros((len(i), len(j)))  # (faster than in place)
        h += along[k]
        if not in_r.all():
            h[~in_r, :] = np.nan
        if not in_c.all():
            h[:, ~in_c] = np.nan
        return h

    def breaks_grid(self, X, Y):
        """Where the heights of :meth:`heights_grid` at the grid ``X`` (columns) × ``Y`` (rows), both evenly spaced,
        may have a kink: the fractional column and row indices at which ``X`` and ``Y`` cross a line of DEM cell
        centres (between two such lines the heights are bilinear) or the DEM's edge — ``(columns, rows)``; None for a
        rotated DEM."""
        a, b, c0, d, e, f0 = self._inverse()
        if b != 0 or d != 0:
            return None
        rows, cols = self.data.shape
        return (_crossings(to_centre(a * np.asarray(X, float) + c0), cols),
                _crossings(to_centre(e * np.asarray(Y, float) + f0), rows))

    def heights_and_gradient(self, XY):
        """Bilinear heights and their map-coordinate gradient ``(h, dh/dX, dh/dY)``, each ``(N,)``."""
        i, j, t, u, inside = self._index(XY)
        z = self.data
        z00, z01, z10, z11 = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]
        h = (1 - t) * ((1 - u) * z00 + u * z01) + t * ((1 - u) * z10 + u * z11)
        dh_du = (1 - t) * (z01 - z00) + t * (z11 - z10)  # per array column
        dh_dt = (1 - u) * (z10 - z00) + u * (z11 - z01)  # per array row
        h = np.where(inside, h, np.nan)
        # chain rule through the inverse geotransform: (col, row) = inv * (X, Y)
        a, b, _, d, e, _ = self._inverse()
        dX = dh_du * a + dh_dt * d
        dY = dh_du * b + dh_dt * e
        return h, np.where(inside, dX, np.nan), np.where(inside, dY, np.nan)

    def __getstate__(self):  # pickled (dask tasks) without the cache of :meth:`_quads`
        return {k: v for k, v in self.__dict__.items() if k != "_quads_"}

    def __repr__(self) -> str:  # the array is large
        return f"Dem(shape={self.shape}, path={self.path!r})"


def _axis_weights(p, n: int):
    """Along one DEM axis of ``n`` cells: the lower index, the weight of the next and whether each
    centre-convention coordinate ``p`` lies on the DEM (the per-axis half of :meth:`Dem._index`)."""
    inside = (p >= -0.5) & (p <= n - 0.5)
    p = np.clip(np.where(inside, p, 0.0), 0.0, n - 1.0)
    k = np.minimum(np.floor(p).astype(np.intp), n - 2)
    return k, p - k, inside


def _crossings(p, n: int) -> np.ndarray:
    """Fractional indices at which the centre-convention coordinates ``p`` (linear in the index) cross ``-0.5``,
    ``0, 1, …, n - 1`` or ``n - 0.5``: the kinks of :func:`_axis_weights`' interpolation along an axis of ``n``
    cells (and its edges)."""
    if len(p) < 2 or p[1] == p[0]:
        return np.empty(0)
    lines = np.r_[-0.5, np.arange(n), n - 0.5]
    lines = lines[(lines > min(p[0], p[-1])) & (lines < max(p[0], p[-1]))]
    return np.sort((lines - p[0]) / (p[1] - p[0]))


class DemSampler:
    """Heights of a :class:`~fotogeo.geometry.dem.Dem` at points given in another CRS (bilinear).

    ``heights_and_gradient`` makes it usable wherever fotogeo takes a height source. The DEM's heights are in
    its CRS's length unit (:func:`fotogeo.io.raster.read_dem`); they are returned in ``crs``'s:
    ``h · m(DEM unit) / m(crs unit)`` (a DEM in US feet queried from UTM: × 0.3048006).
    """

    def __init__(self, dem, crs):
        from ..crs import same_crs
        from .vertical import length_unit_m
        self.dem = dem
        if dem.crs is None:
            raise InputError(f"DEM {dem.path!r} has no CRS; assign one (gdal_edit.py -a_srs) before using it")
        dcrs = dem.crs
        if same_crs(dcrs, crs):
            self._t = None
        else:
            from ..crs import transformer
            from .vertical import horizontal_crs
            self._t = transformer(crs, horizontal_crs(dcrs))  # the one read_dem_around's window used
        self.z_scale = length_unit_m(dcrs) / length_unit_m(crs)
        self.z_range = tuple(z * self.z_scale for z in dem.z_range)

    def heights(self, XY) -> np.ndarray:
        XY = np.asarray(XY, float)
        if self._t is not None:
            XY = np.column_stack(self._t.transform(XY[:, 0], XY[:, 1]))
        h = self.dem.heights(XY)
        return h * self.z_scale if self.z_scale != 1.0 else h

    def heights_grid(self, X, Y):
        """Heights ``(len(Y), len(X))`` at the grid ``X`` (columns) × ``Y`` (rows) of ``crs``: :meth:`heights`' values
        but for the CRS transformation, which is exact on a lattice of every :data:`GRID_STEP`-th row and column
        (:func:`~fotogeo.geometry.lattice.lattice`) and bilinear between its nodes in the DEM's pixel coordinates.
        It is checked at the middle of every lattice edge and cell (where bilinear interpolation of a smooth mapping
        errs most): when a point is more than :data:`GRID_TOL_PX` DEM pixels from the exact transformation's, or a
        node has none, the result is None (the caller then asks :meth:`heights` per point). A height is then off by
        at most that bound times the DEM's largest height step between neighbouring cells."""
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        if self._t is None:
            h = self.dem.heights_grid(X, Y)
            return h if h is None or self.z_scale == 1.0 else h * self.z_scale
        rows, cols = lattice(len(Y), GRID_STEP), lattice(len(X), GRID_STEP)
        rc, cc = _with_middles(rows), _with_middles(cols)
        exact = self._dem_pixels(X[cc], Y[rc])  # (2, len(rc), len(cc)): nodes at even indices, middles at odd
        if not np.isfinite(exact).all():
            return None
        # lattice.bilinear's two passes, the second a block of rows at a time: the same values, without the two
        # full-size planes of positions (written once and read back: the cost of a large window)
        top = along(exact[:, ::2, ::2], cols, np.arange(len(X)), 2)  # (2, len(rows), len(X))
        if not np.hypot(*(along(top[:, :, cc], rows, rc, 1) - exact)).max() <= GRID_TOL_PX:
            return None
        h = np.empty((len(Y), len(X)))
        for r0 in range(0, len(Y), _ROWS):  # a block of rows at a time: the temporaries stay in the cache
            b = along(top, rows, np.arange(r0, min(r0 + _ROWS, len(Y))), 1)
            h[r0:r0 + _ROWS] = self.dem.heights_at_pixels(b[0].ravel(), b[1].ravel()).reshape(b.shape[1:])
        return h * self.z_scale if self.z_scale != 1.0 else h

    def _dem_pixels(self, X, Y) -> np.ndarray:
        """The DEM's pixel coordinates ``(2, len(Y), len(X))`` (column, row; corner convention) of the grid ``X``
        × ``Y`` of ``crs``, transformed exactly."""
        XX, YY = np.meshgrid(X, Y)
        x, y = (np.asarray(v, float) for v in self._t.transform(XX.ravel(), YY.ravel()))
        a, b, c0, d, e, f0 = self.dem._inverse()
        return np.stack([a * x + b * y + c0, d * x + e * y + f0]).reshape(2, len(Y), len(X))

    def heights_and_gradient(self, XY, step: float = 1.0):
        """:meth:`heights` and their central differences over ``step`` map units, the five point sets through one
        transformation and one sampling (a ray intersection asks this every iteration)."""
        XY = np.asarray(XY, float).reshape(-1, 2)
        n = len(XY)
        h = self.heights(np.concatenate([XY, XY + [step, 0], XY - [step, 0], XY + [0, step], XY - [0, step]]))
        h0, xp, xm, yp, ym = (h[k * n:(k + 1) * n] for k in range(5))
        return h0, (xp - xm) / (2 * step), (yp - ym) / (2 * step)


def _with_middles(nodes) -> np.ndarray:
    """``nodes`` (increasing indices) with the middle index between each two inserted: nodes at even positions."""
    out = np.empty(2 * len(nodes) - 1, np.intp)
    out[::2] = nodes
    out[1::2] = (nodes[:-1] + nodes[1:]) // 2
    return out


def underlying_dem(heights) -> tuple:
    """``(Dem, queried from another CRS?)`` behind a height source: a :class:`Dem` itself, the DEM a
    :class:`DemSampler` queries from another CRS, the DEM under a geoid shift
    (:class:`~fotogeo.geometry.vertical.ShiftedHeights`, its ``source``)."""
    source = getattr(heights, "source", heights)
    dem = getattr(source, "dem", source)
    return dem, dem is not source
