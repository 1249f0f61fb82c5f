"""The registration report: every number of :func:`fotogeo.register` with its units, a
``notes`` entry explaining each, and the summary lines the command line and QGIS print."""
from __future__ import annotations

import platform

import numpy as np

from ... import __version__
from ...crs import crs_text
from ...models.stats import residual_stats


def _versions() -> dict:
    import cv2
    import pyproj
    import rasterio
    return {"fotogeo": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "opencv": cv2.__version__, "rasterio": rasterio.__version__, "gdal": rasterio.__gdal_version__,
            "pyproj": pyproj.__version__}


def circular_error(resid, p: float) -> float:
    """CE``p``: the radius holding ``p`` percent of the residual vectors ``(N, 2)`` — the empirical
    ``p``-th percentile of their lengths (linear interpolation between order statistics).

    >>> circular_error([[3.0, 4.0], [0.0, 1.0], [0.0, 2.0]], 50)
    2.0
    """
    r = np.asarray(resid, float).reshape(-1, 2)
    return float(np.percentile(np.hypot(r[:, 0], r[:, 1]), p))


def _stats(resid: np.ndarray, px: float) -> dict:
    """Residual statistics of one role in output CRS units (m) and reference pixels (px): RMSE
    beside the radial CE90 / CE95."""
    s = residual_stats(resid)
    if s["n"] == 0:
        return s
    ce90, ce95 = circular_error(resid, 90), circular_error(resid, 95)
    return {"n": s["n"], "rmse_m": s["rms_xy"], "rmse_px": s["rms_xy"] / px, "ce90_m": ce90, "ce90_px": ce90 / px,
            "ce95_m": ce95, "ce95_px": ce95 / px, "rms_x_m": s["rms_x"], "rms_y_m": s["rms_y"],
            "median_m": s["median"], "max_m": s["max"]}


def precision(rep: dict, sigma_px) -> dict:
    """The report's ``precision``: the tie points' own precision (median LSM σ of the check points,
    when refined) apart from the model's residuals at the check points (RMSE, CE90, CE95), in
    reference px and metres; ``model_rmse``: the check RMSE with the tie points' own scatter taken
    out (``sqrt(max(0, RMSE² − mean σ²))``), an estimate of the model's error alone."""
    px = rep["reference_pixel_size"]
    role = "check" if rep["check"].get("n") else "control"
    s = rep[role]
    out = {"residuals_of": role}
    if s.get("n"):
        out.update({f"{role}_{k}": s[k] for k in ("rmse_px", "rmse_m", "ce90_px", "ce90_m", "ce95_px", "ce95_m")})
    sig = None if sigma_px is None else np.asarray(sigma_px, float)
    if sig is not None and np.isfinite(sig).any():
        sig = sig[np.isfinite(sig)]
        med = float(np.median(sig))
        out.update(tie_point_sigma_px=med, tie_point_sigma_m=med * px)
        if s.get("n"):
            model = float(np.sqrt(max(0.0, s["rmse_px"] ** 2 - float(np.mean(sig ** 2)))))
            out.update(model_rmse_px=model, model_rmse_m=model * px)
    return out


