"""The registration report: every number of :func:`fotogeo.register` with its units, a
``notes`` entry explaining each, and the summary lines the command line and QGIS print."""
from __future__ import annotations

import platform

import numpy as np

from .. import __version__
from ..models.stats import residual_stats


def _versions() -> dict:
    import cv2
    import pyproj
    import rasterio
    return {"fotogeo": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "opencv": cv2.__version__, "rasterio": rasterio.__version__, "gdal": rasterio.__gdal_version__,
            "pyproj": pyproj.__version__}


def _stats(resid: np.ndarray, px: float) -> dict:
    """Residual statistics of one role in output CRS units (m) and reference pixels (px)."""
    s = residual_stats(resid)
    if s["n"] == 0:
        return s
    return {"n": s["n"], "rmse_m": s["rms_xy"], "rmse_px": s["rms_xy"] / px, "rms_x_m": s["rms_x"],
            "rms_y_m": s["rms_y"], "median_m": s["median"], "max_m": s["max"]}


def build_report(opts, ref, tgt, crs, ref_px, res, counts, gf):
    from dataclasses import asdict
    return {
        "fotogeo": "register",
        "reference": str(ref.path), "target": str(tgt.path),
        "options": asdict(opts),
        "output_crs": crs.to_string(), "output_crs_wkt": crs.to_wkt(),
        "output_grid": {"width": gf.width, "height": gf.height, "resolution": res,
                        "transform": list(gf.transform)[:6]},
        "reference_pixel_size": ref_px,
        **counts,
        "inliers": int(gf.inliers.sum()),
        "model": gf.model.to_dict(),
        **gf.details,
        "control": _stats(gf.residual_m[gf.role == "control"], ref_px),
        "check": _stats(gf.residual_m[gf.role == "check"], ref_px),
        "units": "metres in the output CRS (px = reference pixels)",
        "versions": _versions(),
    }


def notes(rep: dict, terrain: bool) -> dict:
    """What each number of the report means (the report's ``notes``)."""
    px = "reference pixels: the reference orthophoto's pixel size at its centre, measured in the output CRS"
    notes = {
        "control": "residuals at the tie points the model was fitted to (control points): how well the model "
                   "fits, an optimistic measure of accuracy; in metres of the output CRS and in " + px,
        "check": "residuals at tie points held out of the fit (check points, spatially spread): the accuracy "
                 "estimate. They include the matching noise of the tie points themselves (their positions are "
                 "measured by SURF/SIFT, not surveyed), so the check RMSE is an upper bound of the model's error",
        "residual": "model position of the target pixel on the map minus the reference's map position of the "
                    "same feature (dx, dy), in the output CRS",
        "output_crs": f"{rep['output_crs_rule']} (options.dst_crs = {rep['options']['dst_crs']!r})",
        "output_grid": ("aligned to the reference's pixel grid: origin and pixel size whole numbers of reference "
                        "pixels" if rep["output_grid"].get("aligned_to_reference") else
                        "not aligned to the reference's pixels (another CRS, a rotated reference or a resolution "
                        "that is not a whole number of reference pixels): edges on multiples of the resolution"),
        "exaggeration": f"error vectors drawn {rep['exaggeration']['legend']} ({rep['exaggeration']['chosen']})",
        "inliers": "matches kept by RANSAC and the robust refit (control + check points)",
    }
    if terrain:
        notes["terrain"] = ("check_rmse_target_px / control_rmse_target_px: the same residuals measured in the "
                            "target image's pixels (the 3-D model maps ground to target pixels)")
    return notes


def summary_lines(rep: dict) -> list[str]:
    """The lines the command line prints after a registration (units named)."""
    lines = [f"keypoints {rep['keypoints']['target']} / {rep['keypoints']['reference']}, "
             f"matches {rep['matches']}, inliers {rep['inliers']}"]
    for role in ("control", "check"):
        s = rep[role]
        if s.get("n"):
            lines.append(f"{role:8s} n={s['n']:5d}  RMSE {s['rmse_m']:.3f} m  ({s['rmse_px']:.2f} reference px)")
    if "terrain" in rep:
        t = rep["terrain"]
        lines.append(f"3-D model {t['chosen']} ({t['chosen_because']}); check RMSE {t['check_rmse_target_px']:.2f} "
                     f"target px; {t['tie_points_without_height']} tie points without DEM height skipped")
    g = rep["output_grid"]
    lines.append(f"output CRS {rep.get('output_crs_name', rep['output_crs'])} ({rep['output_crs_rule']}); grid {g['width']}x{g['height']} of "
                 f"{g['resolution']:g}, {'aligned to' if g.get('aligned_to_reference') else 'not aligned to'} "
                 f"the reference's pixels")
    if "exaggeration" in rep:
        lines.append(f"error vectors {rep['exaggeration']['legend']}")
    return lines
