"""``fotogeo points-to-layer`` / ``fotogeo layer-to-points`` — QGIS ``.points`` ↔ GCP layer."""
from __future__ import annotations

import click

from ..options import LAYER_TO_POINTS, POINTS_TO_LAYER
from .common import ConsoleProgress, options_from, quiet_option, run_tool


@click.command("points-to-layer")
@click.argument("points", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="GeoPackage.")
@click.option("--layer", default="gcps", show_default=True, help="Layer name in the GeoPackage.")
@options_from(POINTS_TO_LAYER)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def to_layer(points, output, layer, overwrite, quiet, **options):
    """Convert a QGIS Georeferencer .points file into a GCP point layer (fields id, col, row, role, ...)."""
    from ..tools.points.layers import points_to_layer
    bar = ConsoleProgress(quiet)
    try:
        r = points_to_layer(points, output, layer=layer, overwrite=overwrite, progress=bar, **options)
    finally:
        bar.close()
    click.echo(f"{r['points']} points ({r['enabled']} enabled = control) -> {r['output']} layer {r['layer']}")
    return r


@click.command("layer-to-points")
@click.argument("source", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help=".points file.")
@click.option("--layer", help="Layer of a multi-layer file [the first].")
@options_from(LAYER_TO_POINTS)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def to_points(source, output, layer, overwrite, quiet, **options):
    """Convert a GCP point layer (fields col, row, role; or a register tie_points layer) into a .points file."""
    from ..tools.points.layers import layer_to_points
    bar = ConsoleProgress(quiet)
    try:
        r = layer_to_points(source, output, layer=layer, overwrite=overwrite, progress=bar, **options)
    finally:
        bar.close()
    click.echo(f"{r['points']} points -> {r['output']}")
    return r


command = [to_layer, to_points]
