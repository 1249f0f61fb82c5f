"""The model-comparison tool: GCPs (path) → table of control/check RMS per model, count and spread."""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from ..io.camera import load_camera
from ..io.gcps import check_inside, read_gcps
from ..io.raster import AtomicOutputs, check_output, open_raster
from ..models import get_model
from ..orientation.comparison import compare
from .checks import check_camera_size, check_gcp_crs
from .boundary import tool


@tool("COMPARE", "GCP", rasters={"image": None, "dem": None})
def compare_models(image, gcps, *, models=None, counts=(40, 20, 15, 10, 6), spreads=("homogeneous", "heterogeneous"),
                   trials: int = 5, seed: int = 0, table=None, markdown=None, dem=None, height=None, crs=None,
                   layer=None, fields=None, camera=None, overwrite: bool = False, progress=None) -> list[dict]:
    """Every model x control-point count x spread on one GCP set (roles ignored: all points are
    pooled, control points chosen per trial, the rest are check points). Writes CSV / Markdown."""
    info = open_raster(image, "image")
    for p in (table, markdown):
        if p:
            check_output(p, [image, gcps], overwrite, "table")
    g = read_gcps(gcps, layer=layer, crs=crs, raster=image if info.georeferenced else None, dem=dem,
                  height=height, **(fields or {}))
    check_gcp_crs(g, gcps)
    camera = load_camera(camera)
    check_camera_size(camera, info.width, info.height, image)
    check_inside(g, info.width, info.height, f"{gcps}")
    if models is None:
        models = ["similarity", "affine", "projective", "poly2", "poly3", "affine-height", "bilinear", "dlt",
                  "rfm", "rfm-common", "rfm-poly", "collinearity"]
    usable = [m for m in models if get_model(m).src_dims == 2 or g.has_heights]
    counts = [c for c in counts if c < len(g)]
    if not counts:
        raise InputError(f"{gcps} has only {len(g)} GCPs; the comparison needs more points than control points")
    rows = compare(usable, g.ground, g.pixel, counts=counts, spreads=spreads, trials=trials, seed=seed,
                   camera=camera, progress=progress)
    for m in set(models) - set(usable):
        rows.append({"model": m, "note": "3-D model: GCPs have no heights (give a height field, DEM or constant)"})
    with AtomicOutputs(overwrite) as out:
        if table:
            import csv
            keys = ["model", "spread", "n_control", "n_check", "control_rms_x_px", "control_rms_y_px",
                    "check_rms_x_px", "check_rms_y_px", "check_rms_xy_px", "check_max_px", "trials", "note"]
            with open(out.temp(table), "w", newline="") as f:
                wr = csv.DictWriter(f, keys, extrasaction="ignore")
                wr.writeheader()
                wr.writerows(rows)
        if markdown:
            Path(out.temp(markdown)).write_text(markdown_table(rows))
        out.commit()
    return rows


def markdown_table(rows) -> str:
    def f(v):
        return "" if v is None else (f"{v:.3f}" if isinstance(v, float) else str(v))
    head = "| model | spread | control | check | ctrl RMS x | ctrl RMS y | check RMS x | check RMS y | check max | note |\n"
    head += "|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n"
    return head + "".join(
        f"| {r.get('model')} | {f(r.get('spread'))} | {f(r.get('n_control'))} | {f(r.get('n_check'))} | "
        f"{f(r.get('control_rms_x_px'))} | {f(r.get('control_rms_y_px'))} | {f(r.get('check_rms_x_px'))} | "
        f"{f(r.get('check_rms_y_px'))} | {f(r.get('check_max_px'))} | {f(r.get('note'))} |\n" for r in rows)
