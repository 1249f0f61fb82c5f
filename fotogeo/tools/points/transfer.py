"""Area-based matching tools (paths in → paths out): GCP transfer and X-target measurement.

``transfer_gcps`` finds points of a reference image (GCPs measured there, or an orthophoto's
map positions) in a search image, to sub-pixel, with their precision: pyramid NCC from the
approximate positions, then least-squares matching (:func:`fotogeo.matching.transfer_points`).
The two images must have about the same orientation and scale (within ~10° and ~10 %).

``measure_targets`` measures X-shaped fiducial/calibration targets near approximate
positions (:func:`fotogeo.matching.measure_target`).

Point tables are CSV (columns named below) or any vector layer GDAL reads; outputs are CSV
or GeoPackage by their suffix. Pixel coordinates follow the GDAL corner convention.
"""
from __future__ import annotations

import warnings

import numpy as np

from ...errors import FotogeoWarning, VectorError
from ...image.fusion import pca_fuse
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, open_raster, read_decimated
from ...io.tables import find_column, is_layer, numeric_columns, read_table, write_table
from ...matching.status import CONVERGED
from ...progress import as_progress
from ..common.boundary import tool
from ..common.checks import check_has_points, check_unique_ids, check_window_fits


def _fused(info, role):
    path = info.path
    bands, mask, _ = read_decimated(info, info.width * info.height, role)
    f = pca_fuse(bands, mask, nodata=info.nodata, contrast="linear", name=f"{role} {path}")
    return info, np.where(f.mask, f.image, np.nan).astype(np.float32)


@tool("TRANSFER", rasters={"reference": None, "search": None})
def transfer_gcps(reference, search, points, output, *, search_radius: int = 32, half_window: int = 10,
                  ref_fields=("ref_col", "ref_row"), approx_fields=("col", "row"), id_field="id",
                  overwrite: bool = False, progress=None) -> dict:
    """Transfer the points of table ``points`` from ``reference`` into ``search``; write ``output``.

    Reference positions come from ``ref_fields`` or, when the table has no such columns but
    point geometries and the reference is georeferenced, from the geometries (map → pixel).
    Approximate search positions come from ``approx_fields``. The output holds per point
    ``col``, ``row`` (refined), ``sigma_x``, ``sigma_y``, ``ncc``, ``status`` and the approximation.
    """
    prog = as_progress(progress)
    check_output(output, [reference, search, points], overwrite, suffixes=(".csv", ".gpkg"))
    table = read_table(points, "point table")
    check_has_points(table, f"point table {str(points)!r}", (id_field, *ref_fields, *approx_fields))
    check_unique_ids(table, id_field, f"point table {str(points)!r}")
    ref_info, search_info = open_raster(reference, "reference"), open_raster(search, "search")
    check_window_fits(half_window, {"reference": ref_info, "search": search_info})
    ref_info, ref_img = _fused(ref_info, "reference")
    if all(find_column(table, f) is not None for f in ref_fields):
        ref_xy = numeric_columns(table, ref_fields, f"point table {str(points)!r}", finite=True, id_field=id_field)
    elif is_layer(table) and ref_info.georeferenced and len(table):
        from ...crs import transform_points
        from ...pixels import map_to_pixel
        if table.crs is None:
            raise VectorError(f"point table {points!r} has no CRS; its geometries cannot be placed on the reference")
        XY = np.column_stack([table.geometry.x, table.geometry.y])
        ref_xy = map_to_pixel(ref_info.transform, transform_points(table.crs, ref_info.crs, XY))
    else:
        raise VectorError(f"point table {points!r} needs reference pixel columns {', '.join(ref_fields)} "
                          f"(or point geometries on a georeferenced reference)")
    approx = numeric_columns(table, approx_fields, f"point table {str(points)!r}", finite=True, id_field=id_field)
    _, search_img = _fused(search_info, "search")
    prog(0.2, "images read")
    from ...matching import transfer_points
    res = transfer_points(ref_img, search_img, ref_xy, approx, search_radius=search_radius,
                          half_window=half_window, progress=prog.stage(0.2, 0.95, "matching"))
    ids = table[id_field].astype(str).to_numpy() if id_field in table.columns else np.arange(1, len(table) + 1).astype(str)
    cols = {"id": ids.astype(object), "ref_col": ref_xy[:, 0], "ref_row": ref_xy[:, 1],
            "approx_col": approx[:, 0], "approx_row": approx[:, 1], "col": res.xy[:, 0], "row": res.xy[:, 1],
            "sigma_x": res.sigma[:, 0], "sigma_y": res.sigma[:, 1], "ncc": res.ncc,
            "status": np.asarray(res.status).astype(object)}
    with AtomicOutputs(overwrite) as out:
        write_table(out.temp(output), cols, None, np.where(np.isfinite(res.xy), res.xy, approx))
        out.commit()
    ok = np.asarray(res.status) == CONVERGED
    if not ok.any():
        warnings.warn(f"none of the {len(ok)} points converged in {str(search)!r}: area-based matching needs the "
                      "search image at about the reference's orientation and scale, and approximate positions within "
                      "the search radius of the points", FotogeoWarning, stacklevel=2)
    prog(1.0, "done")
    return {"output": str(output), "points": len(ok), "converged": int(ok.sum()),
            "median_sigma_px": float(np.median(np.hypot(*res.sigma[ok].T))) if ok.any() else None,
            "statuses": {str(s): int(c) for s, c in zip(*np.unique(np.asarray(res.status), return_counts=True))}}
