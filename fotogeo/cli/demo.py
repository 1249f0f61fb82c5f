"""``fotogeo demo`` — the embedded default scene, registered, checked against its truth."""
from __future__ import annotations

import time

import click

from ..options import DEMO
from .common import ConsoleProgress, options_from, quiet_option, run_tool


@click.command("demo")
@click.option("-o", "--output", default="out/demo", show_default=True, type=click.Path(file_okay=False),
              help="Folder for the generated scene and the results.")
@options_from(DEMO)
@click.option("--overwrite", is_flag=True, help="Replace the files of an earlier demo in the folder.")
@quiet_option
@run_tool
def command(output, overwrite, quiet, **options):
    """Generate a realistic scene (fractal DEM, textured UTM orthophoto, a frame rendered through a
    known rotated and tilted camera with other radiometry and noise), register the frame to the
    orthophoto, and print the accuracy against the known truth; then render a small aerial block
    (2 strips of 4 frames over relief), triangulate it with matched tie points and 5 GCPs, and print
    its check-point errors against the truth. No download."""
    from ..tools.demo.tool import run_demo
    t0 = time.perf_counter()
    bar = ConsoleProgress(quiet)
    try:
        res = run_demo(output, progress=bar, overwrite=overwrite, **options)
    finally:
        bar.close()
    rep, truth = res["registration"].report, res["truth"]
    click.echo(f"scene: {output}/reference.tif (orthophoto, EPSG:32635, 4 m), {output}/target.tif (frame), "
               f"{output}/dem.tif")
    click.echo(f"keypoints {rep['keypoints']['target']} / {rep['keypoints']['reference']}, "
               f"matches {rep['matches']}, inliers {rep['inliers']}")
    for title, r, t in (("homography (the paper's model)", res["registration"], truth),
                        ("terrain-aware (tie points + DEM -> 3-D model)", res["terrain"], res["terrain_truth"])):
        click.echo(f"{title}: model {r.report['model']['model']}")
        for role in ("control", "check"):
            s = r.report[role]
            click.echo(f"  {role:7s} points n={s['n']:4d}  RMSE {s['rmse_m']:6.2f} m ({s['rmse_px']:.2f} px)")
        click.echo(f"  truth   grid   n={t['n']:4d}  RMSE {t['dense_rmse_m']:6.2f} m (max {t['dense_max_m']:.2f} m)"
                   f"; best possible homography {t['best_homography_rmse_m']:.2f} m")
        click.echo(f"  wrote {r.output} (+ .gpkg, .json)")
    _echo_block(output, res["block"])
    click.echo(f"done in {time.perf_counter() - t0:.1f} s")
    return res


def _echo_block(output, block):
    """The aerial-triangulation part of the demo: the block, its adjustment, its errors against the truth."""
    from ..tools.demo.block import FRAMES_DIR, OUTPUT_DIR
    rep, t = block["report"], block["truth"]
    st, m = rep["statistics"], rep["matching"]
    click.echo(f"aerial triangulation: {len(rep['frames'])} rendered frames in 2 strips (60 %/30 % overlap, "
               f"{t['gsd_m']:.2f} m ground pixels), 5 GCPs; {output}/{FRAMES_DIR}/")
    click.echo(f"  tie points: {m['tracks']} tracks matched over {len(m['pairs'])} frame pairs; "
               f"sigma0 {rep['sigma0']:.2f}, image RMS {st['image_rms_px']:.2f} px")
    click.echo(f"  check   points n={t['check_n']:4d}  RMSE {t['check_planimetric_m']:.2f} m in plan "
               f"({t['check_planimetric_gsd']:.2f} GSD), {t['check_z_m']:.2f} m in height "
               f"({t['check_z_gsd']:.2f} GSD) against the truth")
    click.echo(f"  orientations against the truth: centres RMSE {t['centre_rmse_m']:.2f} m, "
               f"angles RMSE {t['angle_rmse_deg']:.3f} deg")
    click.echo(f"  wrote {output}/{OUTPUT_DIR}/ (exterior_orientation.txt, block.gpkg, report.json, report.html)")
