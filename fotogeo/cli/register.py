"""``fotogeo.tools.register REFERENCE TARGET -o OUT.tif``."""
from __future__ import annotations

import click

from ..features.detect import DETECTORS
from ..image.contrast import CONTRASTS
from ..io.warp import RESAMPLING
from ..orientation.terrain import TERRAIN_MODELS
from ..tools.register import PLANAR_MODELS, RegisterOptions, register
from .common import ConsoleProgress, run_tool

_D = RegisterOptions()


@click.command("register")
@click.argument("reference", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Output GeoTIFF.")
@click.option("--vectors", type=click.Path(dir_okay=False), help="GeoPackage of tie points and error vectors [OUT.gpkg].")
@click.option("--report", type=click.Path(dir_okay=False), help="JSON report [OUT.json].")
@click.option("--crs", "dst_crs", default=_D.dst_crs, show_default=True,
              help="Output CRS: 'auto' (UTM zone of the reference centre), EPSG:xxxx, WKT or PROJ.")
@click.option("--resolution", type=float, help="Output pixel size in output CRS units [the reference's].")
@click.option("--resampling", type=click.Choice(list(RESAMPLING)), default=_D.resampling, show_default=True)
@click.option("--model", type=click.Choice(PLANAR_MODELS + TERRAIN_MODELS),
              help="projective (default), affine, similarity; with --dem: auto (default), dlt, rfm, "
                   "rfm-common, rfm-poly, collinearity.")
@click.option("--dem", type=click.Path(dir_okay=False),
              help="DEM: terrain-aware registration with a 3-D model and an orthorectified output.")
@click.option("--camera", type=click.Path(dir_okay=False),
              help="Interior orientation YAML of the target's camera (for --model collinearity).")
@click.option("--detector", type=click.Choice(DETECTORS), default=_D.detector, show_default=True)
@click.option("--max-keypoints", type=int, default=_D.max_keypoints, show_default=True,
              help="Per image, spatially balanced.")
@click.option("--hessian-threshold", type=float, help="SURF detector threshold (on 0..255 fused images).")
@click.option("--ratio", type=float, default=_D.ratio, show_default=True, help="Nearest/second-nearest ratio test.")
@click.option("--mutual/--no-mutual", default=_D.mutual, show_default=True, help="Keep only mutual nearest neighbours.")
@click.option("--ransac-threshold", type=float, default=_D.ransac_threshold, show_default=True,
              help="RANSAC inlier threshold in reference pixels.")
@click.option("--check-fraction", type=float, default=_D.check_fraction, show_default=True,
              help="Fraction of inliers held out as check points.")
@click.option("--seed", type=int, default=_D.seed, show_default=True)
@click.option("--max-match-pixels", type=int, default=_D.max_match_pixels, show_default=True,
              help="Images larger than this are decimated for matching (not for resampling).")
@click.option("--exaggeration", type=float, default=_D.exaggeration, show_default=True,
              help="Scale factor drawing the error vectors.")
@click.option("--contrast", type=click.Choice(CONTRASTS), default=_D.contrast, show_default=True,
              help="Contrast of the fused images for matching (adaptive = equalize + CLAHE).")
@click.option("--reference-nodata", type=float, help="Nodata value of the reference (overrides the file's).")
@click.option("--target-nodata", type=float, help="Nodata value of the target (overrides the file's).")
@click.option("--refine", type=click.Choice(["none", "lsm"]), default=_D.refine, show_default=True,
              help="Refine tie points by least-squares matching before the fit.")
@click.option("--overwrite", is_flag=True, help="Replace existing outputs.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
@run_tool
def command(reference, target, output, vectors, report, overwrite, quiet, dem, camera, **opts):
    """Register TARGET (any image of the area) to the georeferenced REFERENCE orthophoto.

    PCA band fusion, SURF keypoints, SSD ratio-test matching, RANSAC + robust homography,
    check points held out; writes OUT.tif (nearest neighbour by default), OUT.gpkg (layers
    tie_points, error_vectors) and OUT.json (report).
    """
    bar = ConsoleProgress(quiet)
    try:
        r = register(reference, target, output, vectors=vectors, report=report, overwrite=overwrite,
                     options=RegisterOptions(**opts), progress=bar, dem=dem, camera=camera)
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
