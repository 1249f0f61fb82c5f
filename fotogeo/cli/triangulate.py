"""``fotogeo triangulate FRAMES... [--camera C.yaml] [--eo EO.txt] [--observations OBS.csv] [--gcps GCPS] -o OUTDIR``."""
from __future__ import annotations

import math

import click

from ..options import TRIANGULATE
from .common import ConsoleProgress, options_from, quiet_option, run_tool, tool_arguments


@click.command("triangulate")
@click.argument("frames", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--camera", type=click.Path(dir_okay=False),
              help="Interior orientation YAML (pinhole, or brown with k1, k2, p1, p2, k3: a camera.yaml it wrote) "
                   "[the images' EXIF/XMP: focal length and pixel pitch, DJI calibration].")
@click.option("--eo", type=click.Path(),
              help="Approximate exterior orientation: 'name X Y Z omega phi kappa' lines (map CRS, degrees), "
                   "an OpenSfM/ODM reconstruction.json, a COLMAP model (its folder, images.txt or images.bin) or "
                   "orthority .geojson/.csv "
                   "[frames without a line: space resection against their GCPs; without --gcps: the images' GPS "
                   "and attitude].")
@click.option("--observations", type=click.Path(dir_okay=False),
              help="Tie-point measurements: a table frame, point, col, row[, sigma] (corner convention) "
                   "[match the overlapping frames].")
@click.option("--gcps", type=click.Path(dir_okay=False),
              help="Ground control: ODM/OpenSfM gcp_list.txt, or a point layer / CSV in any CRS with one row per "
                   "(point, frame) measurement: id, frame, col, row, z, optional role.")
@click.option("--reference", multiple=True, type=click.Path(dir_okay=False),
              help="Reference orthophoto(s) (repeat for tiles, or a VRT): control found automatically by matching "
                   "every frame to it, heights from --dem.")
@click.option("-o", "--output", "folder", required=True, type=click.Path(file_okay=False),
              help="Folder for exterior_orientation.txt, block.gpkg, report.json and report.html (created).")
@options_from(TRIANGULATE)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(frames, camera, eo, observations, gcps, reference, folder, overwrite, quiet, **kw):
    """Orient a block of frames together: bundle block adjustment with GCPs (aerial triangulation).

    Reports σ0, the control and check-point RMSE, the blunders culled and the interior parameters
    estimated or held fixed (and why).
    """
    from ..tools.triangulate import triangulate
    from ..tools.triangulate.outputs import accuracy_lines, dropped_lines, held_fixed_line, variance_lines
    from .dsm import result_lines
    bar = ConsoleProgress(quiet)
    try:
        rep = triangulate(list(frames), camera, eo, observations, folder, gcps=gcps, reference=list(reference) or None,
                          overwrite=overwrite,
                          progress=bar, **tool_arguments(kw, TRIANGULATE))
    finally:
        bar.close()
    for line in dropped_lines(rep):  # first: a frame left out is never a footnote
        click.echo(line)
    st = rep["statistics"]
    click.echo(f"{st['n_frames']} frames, {st['n_points']} points, {st['n_observations']} observations: "
               f"sigma0 {rep['sigma0']:.3f}, image RMS {st['image_rms_px']:.3f} px, {st['n_blunders']} blunders culled")
    if st.get("covariance_rule"):
        click.echo(f"sigma of the results: {st['covariance_rule']}")
    if quiet and st.get("focal_length_check"):  # a camera its own adjustment contradicts: said even with -q
        click.echo(f"camera: {st['focal_length_check']}")
    for line in variance_lines(rep):
        click.echo(line)
    for line in accuracy_lines(rep):
        click.echo(line)
    quality = rep.get("frame_quality") or []
    if quality:  # a σ that is not finite ranks worst and reads "undetermined", never "nan"
        worst = max(quality, key=lambda q: _rank(q.get("angle_sigma_deg")))
        click.echo(f"worst frame {worst['name']}: angle sigma {_sigma(worst.get('angle_sigma_deg'))} deg, position "
                   f"sigma {_sigma(worst.get('position_sigma_m'))} m, {worst['points']} points "
                   f"({worst['multi_ray_points']} with 3+ rays)")
    for r in rep.get("restarted_frames") or []:
        click.echo(f"re-started (attitude prior contradicted): {r['name']}: {r['reason']}")
    start = rep.get("start") or {}
    if start.get("source"):
        click.echo(f"start: {start['source']}")
    if start.get("sfm_frame"):
        click.echo(f"--eo {start['sfm_frame']}")
    registered = [r for r in start.get("registration") or [] if r["status"] == "start"]
    if registered:
        low = min(registered, key=lambda r: r["inliers"])
        click.echo(f"registered to the reference: {len(registered)} frames, fewest inliers {low['inliers']} "
                   f"({low['name']}), largest angle sigma {max(r['angle_sigma_deg'] for r in registered):.3g} deg")
    if start.get("self_calibration"):
        click.echo(f"camera: {start['self_calibration']}")
    if start.get("crs_rule"):
        click.echo(f"map CRS {rep.get('crs_name') or rep['crs']}: {start['crs_rule']}")
    if start.get("heights"):
        click.echo(f"GPS heights: {start['heights']}")
    if rep.get("resected_frames"):
        click.echo(f"resected from their GCPs (no --eo line): {', '.join(rep['resected_frames'])}")
    if rep.get("automatic_control"):
        click.echo(f"{rep['automatic_control']} control points found on the reference")
    if rep["fixed_parameters"]:
        click.echo(held_fixed_line(rep["fixed_parameters"]))
    surface = rep.get("dsm")
    if surface:
        for line in [surface["error"]] if "error" in surface else result_lines(surface):
            click.echo(line)
    click.echo(f"wrote {rep['folder']}")
    return rep


def _rank(sigma) -> float:
    """A σ for ranking frames: one that is missing or not finite (undetermined) ranks above every number."""
    return sigma if sigma is not None and math.isfinite(sigma) else math.inf


def _sigma(sigma) -> str:
    """A σ for the console: 3 significant digits, or "undetermined" when missing or not finite."""
    return f"{sigma:.3g}" if sigma is not None and math.isfinite(sigma) else "undetermined"
