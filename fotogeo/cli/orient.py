"""``fotogeo orient IMAGE GCPS --model …`` — fit an orientation model to GCPs."""
from __future__ import annotations

import click

from ..io.warp import RESAMPLING
from ..models import MODELS
from .common import ConsoleProgress, run_tool


def gcp_options(f):
    """Options shared by orient and compare-models: where GCPs, heights and the camera come from."""
    for opt in reversed([
        click.option("--layer", help="Layer of a multi-layer GCP file."),
        click.option("--crs", help="Map CRS of the GCPs (needed for CSV, .points without #CRS, layers without CRS)."),
        click.option("--col-field", default="col", show_default=True),
        click.option("--row-field", default="row", show_default=True),
        click.option("--z-field", default="z", show_default=True),
        click.option("--role-field", default="role", show_default=True),
        click.option("--id-field", default="id", show_default=True),
        click.option("--dem", type=click.Path(dir_okay=False), help="Heights for GCPs without a z value (bilinear)."),
        click.option("--height", type=float, help="Constant height for GCPs without a z value."),
        click.option("--camera", type=click.Path(dir_okay=False), help="Interior orientation YAML (collinearity)."),
        click.option("--overwrite", is_flag=True),
    ]):
        f = opt(f)
    return f


def fields_of(kw):
    return {k: kw.pop(f"{k}_field") for k in ("col", "row", "z", "role", "id")}


@click.command("orient")
@click.argument("image", type=click.Path(dir_okay=False))
@click.argument("gcps", type=click.Path(dir_okay=False))
@click.option("--model", type=click.Choice(sorted(MODELS)), default="poly1", show_default=True)
@click.option("--report", type=click.Path(dir_okay=False), help="JSON report.")
@click.option("--vectors", type=click.Path(dir_okay=False), help="GeoPackage: gcps and error_vectors layers.")
@click.option("--plot", type=click.Path(dir_okay=False), help="PNG of the residual vectors over the image.")
@click.option("--points", type=click.Path(dir_okay=False), help="QGIS .points file with residuals.")
@click.option("--rpc", type=click.Path(dir_okay=False), help="GeoTIFF copy with the RFM as GDAL RPC metadata.")
@click.option("--gcp-tiff", type=click.Path(dir_okay=False),
              help="GeoTIFF copy with the control points as GDAL GCPs (poly1-3; gdalwarp -order N reproduces them).")
@click.option("--rectify", type=click.Path(dir_okay=False), help="Rectified GeoTIFF in the GCP CRS.")
@click.option("--resolution", type=float, help="Pixel size of the rectified raster [image GSD].")
@click.option("--resampling", type=click.Choice(list(RESAMPLING)), default="nearest", show_default=True)
@click.option("--scan-pixel-um", type=float, help="Scan pixel size (µm) to report residuals in mm on the photo.")
@click.option("--snooping/--no-snooping", default=True, show_default=True, help="Data snooping for blunders.")
@click.option("--remove-blunders", is_flag=True, help="Drop flagged blunders and refit.")
@click.option("--exaggeration", type=float, default=1.0, show_default=True)
@gcp_options
@click.option("-q", "--quiet", is_flag=True)
@run_tool
def command(image, gcps, quiet, **kw):
    """Fit an orientation model (ground → image) to the GCPs of IMAGE; check points measure it."""
    from ..tools.orient import orient
    fields = fields_of(kw)
    bar = ConsoleProgress(quiet)
    try:
        rep = orient(image, gcps, fields=fields, progress=bar, **kw)
    finally:
        bar.close()
    click.echo(f"model {rep['model_name']}: {rep['n_gcps']} GCPs")
    for role in ("control", "check", "blunder"):
        s = rep.get(role)
        if s and s.get("n"):
            mm = f"  ({s['rms_x_mm']:.4f} / {s['rms_y_mm']:.4f} mm)" if "rms_x_mm" in s else ""
            click.echo(f"{role:8s} n={s['n']:4d}  RMS x {s['rms_x_px']:.3f}  y {s['rms_y_px']:.3f}  "
                       f"xy {s['rms_xy_px']:.3f} px  max {s['max_px']:.3f}{mm}")
    for f in rep["snooping"]:
        click.echo(f"blunder? GCP {f['id']}: {f['reason']}{' — removed' if f['removed'] else ''}")
    for w in rep["warnings"]:
        click.echo(f"warning: {w}")
