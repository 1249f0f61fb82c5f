"""What ``fotogeo dsm`` writes, shared by the frame and the RPC runs: the DSM GeoTIFF (COG layout) written tile by
tile, the point cloud, and the JSON report.

The DSM has float32 bands: 1 the height (nodata :data:`NODATA`), 2 the number of pairs that gave it, 3 the
spread (standard deviation) of the points' heights in the cell, and with ``fill`` (the filling's reach in cells,
None for none) 4 the filled cells (1).

:class:`Products` takes the fused heights of one output tile at a time (:meth:`Products.add`), over the tile
expanded by a margin of cells: there it removes the speckles (islands smaller than :data:`SPECKLE_CELLS` cells,
:func:`fotogeo.stereo.fusion.remove_speckles` — a margin of that many cells sees every island that touches the
tile whole, so tiles give the result of the whole grid), fills the holes with ``fill`` (inside the expanded tile:
a reach up to the margin sees every height it measures from, so here too tiles give the whole grid's result),
writes the tile's window and keeps what the report needs (completeness, heights); :meth:`Products.finish` writes
the report, turns the GeoTIFF into a COG and writes beside it (``style``: its path, None for none) the QGIS style
that draws band 1 over the heights' 2 … 98 % (:mod:`fotogeo.io.qml`). Memory: the tile, never the grid.

The report counts cells: ``overlap_cells`` those both images of a kept pair see (``stereo_cells``, its earlier
name, kept for readers of earlier reports: it never counted cells with a height), ``matched_cells`` those of them
with a matched height (``completeness`` = matched / overlap), ``filled_cells`` those ``fill`` gave a height.
"""
from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np
from affine import Affine

from ...errors import FotogeoWarning, InputError
from ...io.qml import CUT, write_dsm_style
from ...io.raster import HEIGHT_REFERENCE_TAG
from ...stereo.fusion import fill_holes, remove_speckles

NODATA = -32767.0
#: islands of the fused heights smaller than this many cells, joined by steps of at most SPECKLE_STEP cells'
#: widths, are mismatches and removed (:func:`fotogeo.stereo.fusion.remove_speckles`)
SPECKLE_CELLS = 64
SPECKLE_STEP = 4.0
#: the margin of cells around an output tile (module docstring)
TILE_MARGIN = SPECKLE_CELLS
BANDS = ("height", "pairs", "spread", "filled")
#: at most about this many heights are kept for the report's median (a regular sample of each tile beyond it)
HEIGHT_SAMPLE = 4_000_000
#: below this share of the overlap with a height (``completeness``) the run warns, naming the likely cause
#: (:func:`coverage_cause`)
LOW_COMPLETENESS = 0.5


class NoHeight(NamedTuple):
    """The refusal of a run where no cell got a height, in its two parts: what happened (``head``, which may
    name images: any text) and its likely ``cause``; :meth:`Products.finish` puts the resolution before the cause
    when it is finer than the images' ground sample distance. (A single sentence was split at its first ": ",
    which a name holding ": " moved.)"""
    head: str
    cause: str

    def __str__(self) -> str:
        return f"{self.head}: {self.cause}"


def finer_than_gsd(resolution: float, gsd: float | None) -> str:
    """Why a DSM of cells ``resolution`` (m) comes out sparse from images of ground sample distance ``gsd`` (m,
    None: not known), "" when its cells are not finer than a pixel: each pixel matched gives one point, so a cell
    smaller than a pixel gets a height only where a point falls in it, and the islands of such cells are removed as
    speckles (:data:`SPECKLE_CELLS`)."""
    if gsd is None or not resolution < gsd:
        return ""
    return (f"--resolution {resolution:g} is finer than the images' ground sample distance ({gsd:.3g} m; one "
            f"point per pixel matched leaves cells empty): give --resolution {float(f'{2 * gsd:.2g}'):g} (the "
            f"default, twice the ground sample distance) or one nearer it")


def coverage_cause(resolution: float, gsd: float | None) -> str:
    """The likely cause the run can see of a DSM with few heights: a resolution finer than the images' ground
    sample distance (:func:`finer_than_gsd`), else what no resolution mends (texture, cloud, change); one rule of
    the frame and the RPC runs."""
    return finer_than_gsd(resolution, gsd) or "textureless, cloud-covered or changed areas?"


def pair_entry(p, names) -> dict:
    """A pair's entry in the report (its measures, kept or not and why; not its overlap's outline)."""
    d = p.as_dict(names)
    d.pop("overlap_polygon", None)
    return d


