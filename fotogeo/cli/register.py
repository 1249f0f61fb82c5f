"""``fotogeo register REFERENCE TARGET -o OUT.tif`` — options from :data:`fotogeo.options.REGISTER`."""
from __future__ import annotations

import click

from ..options import REGISTER, REGISTER_TERRAIN
from .common import ConsoleProgress, options_from, quiet_option, run_tool


@click.command("register")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Output GeoTIFF.")
@click.option("--vectors", type=click.Path(dir_okay=False), help="GeoPackage of tie points and error vectors [OUT.gpkg].")
@click.option("--report", type=click.Path(dir_okay=False), help="JSON report [OUT.json].")
@click.option("--field", type=click.Path(dir_okay=False),
              help="With --local: the displacement field, 2-band GeoTIFF dx, dy in output px [OUT_field.tif].")
@options_from(REGISTER_TERRAIN, REGISTER)
@click.option("--overwrite", is_flag=True, help="Replace existing outputs.")
@quiet_option
@run_tool
def command(reference, target, output, vectors, report, field, overwrite, quiet, **options):
    """Register TARGET (any image of the area) to the georeferenced REFERENCE orthophoto.

    PCA band fusion, SURF keypoints, SSD ratio-test matching, RANSAC + robust homography,
    check points held out; writes OUT.tif (nearest neighbour by default; --cog for a Cloud
    Optimized GeoTIFF), OUT.gpkg (layers tie_points, error_vectors, error_grid) and OUT.json
    (report). Output CRS: the reference's when it is projected (on its pixel grid), else the UTM
    zone of its centre; --crs utm / reference / EPSG:xxxx to choose.
    """
    from ..tools.register.tool import register
    bar = ConsoleProgress(quiet)
    try:
        r = register(reference, target, output, vectors=vectors, report=report, field=field, overwrite=overwrite,
                     progress=bar, **options)
    finally:
        bar.close()
    for line in r.report["summary"]:  # fotogeo.tools.register.report.summary_lines: units and choices named
        click.echo(line)
    field = r.report.get("local", {}).get("field")
    click.echo(f"wrote {r.output}, {r.vectors}, {r.report_path}" + (f", {field}" if field else ""))
    return r
