"""``fotogeo match REFERENCE TARGET -o TIE_POINTS.gpkg`` — detect and match features only."""
from __future__ import annotations

import click

from ..options import MATCH
from .common import ConsoleProgress, options_from, quiet_option, run_tool


@click.command("match")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="GeoPackage (layer tie_points).")
@options_from(MATCH)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(reference, target, output, overwrite, quiet, **options):
    """Tie points between TARGET and REFERENCE (PCA fusion, SURF, ratio test), with an inlier flag."""
    from ..tools.register.match import match_images
    bar = ConsoleProgress(quiet)
    try:
        r = match_images(reference, target, output, overwrite=overwrite, progress=bar, **options)
    finally:
        bar.close()
    click.echo(f"keypoints {r['keypoints']['target']} / {r['keypoints']['reference']}, matches {r['matches']}, "
               f"homography inliers {r['inliers']}; wrote {r['output']}")
    return r
