"""``fotogeo register REFERENCE TARGET -o OUT.tif`` — options from :data:`fotogeo.options.REGISTER`."""
from __future__ import annotations

import click

from ..options import REGISTER, REGISTER_TERRAIN
from .common import ConsoleProgress, options_from, run_tool


@click.command("register")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Output GeoTIFF.")
@click.option("--vectors", type=click.Path(dir_okay=False), help="GeoPackage of tie points and error vectors [OUT.gpkg].")
@click.option("--report", type=click.Path(dir_okay=False), help="JSON report [OUT.json].")
@options_from(REGISTER_TERRAIN, REGISTER)
@click.option("--overwrite", is_flag=True, help="Replace existing outputs.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
@run_tool
def command(reference, target, output, vectors, report, overwrite, quiet, **options):
    """Register TARGET (any image of the area) to the georeferenced REFERENCE orthophoto.

    PCA band fusion, SURF keypoints, SSD ratio-test matching, RANSAC + robust homography,
    check points held out; writes OUT.tif (nearest neighbour by default), OUT.gpkg (layers
    tie_points, error_vectors) and OUT.json (report).
    """
    from ..tools.register import register
    bar = ConsoleProgress(quiet)
    try:
        r = register(reference, target, output, vectors=vectors, report=report, overwrite=overwrite, progress=bar,
                     **options)
    finally:
        bar.close()
    rep = r.report
    click.echo(f"keypoints {rep['keypoints']['target']} / {rep['keypoints']['reference']}, "
               f"matches {rep['matches']}, inliers {rep['inliers']}")
    for role in ("control", "check"):
        s = rep[role]
        if s.get("n"):
            click.echo(f"{role:8s} n={s['n']:5d}  RMSE {s['rmse_m']:.3f} m  ({s['rmse_px']:.2f} reference px)")
    if "terrain" in rep:
        t = rep["terrain"]
        click.echo(f"3-D model {t['chosen']} ({t['chosen_because']}); check RMSE {t['check_rmse_target_px']:.2f} "
                   f"target px; {t['tie_points_without_height']} tie points without DEM height skipped")
    click.echo(f"wrote {r.output}, {r.vectors}, {r.report_path}")