def with_dem_vertical(crs, ref, dem):
    """The DSM's CRS: the map CRS ``crs`` joined, as a compound CRS, to the vertical CRS the ``dem`` file states
    when the DSM's heights are in that DEM's reference (``ref`` "geoid", the report's ``height_reference``), so
    that the GeoTIFF and the LAS say what the report says; ``crs`` otherwise (no DEM, ellipsoidal heights, a DEM
    without a vertical CRS)."""
    if ref != "geoid" or dem is None:
        return crs
    from pyproj.crs import CompoundCRS

    from ...geometry.vertical import as_pyproj, crs_height_reference, horizontal_crs
    from ...io.raster import open_raster
    stated = open_raster(dem, "DEM").raster_crs
    if stated is None or crs_height_reference(stated) != "geoid":
        return crs
    d, h = as_pyproj(stated), as_pyproj(horizontal_crs(crs))  # a map CRS with a vertical part: its horizontal one
    parts = [s.source_crs if s.is_bound else s for s in (d.sub_crs_list or [d])]
    v = next((s for s in parts if s.type_name == "Vertical CRS"), None)
    if v is None:
        return crs
    name = h.name if h.name.endswith(f" + {v.name}") else f"{h.name} + {v.name}"
    return CompoundCRS(name, [h, v])


def with_ellipsoidal_height(crs, ref):
    """The point cloud's CRS: ``crs`` made 3-D (its third axis the ellipsoidal height) when the heights are
    ellipsoidal (``ref`` "ellipsoid") and ``crs`` is 2-D; ``crs`` otherwise. LAS 1.4 stores it as WKT; a GeoTIFF
    cannot (GeoTIFF 1.1 has no projected CRS with an ellipsoidal height, and GDAL writes none), so the DSM states
    the reference in its metadata item :data:`fotogeo.io.raster.HEIGHT_REFERENCE_TAG` (as the report's
    ``height_reference``), read back by :func:`fotogeo.io.raster.stated_height_reference`."""
    from ...geometry.vertical import as_pyproj, crs_height_reference
    if ref != "ellipsoid" or crs is None or crs_height_reference(crs) is not None:
        return crs
    return as_pyproj(crs).to_3d()


def transform_of(grid) -> Affine:
    return Affine(grid.resolution, 0.0, grid.x0, 0.0, -grid.resolution, grid.y0)


