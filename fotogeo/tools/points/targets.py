"""The target-measurement tool: an image + approximate target positions → sub-pixel centres."""
from __future__ import annotations

import numpy as np

from ...errors import InputError
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, open_raster, read_decimated
from ...io.tables import numeric_columns, read_table, write_table
from ...matching.status import CONVERGED
from ...progress import as_progress
from ..common.boundary import tool
from ..common.checks import check_has_points, check_unique_ids, check_window_fits


@tool("TARGETS", rasters={"image": None})
def measure_targets(image, points, output, *, half_window: int = 12, polarity: str = "auto",
                    approx_fields=("col", "row"), id_field="id", overwrite: bool = False, progress=None) -> dict:
    """Measure X-targets near the approximate positions of table ``points``; write ``output``."""
    prog = as_progress(progress)
    check_output(output, [image, points], overwrite, suffixes=(".csv", ".gpkg"))
    if polarity not in ("auto", "bright", "dark"):
        raise InputError(f"polarity must be 'auto', 'bright' or 'dark'; got {polarity!r}")
    table = read_table(points, "point table")
    check_has_points(table, f"point table {str(points)!r}", (id_field, *approx_fields))
    check_unique_ids(table, id_field, f"point table {str(points)!r}")
    approx = numeric_columns(table, approx_fields, f"point table {str(points)!r}", finite=True, id_field=id_field)
    info = open_raster(image, "image")
    check_window_fits(half_window, {"image": info})
    bands, mask, _ = read_decimated(info, info.width * info.height, "image")
    img = np.where(mask, bands.astype(np.float32).mean(axis=0), np.nan)
    from ...matching import measure_target
    rows = []
    for k, q in enumerate(approx):
        r = measure_target(img, q, half_window=half_window, polarity=polarity)
        rows.append((r.xy, r.sigma, r.status))
        prog((k + 1) / len(approx), f"target {k + 1}/{len(approx)}")
    xy = np.array([r[0] for r in rows], float).reshape(-1, 2)
    sig = np.array([r[1] for r in rows], float).reshape(-1, 2)
    ids = table[id_field].astype(str).to_numpy() if id_field in table.columns else np.arange(1, len(table) + 1).astype(str)
    cols = {"id": ids.astype(object), "approx_col": approx[:, 0], "approx_row": approx[:, 1],
            "col": xy[:, 0], "row": xy[:, 1], "sigma_x": sig[:, 0], "sigma_y": sig[:, 1],
            "status": np.array([r[2] for r in rows], dtype=object)}
    with AtomicOutputs(overwrite) as out:
        write_table(out.temp(output), cols, None, np.where(np.isfinite(xy), xy, approx))
        out.commit()
    return {"output": str(output), "targets": len(rows),
            "measured": int(sum(r[2] == CONVERGED for r in rows))}
