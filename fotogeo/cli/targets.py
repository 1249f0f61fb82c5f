"""``fotogeo measure-targets IMAGE POINTS -o OUT`` — X-shaped targets to sub-pixel precision."""
from __future__ import annotations

import click

from .common import ConsoleProgress, run_tool


@click.command("measure-targets")
@click.argument("image", type=click.Path(dir_okay=False))
@click.argument("points", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="CSV or GeoPackage.")
@click.option("--half-window", type=int, default=12, show_default=True)
@click.option("--polarity", type=click.Choice(["auto", "bright", "dark"]), default="auto", show_default=True)
@click.option("--overwrite", is_flag=True)
@click.option("-q", "--quiet", is_flag=True)
@run_tool
def targets(image, points, output, half_window, polarity, overwrite, quiet):
    """Measure X-shaped fiducial/calibration targets near the approximate col/row of POINTS."""
    from ..tools.targets import measure_targets
    bar = ConsoleProgress(quiet)
    try:
        r = measure_targets(image, points, output, half_window=half_window, polarity=polarity,
                            overwrite=overwrite, progress=bar)
    finally:
        bar.close()
    click.echo(f"{r['measured']} of {r['targets']} targets measured; wrote {r['output']}")


command = targets
