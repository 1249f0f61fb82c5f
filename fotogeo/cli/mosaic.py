"""``fotogeo mosaic ORTHOS... -o MOSAIC.tif [--seamlines SEAMS.gpkg]`` — one mosaic with seamlines."""
from __future__ import annotations

import click

from ..options.products import MOSAIC
from .common import ConsoleProgress, options_from, quiet_option, run_tool, tool_arguments


@click.command("mosaic")
@click.argument("orthos", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="The mosaic (GeoTIFF).")
@click.option("--seamlines", type=click.Path(dir_okay=False), help="GeoPackage of seamlines and regions [OUT.gpkg].")
@options_from(MOSAIC)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(orthos, output, seamlines, overwrite, quiet, **kw):
    """Mosaic orthophotos of one CRS (others' pixel grids resampled onto the finest): seamlines along low-contrast
    paths between Voronoi cells of nadir distance, feathered blending, a gain and offset per image. Blended in
    tiles (threads; on Dask with --workers N or --scheduler ADDRESS) assembled into one Cloud-Optimised GeoTIFF."""
    from ..tools.ortho.mosaic import mosaic
    bar = ConsoleProgress(quiet)
    try:
        rep = mosaic(list(orthos), output, seamlines=seamlines, overwrite=overwrite, progress=bar,
                     **tool_arguments(kw, MOSAIC))
    finally:
        bar.close()
    for name, g, o in zip(rep["images"], rep["gains"], rep["offsets"]):
        click.echo(f"{name}: gain {' '.join(f'{v:.3f}' for v in g)}, offset {' '.join(f'{v:+.1f}' for v in o)}")
    if rep["resampled_onto_lattice"]:
        click.echo(f"resampled onto the mosaic's pixel grid (bilinear): {', '.join(rep['resampled_onto_lattice'])}")
    click.echo(f"wrote {rep['output']} ({rep['width']}x{rep['height']}) and {rep['seamlines']}")
    return rep
