"""``fotogeo measure-targets IMAGE POINTS -o OUT`` — X-shaped targets to sub-pixel precision."""
from __future__ import annotations

import click

from ..options import TARGETS
from .common import ConsoleProgress, options_from, quiet_option, run_tool, tool_arguments


@click.command("measure-targets")
@click.argument("image", type=click.Path(dir_okay=False))
@click.argument("points", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="CSV or GeoPackage.")
@options_from(TARGETS)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(image, points, output, overwrite, quiet, **kw):
    """Measure X-shaped fiducial/calibration targets near the approximate col/row of POINTS."""
    from ..tools.points.targets import measure_targets
    bar = ConsoleProgress(quiet)
    try:
        r = measure_targets(image, points, output, overwrite=overwrite, progress=bar, **tool_arguments(kw, TARGETS))
    finally:
        bar.close()
    click.echo(f"{r['measured']} of {r['targets']} targets measured; wrote {r['output']}")
    return r
