"""``fotogeo orient IMAGE GCPS --model …`` — fit an orientation model to GCPs."""
from __future__ import annotations

import click

from ..options import GCP, ORIENT
from .common import ConsoleProgress, options_from, quiet_option, run_tool, skipped_line, tool_arguments, warn


@click.command("orient")
@click.argument("paths", nargs=-1, required=True, metavar="[IMAGE] GCPS", type=click.Path(dir_okay=False))
@click.option("--report", type=click.Path(dir_okay=False), help="JSON report.")
@click.option("--vectors", type=click.Path(dir_okay=False), help="GeoPackage: gcps and error_vectors layers.")
@click.option("--plot", type=click.Path(dir_okay=False), help="PNG of the residual vectors over the image.")
@click.option("--points", type=click.Path(dir_okay=False), help="QGIS .points file with residuals.")
@click.option("--rpc", type=click.Path(dir_okay=False), help="GeoTIFF copy with the RFM as GDAL RPC metadata.")
@click.option("--gcp-tiff", type=click.Path(dir_okay=False),
              help="GeoTIFF copy with the control points as GDAL GCPs (poly1-3; gdalwarp -order N reproduces them).")
@click.option("--rectify", type=click.Path(dir_okay=False), help="Rectified GeoTIFF in the GCP CRS.")
@options_from(ORIENT, GCP)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(paths, quiet, **kw):
    """Fit an orientation model (ground → image) to the GCPs of IMAGE; check points measure it.

    Without IMAGE (GCPS only, with --camera) it is a numbers-only resection: the GCPs' pixel positions and the
    camera, whose image size is the image's.

    --model auto fits every model the GCPs allow and keeps the simplest within 5 % of the best
    check RMSE (the candidates and the reason are printed and in the report).

    GCPs whose pixel lies outside IMAGE are skipped with a warning naming each (and listed in the report); too
    few left for the model is an error. GCPs without a z value take their heights from --dem (or --height)
    when given, which opens the 3-D models (dlt, rfm, collinearity); without heights only 2-D models are
    fitted, and a hint names --dem when their residuals suggest relief."""
    from ..tools.orient.tool import orient
    if len(paths) > 2:
        raise click.UsageError(f"give IMAGE and GCPS (or GCPS alone with --camera), not {len(paths)} paths")
    image, gcps = (None, paths[0]) if len(paths) == 1 else paths
    bar = ConsoleProgress(quiet)
    try:
        rep = orient(image, gcps, progress=bar, **tool_arguments(kw, ORIENT, GCP), **kw)
    finally:
        bar.close()
    click.echo(f"model {rep['model_name']}: {rep['n_gcps']} GCPs")
    if skipped_line(rep):
        click.echo(skipped_line(rep))
    if "model_selection" in rep:
        sel = rep["model_selection"]
        key = sel["compared"]
        tried = ", ".join(f"{c['model']} {c[key]:.3f}" if c.get(key) is not None else f"{c['model']} (not fitted)"
                          for c in sel["candidates"])
        click.echo(f"auto chose {sel['chosen']}: {sel['because']}; {key.replace('_', ' ')}: {tried}")
    for role in ("control", "check", "blunder"):
        s = rep.get(role)
        if s and s.get("n"):
            mm = f"  ({s['rms_x_mm']:.4f} / {s['rms_y_mm']:.4f} mm)" if "rms_x_mm" in s else ""
            click.echo(f"{role:8s} n={s['n']:4d}  RMS x {s['rms_x_px']:.3f}  y {s['rms_y_px']:.3f}  "
                       f"xy {s['rms_xy_px']:.3f} px  max {s['max_px']:.3f}{mm}")
    click.echo(rep["blunder_test"])
    for f in rep["snooping"]:
        click.echo(f"{f['flag']}: GCP {f['id']}: {f['reason']}{' — removed' if f['removed'] else ''}")
    for w in rep["warnings"]:
        warn(w)
    if kw.get("vectors") or kw.get("plot"):
        click.echo(f"error vectors {rep['exaggeration']['legend']}")
    return rep
