"""``fotogeo match REFERENCE TARGET -o TIE_POINTS.gpkg`` — detect and match features only."""
from __future__ import annotations

import click

from ..features.detect import DETECTORS
from ..tools.register import RegisterOptions
from .common import ConsoleProgress, run_tool

_D = RegisterOptions()


@click.command("match")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="GeoPackage (layer tie_points).")
@click.option("--detector", type=click.Choice(DETECTORS), default=_D.detector, show_default=True)
@click.option("--max-keypoints", type=int, default=_D.max_keypoints, show_default=True)
@click.option("--ratio", type=float, default=_D.ratio, show_default=True)
@click.option("--ransac-threshold", type=float, default=_D.ransac_threshold, show_default=True,
              help="Pixels, for the inlier flag.")
@click.option("--overwrite", is_flag=True)
@click.option("-q", "--quiet", is_flag=True)
@run_tool
def command(reference, target, output, overwrite, quiet, **opts):
    """Tie points between TARGET and REFERENCE (PCA fusion, SURF, ratio test), with an inlier flag."""
    from ..tools.match import match_images
    bar = ConsoleProgress(quiet)
    try:
        r = match_images(reference, target, output, overwrite=overwrite, progress=bar, **opts)
    finally:
        bar.close()
    click.echo(f"keypoints {r['keypoints']['target']} / {r['keypoints']['reference']}, matches {r['matches']}, "
               f"homography inliers {r['inliers']}; wrote {r['output']}")
