"""What ``fotogeo dsm`` writes: the DSM GeoTIFF (COG layout), the JSON report and the point cloud's place in it.

The DSM has float32 bands: 1 the height (nodata :data:`NODATA`), 2 the number of pairs that gave it, 3 the
spread (standard deviation) of the points' heights in the cell, and with ``fill`` 4 the filled cells (1).
"""
from __future__ import annotations

import time

import numpy as np
from affine import Affine

NODATA = -32767.0
#: islands of the fused heights smaller than this many cells, joined by steps of at most SPECKLE_STEP cells'
#: widths, are mismatches and removed (:func:`fotogeo.stereo.fusion.remove_speckles`)
SPECKLE_CELLS = 64
SPECKLE_STEP = 4.0
BANDS = ("height", "pairs", "spread", "filled")


def _pair_entry(p, names) -> dict:
    d = p.as_dict(names)
    d.pop("overlap_polygon", None)
    return d


def pair_summary(choices, names, grid, height, count, filled, crs, rule, ref, notes, zlo, zhi, overlap, t0,
                 timings) -> dict:
    """The report (without the output paths): pairs, grid, completeness (the share of the cells both images of a
    kept pair see, ``overlap``, that got a height), heights, timings."""
    valid = np.isfinite(height) if filled is None else np.isfinite(height) & (filled == 0)
    inside = int(overlap.sum())
    return {
        "fotogeo": "dsm", "crs": crs.name, "crs_rule": rule, "height_reference": ref, "notes": notes,
        "height_search_range": [round(zlo, 3), round(zhi, 3)],
        "pairs": [_pair_entry(p, names) for p in choices],
        "pairs_kept": sum(p.kept for p in choices),
        "grid": {"width": grid.width, "height": grid.height, "resolution": grid.resolution,
                 "transform": list(transform_of(grid))[:6]},
        "completeness": round(float((valid & overlap).sum()) / max(1, inside), 4),
        "stereo_cells": inside,
        "filled_cells": int(filled.sum()) if filled is not None else 0,
        "heights": ({"min": float(np.nanmin(height)), "median": float(np.nanmedian(height)),
                     "max": float(np.nanmax(height))} if np.isfinite(height).any() else None),
        "timings_s": {"pairs_wall": timings, "cpu": round(time.process_time() - t0[0], 3),
                      "wall": round(time.perf_counter() - t0[1], 3)},
    }


def transform_of(grid) -> Affine:
    return Affine(grid.resolution, 0.0, grid.x0, 0.0, -grid.resolution, grid.y0)


def write_dsm(out, output, grid, crs, height, count, spread, filled, rep, report, cloud, point_cloud) -> None:
    """Write the DSM (and the report) through the :class:`~fotogeo.io.raster.AtomicOutputs` ``out``; the report
    gets the outputs' paths."""
    from ...io.cog import convert_to_cog
    from ...io.raster import geotiff_profile, ropen
    bands = [np.where(np.isfinite(height), height, NODATA), count.astype(np.float32),
             np.where(np.isfinite(spread), spread, NODATA)]
    if filled is not None:
        bands.append(filled.astype(np.float32))
    tmp = out.temp(output)
    profile = geotiff_profile(width=grid.width, height=grid.height, count=len(bands), dtype="float32",
                              crs=crs.to_wkt(), transform=transform_of(grid), nodata=NODATA, predictor=True)
    with ropen(tmp, "w", **profile) as ds:
        ds.write(np.stack(bands).astype(np.float32))
        for k, name in enumerate(BANDS[:len(bands)]):
            ds.set_band_description(k + 1, name)
    convert_to_cog(tmp, "average")
    rep["outputs"] = {"dsm": str(output)}
    if cloud is not None:
        rep["outputs"]["point_cloud"] = str(point_cloud)
        rep["points_written"] = cloud.count
    if report is not None:
        from ...io.report import write_json
        rep["outputs"]["report"] = str(report)
        write_json(out.temp(report), rep)
