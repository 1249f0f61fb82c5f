"""``fotogeo register-batch REFERENCE TARGETS... -o OUTDIR`` — many scenes on Dask; options from
:data:`fotogeo.options.REGISTER_BATCH`, :data:`~fotogeo.options.REGISTER` and
:data:`~fotogeo.options.REGISTER_TERRAIN`."""
from __future__ import annotations

import sys

import click

from ..options import REGISTER, REGISTER_BATCH, REGISTER_TERRAIN
from .common import ConsoleProgress, options_from, quiet_option, run_tool

#: exit code when the batch ran but some scenes failed (their rows in the manifest say why)
EXIT_SOME_FAILED = 1


@click.command("register-batch")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("targets", nargs=-1, required=True)
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False),
              help="Output folder: <scene>.tif/.gpkg/.json per scene, manifest.csv and manifest.gpkg.")
@options_from(REGISTER_BATCH, REGISTER_TERRAIN, REGISTER)
@quiet_option
@run_tool
def command(reference, targets, outdir, quiet, **options):
    """Register every TARGET scene to REFERENCE (an orthophoto, a mosaic or a VRT) on Dask.

    TARGETS are paths, globs ('scenes/*.tif', quoted) or a list file (.txt, one path per line).
    Runs on a local Dask cluster (one worker per CPU, --workers) or on a running cluster
    (--scheduler tcp://host:8786; the workers must see the same paths). One task per scene;
    a failed scene is recorded and the batch goes on; a second run skips the scenes already
    done (--no-resume registers them again). Writes OUTDIR/manifest.csv and
    OUTDIR/manifest.gpkg (layer scenes: footprint, status, inliers, check RMSE, time, error).
    Exit code 1 when some scenes failed.
    """
    from ..tools.register.batch import register_batch
    bar = ConsoleProgress(quiet)
    try:
        r = register_batch(reference, list(targets), outdir, progress=bar, **options)
    finally:
        bar.close()
    click.echo(f"{r.ok} registered, {r.skipped} done before, {r.failed} failed; manifest {r.manifest_csv}, "
               f"{r.manifest_gpkg}")
    for scene, error in r.failures.items():
        click.echo(f"failed {scene}: {error}", err=True)
    if r.failed:
        sys.exit(EXIT_SOME_FAILED)
    return r
