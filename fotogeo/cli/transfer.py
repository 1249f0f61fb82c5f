"""``fotogeo transfer-points REFERENCE SEARCH POINTS -o OUT`` — points transferred by pyramid NCC + LSM."""
from __future__ import annotations

import click

from .common import ConsoleProgress, run_tool


@click.command("transfer-points")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("search", type=click.Path(dir_okay=False))
@click.argument("points", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="CSV or GeoPackage.")
@click.option("--search-radius", type=int, default=32, show_default=True, help="Pixels around the approximation.")
@click.option("--half-window", type=int, default=10, show_default=True, help="LSM window (2h+1)².")
@click.option("--overwrite", is_flag=True)
@click.option("-q", "--quiet", is_flag=True)
@run_tool
def transfer(reference, search, points, output, search_radius, half_window, overwrite, quiet):
    """Transfer POINTS (ref_col/ref_row, approximate col/row) from REFERENCE into SEARCH by
    pyramid NCC + least-squares matching; sub-pixel positions with σ per point."""
    from ..tools.transfer import transfer_gcps
    bar = ConsoleProgress(quiet)
    try:
        r = transfer_gcps(reference, search, points, output, search_radius=search_radius,
                          half_window=half_window, overwrite=overwrite, progress=bar)
    finally:
        bar.close()
    click.echo(f"{r['converged']} of {r['points']} points converged (median σ {r['median_sigma_px']} px); "
               f"statuses {r['statuses']}; wrote {r['output']}")


command = transfer
