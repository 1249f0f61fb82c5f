"""``fotogeo coreg REFERENCE TARGET -o OUT.tif`` — options from :data:`fotogeo.options.COREG`."""
from __future__ import annotations

import click

from ..options.coreg import COREG
from .common import ConsoleProgress, options_from, quiet_option, run_tool


@click.command("coreg")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="Corrected target (GeoTIFF, the target's grid) [none: measure only].")
@click.option("--shifts", type=click.Path(dir_okay=False),
              help="GeoPackage of the window shifts (layer windows) [OUT.gpkg with -o].")
@click.option("--field", type=click.Path(dir_okay=False),
              help="Displacement field, 2-band GeoTIFF dx, dy in target px [OUT_field.tif with -o].")
@click.option("--report", type=click.Path(dir_okay=False), help="JSON report [OUT.json with -o].")
@options_from(COREG)
@click.option("--overwrite", is_flag=True, help="Replace existing outputs.")
@quiet_option
@run_tool
def command(reference, target, output, shifts, field, report, overwrite, quiet, **options):
    """Co-register TARGET to REFERENCE, two georeferenced images of one area (other dates,
    sensors or pixel sizes), by area-based matching: a grid of windows, phase correlation and
    least-squares matching on gradient-orientation images (robust to seasonal and sensor
    radiometry), outliers rejected against a global model and the neighbours, and a smooth
    displacement field through the reliable windows. Writes the target corrected on its own grid
    (every band), the windows (OUT.gpkg), the field (OUT_field.tif) and the report (OUT.json).
    The georeferences must agree to within --max-shift target pixels.
    """
    from pathlib import Path

    from ..tools.coreg.tool import coregister
    if output is not None:
        out = Path(output)
        shifts = shifts or out.with_suffix(".gpkg")
        field = field or out.with_name(out.stem + "_field.tif")
        report = report or out.with_suffix(".json")
    bar = ConsoleProgress(quiet)
    try:
        rep = coregister(reference, target, output, shifts=shifts, field=field, report=report,
                         overwrite=overwrite, progress=bar, **options)
    finally:
        bar.close()
    for line in rep["summary"]:
        click.echo(line)
    written = [str(p) for p in (output, shifts, field, report) if p]
    click.echo(f"wrote {', '.join(written)}" if written else "measured only (give -o to write the corrected target)")
    return rep