class Products:
    """The outputs of one run inside the :class:`~fotogeo.io.raster.AtomicOutputs` ``out`` (module docstring);
    ``seen(grid, height)`` gives the cells of a (sub-)grid that both images of a kept pair see."""

    def __init__(self, out, output, grid, crs, *, fill: float | None, point_cloud=None, report=None, seen=None,
                 height_reference: str | None = None, style=None, gsd: float | None = None):
        import rasterio

        from ...io.raster import gdal_env, geotiff_profile
        self.out, self.output, self.grid, self.crs, self.fill = out, output, grid, crs, fill
        self.point_cloud, self.report, self.seen, self.style = point_cloud, report, seen, style
        self.coverage_warning = None
        self.gsd = gsd  # the images' ground sample distance (m): the cause named when few cells get a height
        self.cloud = None
        if point_cloud is not None:
            from ...io.las import LasWriter
            self.cloud = LasWriter(out.temp(point_cloud), with_ellipsoidal_height(crs, height_reference),
                                   compress=Path(point_cloud).suffix.lower() == ".laz")
        self.tmp = out.temp(output)
        profile = geotiff_profile(width=grid.width, height=grid.height, count=3 if fill is None else 4,
                                  dtype="float32", crs=crs.to_wkt(), transform=transform_of(grid), nodata=NODATA,
                                  predictor=True)
        with gdal_env():
            self.ds = rasterio.open(self.tmp, "w", **profile)
        for k, name in enumerate(BANDS[:profile["count"]]):
            self.ds.set_band_description(k + 1, name)
        if height_reference is not None:
            self.ds.update_tags(**{HEIGHT_REFERENCE_TAG: height_reference})
        self.stride = max(1, int(grid.width * grid.height // HEIGHT_SAMPLE))
        self.valid = self.inside = self.filled = self.speckles = self.single = 0
        self.sample, self.lo, self.hi = [], np.inf, -np.inf

    def add(self, core, expanded, height, count, spread) -> None:
        """The fused ``height``, ``count``, ``spread`` of the window ``expanded`` ``(r0, c0, rows, cols)``; the
        window ``core`` inside it is written."""
        from rasterio.windows import Window

        from ...io.raster import gdal_env
        before = np.isfinite(height)
        height, _ = remove_speckles(height, SPECKLE_CELLS, SPECKLE_STEP * self.grid.resolution)
        gone = before & ~np.isfinite(height)
        matched, filled = height, None  # the stereo cells are found on the matched heights, never the filled ones
        if self.fill is not None and np.isfinite(height).any():
            height, filled = fill_holes(height, max_distance=self.fill)
        r, c = core[0] - expanded[0], core[1] - expanded[1]
        cut = (slice(r, r + core[2]), slice(c, c + core[3]))
        height, count, spread = height[cut], count[cut].copy(), spread[cut]
        gone = gone[cut]
        valid = np.isfinite(height) if filled is None else np.isfinite(height) & (filled[cut] == 0)
        count[~np.isfinite(height)] = 0
        self.speckles += int(gone.sum())
        if np.isfinite(height).any():
            overlap = self.seen(self.grid.sub(*core), matched[cut])
            self.valid += int((valid & overlap).sum())
            self.single += int((valid & overlap & (count == 1)).sum())
            self.inside += int(overlap.sum())
            v = height[np.isfinite(height)]
            self.lo, self.hi = min(self.lo, float(v.min())), max(self.hi, float(v.max()))
            self.sample.append(v[::self.stride])
        bands = [np.where(np.isfinite(height), height, NODATA), count.astype(np.float32),
                 np.where(np.isfinite(spread), spread, NODATA)]
        if self.fill is not None:
            self.filled += int(filled[cut].sum()) if filled is not None else 0
            bands.append(filled[cut].astype(np.float32) if filled is not None else np.zeros(height.shape, np.float32))
        with gdal_env():  # the bounded block cache: GDAL's default would hold a large grid's written blocks
            self.ds.write(np.stack(bands).astype(np.float32), window=Window(core[1], core[0], core[3], core[2]))

    def finish(self, choices, names, rule, ref, notes, zlo, zhi, t0, timings, empty: NoHeight) -> dict:
        """Close the outputs and return the report (written with ``report``); ``empty`` the refusal when no cell
        got a height, the resolution named first when it is finer than the images' ground sample distance; a
        warning below ``LOW_COMPLETENESS`` names the likely cause (:func:`coverage_cause`)."""
        from ...io.cog import convert_to_cog
        fine = finer_than_gsd(self.grid.resolution, self.gsd)
        if not self.sample:
            raise InputError(f"{empty.head}: {fine}; or {empty.cause}" if fine else str(empty))
        self.ds.close()
        convert_to_cog(self.tmp, "average")
        heights = np.concatenate(self.sample)
        if self.style is not None:
            write_dsm_style(self.out.temp(self.style), *np.quantile(heights, CUT))
        g = self.grid
        rep = {
            "fotogeo": "dsm", "crs": self.crs.name, "crs_rule": rule, "height_reference": ref, "notes": notes,
            "height_search_range": [round(zlo, 3), round(zhi, 3)],
            "pairs": [pair_entry(p, names) for p in choices],
            "pairs_kept": sum(p.kept for p in choices),
            "grid": {"width": g.width, "height": g.height, "resolution": g.resolution,
                     "transform": list(transform_of(g))[:6]},
            "completeness": round(self.valid / max(1, self.inside), 4),
            "overlap_cells": self.inside, "matched_cells": self.valid, "stereo_cells": self.inside,
            "filled_cells": self.filled,
            "single_pair_share": round(self.single / max(1, self.valid), 4),
            **({} if self.fill is None else {"fill_max_distance_cells": self.fill}),
            "heights": {"min": self.lo, "median": float(np.median(heights)), "max": self.hi},
            "timings_s": {"pairs_wall": timings, "cpu": round(time.process_time() - t0[0], 3),
                          "wall": round(time.perf_counter() - t0[1], 3)},
            "speckle_cells_removed": self.speckles,
            "outputs": {"dsm": str(self.output), **({} if self.style is None else {"qgis_style": str(self.style)})},
        }
        if self.cloud is not None:
            self.cloud.close()
            rep["outputs"]["point_cloud"] = str(self.point_cloud)
            rep["points_written"] = self.cloud.count
        if self.report is not None:
            from ...io.report import write_json
            rep["outputs"]["report"] = str(self.report)
            write_json(self.out.temp(self.report), rep)
        if rep["completeness"] < LOW_COMPLETENESS:  # said by warn_coverage, once the outputs are in place
            self.coverage_warning = (f"only {100 * rep['completeness']:.0f} % of the overlap got a height ("
                                     f"{coverage_cause(g.resolution, self.gsd)})")
        return rep

    def warn_coverage(self) -> None:
        """:meth:`finish`'s low-completeness warning, given after the outputs are committed: a caller that turns
        warnings into errors keeps the DSM it was told about."""
        if self.coverage_warning:
            warnings.warn(self.coverage_warning, FotogeoWarning, stacklevel=3)

    def close(self) -> None:
        """Release the files (after :meth:`finish`, or on an error: AtomicOutputs then deletes them)."""
        if not self.ds.closed:
            self.ds.close()
