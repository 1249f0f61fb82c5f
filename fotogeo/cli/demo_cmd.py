"""``fotogeo demo`` — the embedded default scene, registered, checked against its truth."""
from __future__ import annotations

import time

import click

from .common import ConsoleProgress, run_tool


@click.command("demo")
@click.option("-o", "--output", default="out/demo", show_default=True, type=click.Path(file_okay=False),
              help="Folder for the generated scene and the results.")
@click.option("--seed", type=int, default=7, show_default=True, help="Seed of the generated scene.")
@click.option("--detector", type=click.Choice(["surf", "sift"]), default="surf", show_default=True)
@click.option("-q", "--quiet", is_flag=True)
@run_tool
def command(output, seed, detector, quiet):
    """Generate a realistic scene (fractal DEM, textured UTM orthophoto, a frame rendered through a
    known rotated and tilted camera with other radiometry and noise), register the frame to the
    orthophoto, and print the accuracy against the known truth. No download."""
    from ..demo import run_demo
    t0 = time.perf_counter()
    bar = ConsoleProgress(quiet)
    try:
        res = run_demo(output, seed=seed, detector=detector, progress=bar)
    finally:
        bar.close()
    rep, truth = res["registration"].report, res["truth"]
    click.echo(f"scene: {output}/reference.tif (orthophoto, EPSG:32635, 4 m), {output}/target.tif (frame)")
    click.echo(f"keypoints {rep['keypoints']['target']} / {rep['keypoints']['reference']}, "
               f"matches {rep['matches']}, inliers {rep['inliers']}")
    for role in ("control", "check"):
        s = rep[role]
        click.echo(f"{role:8s} points n={s['n']:4d}  RMSE {s['rmse_m']:6.2f} m ({s['rmse_px']:.2f} px)")
    click.echo(f"truth    grid   n={truth['n']:4d}  RMSE {truth['dense_rmse_m']:6.2f} m "
               f"(max {truth['dense_max_m']:.2f} m); best possible homography {truth['best_homography_rmse_m']:.2f} m")
    click.echo(f"wrote {res['registration'].output} (+ .gpkg, .json) in {time.perf_counter() - t0:.1f} s")
