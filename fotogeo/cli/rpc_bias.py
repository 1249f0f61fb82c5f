"""``fotogeo rpc-bias IMAGE GCPS -o OUT.tif`` — correct a vendor RPC with GCPs (shift or affine)."""
from __future__ import annotations

import click

from ..options import RPC_BIAS
from .common import ConsoleProgress, options_from, quiet_option, run_tool, skipped_line, tool_arguments


@click.command("rpc-bias")
@click.argument("image", type=click.Path(dir_okay=False))
@click.argument("gcps", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="GeoTIFF copy of IMAGE carrying the corrected RPC.")
@click.option("--report", type=click.Path(dir_okay=False), help="JSON report [OUT.json].")
@options_from(RPC_BIAS)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(image, gcps, output, report, overwrite, quiet, **kw):
    """Correct the vendor RPC of IMAGE with the GCPs (Grodecki & Dial 2003 bias compensation).

    IMAGE's RPC: its GDAL RPC metadata, else an RPC file beside it (.geom, .RPB, _RPC.TXT, DIMAP or
    DigitalGlobe XML). GCPS: ground X, Y and (ellipsoidal) height in any CRS with their image col/row;
    GCPs outside the image are skipped with a warning naming each (as orient does; too few left is an error).
    Writes a copy of IMAGE whose GDAL RPC metadata is the corrected RPC (gdalwarp -rpc and QGIS use it) and a
    JSON report.
    """
    from ..tools.orient.rpc_bias import rpc_bias
    bar = ConsoleProgress(quiet)
    try:
        rep = rpc_bias(image, gcps, output, report=report, overwrite=overwrite, progress=bar,
                       **tool_arguments(kw, RPC_BIAS))
    finally:
        bar.close()
    c = rep["correction"]
    click.echo(f"{rep['method']} correction: shift {c['shift_px'][0]:+.3f} {c['shift_px'][1]:+.3f} px "
               f"(col, row); RMS at control points {c['rms_before_px']:.3f} -> {c['rms_after_px']:.3f} px"
               + (f", leave-one-out {c['rms_leave_one_out_px']:.3f} px" if c["rms_leave_one_out_px"] is not None
                  else ""))
    chk = rep["check"]
    if chk["before"].get("n"):
        click.echo(f"check points n={chk['before']['n']}: {chk['before']['rms_xy']:.3f} -> "
                   f"{chk['after']['rms_xy']:.3f} px")
    if skipped_line(rep):
        click.echo(skipped_line(rep))
    click.echo(f"wrote {rep['output']} (RPC refit max deviation {rep['refit_max_px']:.2g} px)")
    return rep
