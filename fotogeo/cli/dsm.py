"""``fotogeo dsm IMAGES... [--camera C.yaml --eo EO | --orientation OUT/ | --rpc] -o DSM.tif`` — a surface
model from oriented images."""
from __future__ import annotations

import click

from ..options.dsm import DSM
from .common import ConsoleProgress, options_from, quiet_option, run_tool, tool_arguments


@click.command("dsm")
@click.argument("images", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="The DSM (GeoTIFF, COG layout: heights, pair count, spread[, filled]).")
@options_from(DSM)
@click.option("--point-cloud", type=click.Path(dir_okay=False), default=None,
              help="Also write every triangulated point (LAS 1.4 .las, or .laz), coloured from the images.")
@click.option("--report", type=click.Path(dir_okay=False), default=None,
              help="JSON report: pairs kept and left out and why, disparity ranges, disparities searched and the "
                   "strips matched coarse to fine, match density, epipolar residuals and ray miss distances, "
                   "completeness, timings; written also when the run is refused (status refused, the error, the "
                   "pairs tried and why).")
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(images, output, point_cloud, report, overwrite, quiet, **kw):
    """Match overlapping oriented IMAGES pair by pair into a digital surface model.

    Frame cameras: --camera and --eo (the formats ortho reads) or triangulate's output folder (--orientation).
    Pairs are chosen from the footprints, overlap and base-to-height ratio (or --pairs); each is rectified with
    the lens distortion removed, matched by semi-global matching with left-right checks (frames: coarse to fine
    where a strip's disparity range is wide enough for that to halve the search), triangulated and fused onto one
    north-up grid (median of the pairs). Holes stay nodata unless --fill.
    """
    from ..tools.dsm import dsm
    # fewer than two IMAGES: refused by the tool, which writes --report of the refusal (fotogeo.tools.common.refusal)
    bar = ConsoleProgress(quiet)
    try:
        rep = dsm(list(images), output, point_cloud=point_cloud, report=report, overwrite=overwrite, progress=bar,
                  **tool_arguments(kw, DSM))
    finally:
        bar.close()
    click.echo(f"map CRS {rep['crs']}: {rep['crs_rule']}; heights: {'; '.join(rep['notes'])}")
    for line in result_lines(rep):
        click.echo(line)


def result_lines(rep: dict) -> list[str]:
    """The console's lines of a DSM report (:func:`fotogeo.tools.dsm.dsm`): its pairs (every one up to 12, else
    the kept ones), the DSM's grid and cells with a height (matched, and filled with --fill), the point cloud."""
    lines = []
    for p in rep["pairs"]:
        if p["kept"] or len(rep["pairs"]) <= 12:
            what = (f"{100 * p.get('match_density', 0):.0f} % matched, {p.get('points', 0)} points" if p["kept"]
                    else f"left out: {p['reason']}")
            points = (f"; at its points {p['ray_angle_median_deg']:.1f} median, "
                      f"{100 * p['ray_angle_under_5deg']:.0f} % under 5" if "ray_angle_median_deg" in p else "")
            lines.append(f"pair {p['images'][0]}-{p['images'][1]}: rays meet at {p['convergence_deg']:.0f} degrees "
                         f"(B/H {p['base_to_height']:.2f}{points}), {what}")
    g = rep["grid"]
    filled = f", {rep['filled_cells']} cells filled (--fill)" if "fill_max_distance_cells" in rep else ""
    lines.append(f"DSM {g['width']}x{g['height']} cells at {g['resolution']:g}, {100 * rep['completeness']:.1f} % of "
                 f"the overlap with a matched height{filled} -> {rep['outputs']['dsm']}")
    if "point_cloud" in rep["outputs"]:
        lines.append(f"{rep['points_written']} points -> {rep['outputs']['point_cloud']}")
    return lines
