"""``fotogeo interior SCAN... --camera-report CAL.yaml -o OUT`` — interior orientation of scanned film frames."""
from __future__ import annotations

import click

from ..options.interior import INTERIOR
from .common import ConsoleProgress, options_from, quiet_option, run_tool, tool_arguments, warn


@click.command("interior")
@click.argument("scans", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--camera-report", required=True, type=click.Path(dir_okay=False),
              help="Calibration report YAML: focal_mm, principal_point_mm, fiducials_mm {id: [x, y]}, mark.")
@click.option("-o", "--output", required=True, type=click.Path(),
              help="JSON for one scan; a folder for several (one <scan>.json each).")
@options_from(INTERIOR)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(scans, camera_report, output, overwrite, quiet, **kw):
    """Find the fiducial marks of each scanned film frame and fit its pixel -> photo-coordinate transform."""
    from ..tools.interior.tool import interior
    bar = ConsoleProgress(quiet)
    try:
        records = interior(list(scans), camera_report, output, overwrite=overwrite, progress=bar,
                           **tool_arguments(kw, INTERIOR))
    finally:
        bar.close()
    for r in records:
        click.echo(f"{r['scan']}: {len(r['fiducials'])} marks, {r['model']} RMS {r['rms_px']:.3f} px, max "
                   f"{r['max_residual_px']:.3f} px, scan pixel {r['scan_pixel_um']:.3f} µm, rotation "
                   f"{r['rotation_deg']:.2f}°")
        for w in r["warnings"]:
            warn(w)
    return records