def build_report(opts, ref, tgt, crs, ref_px, res, counts, gf):
    from dataclasses import asdict
    return {
        "fotogeo": "register",
        "reference": str(ref.path), "target": str(tgt.path),
        "options": asdict(opts),
        "output_crs": crs_text(crs), "output_crs_wkt": crs.to_wkt(),
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
                 "measured by SURF/SIFT and least-squares matching, not surveyed), so the check RMSE is an upper "
                 "bound of the model's error",
        "radial_error": "ce90_m / ce95_m (and _px): radial circular error, the radius within which 90 % / 95 % of the "
                        "residual vectors of that role lie (empirical percentiles of their lengths), beside the RMSE",
        "precision": "the achieved precision: the tie points' own precision (tie_point_sigma: median radial σ of "
                     "their least-squares matching, reference px and metres) apart from the model's residuals at the "
                     "check points (RMSE, CE90, CE95); model_rmse: the check RMSE with the tie points' σ taken out, "
                     "an estimate of the model's own error",
        "refine": "how the tie points were refined before the fit: lsm (least-squares matching) or none; "
                  "options.refine auto = lsm",
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
    if "lsm" in rep:
        notes["lsm"] = ("least-squares matching of the tie points: the reference's first component around each "
                        "keypoint is matched into the target (affine geometry and radiometry, bicubic); status counts "
                        "every match (refined, or why not); the fit uses the converged points only ('fit_uses'), "
                        "weighted by the spatial balance / (σ² + s0²) (fit_weights); at most 'budget' consistent "
                        "matches are refined, spread over the target, topped up with 'texture_windows' (windows of "
                        "strong texture at the homography's prediction, counted in 'of') when the matches are fewer, "
                        "used ('texture_windows_used', the converged ones) only when the matches alone make a fit that "
                        "is not weak; "
                        "median_sigma_px: radial σ in reference pixels")
    if terrain:
        notes["terrain"] = ("check_rmse_target_px / control_rmse_target_px: the same residuals measured in the "
                            "target image's pixels (the 3-D model maps ground to target pixels)")
    return notes


#: a 2-D registration leaving more than this at its check points (reference px) hints at relief: use the DEM
DEM_HINT_PX = 3.0


def hint_lines(rep: dict) -> list[str]:
    """Advice the numbers call for (lines starting with "hint:"): a 2-D fit many pixels off suggests the DEM."""
    check = rep.get("check", {})
    if "terrain" in rep or not check.get("n") or check["rmse_px"] <= DEM_HINT_PX:
        return []
    return [f"hint: the 2-D model leaves {check['rmse_px']:.1f} reference px ({check['rmse_m']:.3g} m) RMSE at the "
            f"check points: over relief no 2-D model fits a frame; give --dem"]


def _inliers_text(rep: dict) -> str:
    r = rep.get("ransac")
    if not r or "threshold_m" not in r:
        return f"inliers {rep['inliers']}"
    px = r["threshold_m"] / rep["reference_pixel_size"]
    return (f"inliers {rep['inliers']} ({r['inliers']} within RANSAC's {px:g} reference px, "
            f"{rep['inliers']} kept by the robust fit)")


def summary_lines(rep: dict) -> list[str]:
    """The lines the command line prints after a registration (units named), then :func:`hint_lines`."""
    lines = [f"keypoints {rep['keypoints']['target']} / {rep['keypoints']['reference']}, "
             f"matches {rep['matches']}, {_inliers_text(rep)}"]
    if "area_based" in rep:
        a = rep["area_based"]
        c = a.get("compared")
        lead = "feature matching failed" if c is None else (
            f"the feature fit was {c['feature_fit_rmse_px']:.2f} px off the windows' check points, their own fit "
            f"{c['windows_fit_rmse_px']:.2f} px")
        lines[0] = (f"{lead} ({a['why']}); tie points from {a['windows']['reliable']} reliable "
                    f"windows of {a['windows']['total']} (area-based, {a['window']} px windows every "
                    f"{a['grid_spacing']} px), inliers {rep['inliers']}")
    if "windows_check" in rep:
        c = rep["windows_check"]
        lines.append(f"the feature fit was checked by area-based windows and kept: {c['feature_fit_rmse_px']:.2f} "
                     f"px off their {c['at']}, their own fit {c['windows_fit_rmse_px']:.2f} px")
    if rep.get("lsm", {}).get("tried"):
        lsm = rep["lsm"]
        sig = lsm.get("median_sigma_px")
        lines.append(f"tie points refined by LSM: {lsm['refined']} of {lsm['tried']} tried ({lsm['of']} matches)"
                     + (f", median σ {sig:.3f} reference px ({sig * rep['reference_pixel_size']:.3g} m)"
                        if sig else ""))
    for role in ("control", "check"):
        s = rep[role]
        if s.get("n"):
            lines.append(f"{role:8s} n={s['n']:5d}  RMSE {s['rmse_m']:.3f} m  ({s['rmse_px']:.2f} reference px)"
                         f"  CE90 {s['ce90_m']:.3f} m ({s['ce90_px']:.2f} px)  CE95 {s['ce95_m']:.3f} m "
                         f"({s['ce95_px']:.2f} px)")
    p = rep.get("precision", {})
    if "model_rmse_px" in p:
        lines.append(f"precision: tie points σ {p['tie_point_sigma_px']:.3f} px ({p['tie_point_sigma_m']:.3g} m); "
                     f"model {p['model_rmse_px']:.3f} px ({p['model_rmse_m']:.3g} m) RMSE at the {p['residuals_of']} "
                     f"points, tie-point σ taken out")
    if "terrain" in rep:
        t = rep["terrain"]
        lines.append(f"3-D model {t['chosen']} ({t['chosen_because']}); check RMSE {t['check_rmse_target_px']:.2f} "
                     f"target px; {t['tie_points_without_height']} tie points without DEM height skipped")
    if "local" in rep:
        loc, w = rep["local"], rep["local"]["windows"]
        lines.append(f"local field: {w['reliable']} reliable windows of {w['total']}; window shifts before RMS "
                     f"{loc['before'].get('rms', float('nan')):.3f} px, after {loc['after'].get('rms', float('nan')):.3f} "
                     f"px (CE90 {loc['after'].get('ce90', float('nan')):.3f} px); field {loc.get('field')}")
    g = rep["output_grid"]
    lines.append(f"output CRS {rep.get('output_crs_name', rep['output_crs'])} ({rep['output_crs_rule']}); grid {g['width']}x{g['height']} of "
                 f"{g['resolution']:g}, {'aligned to' if g.get('aligned_to_reference') else 'not aligned to'} "
                 f"the reference's pixels")
    if "exaggeration" in rep:
        lines.append(f"error vectors {rep['exaggeration']['legend']}")
    return lines + hint_lines(rep)
