"""``fotogeo transfer-points REFERENCE SEARCH POINTS -o OUT`` — points transferred by pyramid NCC + LSM."""
from __future__ import annotations

import click

from ..options import TRANSFER
from .common import ConsoleProgress, options_from, quiet_option, run_tool, tool_arguments


@click.command("transfer-points")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("search", type=click.Path(dir_okay=False))
@click.argument("points", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="CSV or GeoPackage.")
@options_from(TRANSFER)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(reference, search, points, output, overwrite, quiet, **kw):
    """Transfer POINTS (ref_col/ref_row, approximate col/row) from REFERENCE into SEARCH by
    pyramid NCC + least-squares matching; sub-pixel positions with σ per point."""
    from ..tools.points.transfer import transfer_gcps
    bar = ConsoleProgress(quiet)
    try:
        r = transfer_gcps(reference, search, points, output, overwrite=overwrite, progress=bar,
                          **tool_arguments(kw, TRANSFER))
    finally:
        bar.close()
    sigma = f"median σ {r['median_sigma_px']:.3f} px" if r["median_sigma_px"] is not None else "no σ"
    click.echo(f"{r['converged']} of {r['points']} points converged ({sigma}); statuses {r['statuses']}; "
               f"wrote {r['output']}")
    return r
