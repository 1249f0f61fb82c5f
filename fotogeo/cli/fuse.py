"""``fotogeo fuse SOURCE -o OUT.tif`` — PCA band fusion."""
from __future__ import annotations

import click

from ..tools.fuse import fuse_raster
from .common import ConsoleProgress, run_tool


@click.command("fuse")
@click.argument("source", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False))
@click.option("--stretch/--no-stretch", default=True, show_default=True,
              help="uint8 0..255 robust stretch, or float32 component values.")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--overwrite", is_flag=True)
@click.option("-q", "--quiet", is_flag=True)
@run_tool
def command(source, output, stretch, seed, overwrite, quiet):
    """First principal component of all bands of SOURCE (nodata excluded), georeference kept."""
    bar = ConsoleProgress(quiet)
    try:
        r = fuse_raster(source, output, stretch=stretch, seed=seed, overwrite=overwrite, progress=bar)
    finally:
        bar.close()
    click.echo(f"PC1 explains {100 * r['explained']:.1f}% of the variance; component "
               f"{', '.join(f'{c:.3f}' for c in r['component'])}; wrote {r['output']}")
