"""``fotogeo fuse SOURCE -o OUT.tif`` — PCA band fusion."""
from __future__ import annotations

import click

from ..options import FUSE
from .common import ConsoleProgress, options_from, quiet_option, run_tool


@click.command("fuse")
@click.argument("source", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False))
@options_from(FUSE)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(source, output, overwrite, quiet, **options):
    """First principal component of all bands of SOURCE (nodata excluded), georeference kept."""
    from ..tools.register.fuse import fuse_raster
    bar = ConsoleProgress(quiet)
    try:
        r = fuse_raster(source, output, overwrite=overwrite, progress=bar, **options)
    finally:
        bar.close()
    click.echo(f"PC1 explains {100 * r['explained']:.1f}% of the variance; component "
               f"{', '.join(f'{c:.3f}' for c in r['component'])}; wrote {r['output']}")
    return r
