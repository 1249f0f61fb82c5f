"""What ``fotogeo triangulate`` writes: the GeoPackage layers, the reports and the orthorectified frames,
as one set (:class:`fotogeo.io.raster.AtomicOutputs`: nothing on an error or a cancel)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...crs import crs_text
from ...orientation.bundle_variance import dominant_group
from .statistics import LARGEST, adjusted_pixels, matching_summary, point_sigma_by_role, residuals_by_size, stage_timings

FILES = ("exterior_orientation.txt", "camera.yaml", "block.gpkg", "report.json", "report.html")
CAMERA_FILE = FILES[1]  # the camera the adjustment used: adjusted (self-calibration), given, or from EXIF/XMP
ORTHO_SUFFIX = "_ortho.tif"  # <frame>_ortho.tif with orthorectify
MOSAIC_FILES = ("mosaic.tif", "mosaic.gpkg")  # with mosaic: the mosaic and its seamlines (fotogeo mosaic's layers)


def output_paths(folder, *, names, orthorectify, mosaic=False, uncertainty=False) -> dict:
    """The final paths: ``eo``, ``camera``, ``gpkg``, ``json``, ``html``,
    ``ortho:<frame>`` (orthorectify or mosaic), ``sigma:<frame>`` (uncertainty) and ``mosaic``, ``seamlines``
    (mosaic)."""
    from .ortho import sigma_paths
    folder = Path(folder)
    paths = dict(zip(("eo", "camera", "gpkg", "json", "html"), (folder / f for f in FILES)))
    if orthorectify or mosaic:
        paths.update({f"ortho:{n}": folder / f"{n}{ORTHO_SUFFIX}" for n in names})
    paths.update(sigma_paths({k: p for k, p in paths.items() if k.startswith("ortho:")}, uncertainty))
    if mosaic:
        paths.update(zip(("mosaic", "seamlines"), (folder / f for f in MOSAIC_FILES)))
    return paths


def adjusted_only(paths: dict, frames) -> dict:
    """``paths`` without the per-frame outputs (``ortho:``, ``sigma:``) of frames not in ``frames``: a frame dropped
    from the block (``undetermined="drop"``) gets no orthophoto.

    >>> sorted(adjusted_only({"eo": "eo.txt", "ortho:a": "a_ortho.tif", "ortho:b": "b_ortho.tif",
    ...                       "sigma:b": "b_ortho_sigma.tif"}, ("a",)))
    ['eo', 'ortho:a']
    """
    return {k: p for k, p in paths.items() if not k.startswith(("ortho:", "sigma:")) or k.split(":", 1)[1] in frames}


def write_outputs(paths: dict, result, block, frames, rep: dict, *, dem, resolution, resampling, overwrite,
                  progress, dem_sigma=None, surface=None, compress: str = "deflate") -> None:
    """Write every output of :func:`output_paths` (the orthophoto grids checked before any file; the rasters
    compressed with ``compress``, :mod:`fotogeo.io.compression`) as one set; then
    the mosaic of the orthophotos (:func:`mosaic_outputs`) and the surface model (``surface(frames, progress, rule)``,
    :func:`fotogeo.tools.triangulate.surface.block_dsm`), whose failures leave that set in place. The seconds
    spent go into ``rep["timings_s"]`` (``outputs``, ``mosaic``, ``dsm``)."""
    import time
    t0 = time.perf_counter()
    from ...io.block import write_exterior_orientation, write_interior_orientation
    from ...io.raster import AtomicOutputs
    from ...io.vector import write_layers
    from .ortho import footprints, frame_images, orthorectify, sigma_of_dem, write_sigma_rasters
    crs = block.crs
    paths = adjusted_only(paths, block.frames)
    ortho = {k.split(":", 1)[1]: p for k, p in paths.items() if k.startswith("ortho:")}
    images = frame_images(result, block, frames) if ortho else []
    heights, grids = _terrain_and_grids(ortho, images, result, block, dem, (resolution, compress), rep,
                                        "mosaic" in paths)
    sigma_h = sigma_of_dem(paths, heights, dem_sigma, crs)
    feet = footprints(result, block, heights, crs)
    layers = {**block_layers(result, block), "footprints": feet}
    with AtomicOutputs(overwrite) as out:
        write_exterior_orientation(out.temp(paths["eo"]), block.frames, result.eo,
                                   f"fotogeo triangulate: adjusted exterior orientation, CRS {crs_text(crs)}\n"
                                   f"name X Y Z omega phi kappa (metres, PATB degrees)")
        write_interior_orientation(out.temp(paths["camera"]), "adjusted" if result.interior_sigma else "fixed",
                                   result.camera, result.distortion)
        if ortho:
            temps = {n: out.temp(p) for n, p in ortho.items() if not isinstance(grids.get(n), str)}
            rep["orthorectified"] = orthorectify(temps, grids, images, heights, crs, resampling,
                                                 progress.stage(0.0, 0.9, "orthorectifying"), compress)
            if sigma_h is not None:
                write_sigma_rasters(out, paths, grids, rep["orthorectified"], rep, heights, crs, images, sigma_h,
                                    compress)
        write_layers(out.temp(paths["gpkg"]), layers, crs)
        _timing(rep, "outputs", time.perf_counter() - t0)
        _write_reports(out, paths, rep, result, block, feet)
        out.commit()
    if "mosaic" in paths:
        t0 = time.perf_counter()
        rep["mosaic"] = mosaic_outputs(paths, rep.get("orthorectified") or {}, overwrite, progress.stage(0.9, 1.0,
                                                                                                      "mosaic"),
                                       compress)
        _timing(rep, "mosaic", time.perf_counter() - t0)
    if surface is not None:
        t0 = time.perf_counter()
        rule = (rep.get("start") or {}).get("crs_rule")
        rep["dsm"] = surface(frames, progress.stage(0.9, 1.0, "surface model"), rule)
        _timing(rep, "dsm", time.perf_counter() - t0)
    if "mosaic" in paths or surface is not None:
        with AtomicOutputs(True) as out:  # the reports again, with the mosaic's and the surface model's outcome
            _write_reports(out, paths, rep, result, block, feet)
            out.commit()


def _terrain_and_grids(ortho: dict, images, result, block, dem, grid: tuple, rep: dict, mosaic: bool) -> tuple:
    """The heights (:func:`~fotogeo.tools.triangulate.ortho.terrain`) and the grids
    (:func:`~fotogeo.tools.triangulate.ortho.ortho_grids`; ``grid``: their ``(resolution, compress)``, the latter
    for the free-space check) of the orthophotos ``ortho`` of the frames ``images``,
    the DEM's holes warned of as ``fotogeo ortho`` does. A ``mosaic`` needs one pixel lattice: without
    ``resolution``, the frames' common one; it goes into ``rep["mosaic_resolution_m"]``."""
    from ..ortho.tool import warn_dem_holes
    from .ortho import common_resolution, ortho_grids, terrain
    resolution, compress = grid
    heights = terrain(dem, block.crs, result, images)
    if not ortho:
        return heights, {}
    warn_dem_holes(dem, heights)
    points = result.point_xyz[np.isfinite(result.point_xyz).all(axis=1)]
    ground = points if len(points) else np.zeros((1, 3))
    if mosaic:
        if resolution is None:
            resolution = common_resolution(ortho_grids(ortho, images, heights, block.crs, dem, ground, None,
                                                       quiet=True))
        rep["mosaic_resolution_m"] = resolution
    return heights, ortho_grids(ortho, images, heights, block.crs, dem, ground, resolution, compress=compress)


def _write_reports(out, paths, rep, result, block, feet) -> None:
    from ...io.report import write_json
    from .report import write_html
    write_json(out.temp(paths["json"]), rep)
    write_html(out.temp(paths["html"]), rep, result, block, feet)


def _timing(rep: dict, stage: str, seconds: float) -> None:
    """``rep["timings_s"][stage]`` set and the total recomputed (a report with stage timings only)."""
    timings = rep.get("timings_s")
    if isinstance(timings, dict) and "adjustment_steps" in timings:
        timings[stage] = seconds
        timings.update(stage_timings(timings, timings["adjustment_steps"]))


def mosaic_outputs(paths: dict, orthorectified: dict, overwrite: bool, progress, compress: str = "deflate") -> dict:
    """``fotogeo mosaic`` (:func:`fotogeo.tools.ortho.mosaic.mosaic`) of the orthophotos written into
    ``paths["mosaic"]`` (compressed with ``compress``),
    seamlines into ``paths["seamlines"]``; its report, or ``{"error": ...}`` (warned) when it fails or fewer than
    two frames were orthorectified — the adjustment's outputs are written already and stay."""
    import warnings

    from ...errors import Cancelled, FotogeoError, FotogeoWarning
    from ..ortho.mosaic import mosaic
    done = [paths[f"ortho:{n}"] for n, r in orthorectified.items() if "error" not in r]
    try:
        if len(done) < 2:
            raise FotogeoError(f"{len(done)} frame(s) orthorectified; a mosaic needs two")
        return mosaic(done, paths["mosaic"], seamlines=paths["seamlines"], overwrite=overwrite, progress=progress,
                      compress=compress)
    except Cancelled:
        raise
    except FotogeoError as exc:
        message = f"no mosaic: {exc}; the orientations and orthophotos are written (mosaic them with fotogeo mosaic)"
        warnings.warn(message, FotogeoWarning, stacklevel=2)
        return {"error": message}


def _points3d(xyz):
    import shapely
    return shapely.points(np.asarray(xyz, dtype=np.float64))


def block_layers(result, block) -> dict:
    """``tie_points``, ``control``, ``frames`` and ``residuals`` layers (module docstring of
    :mod:`fotogeo.tools.triangulate`)."""
    ids = np.array(block.point_ids, dtype=object)
    live = np.isfinite(result.point_xyz).all(axis=1)
    tie = live & (result.roles == "tie")
    known = live & (result.roles != "tie")
    d = result.point_xyz[known] - block.point_xyz[known]
    eo = np.array([[e.X, e.Y, e.Z, e.omega, e.phi, e.kappa] for e in result.eo])
    o_live = live[block.obs_point]
    adjusted = adjusted_pixels(result, block)
    n_used = np.bincount(block.obs_frame[result.status == "used"], minlength=len(block.frames))
    return {
        "tie_points": {"geometry": _points3d(result.point_xyz[tie]), "id": ids[tie].astype(str),
                       "rays": result.point_rays[tie], "sigma_x": result.point_sigma[tie, 0],
                       "sigma_y": result.point_sigma[tie, 1], "sigma_z": result.point_sigma[tie, 2]},
        "control": {"geometry": _points3d(result.point_xyz[known]), "id": ids[known].astype(str),
                    "role": result.roles[known], "rays": result.point_rays[known], "dx": d[:, 0], "dy": d[:, 1],
                    "dz": d[:, 2], "given_x": block.point_xyz[known, 0], "given_y": block.point_xyz[known, 1],
                    "given_z": block.point_xyz[known, 2]},
        "frames": {"geometry": _points3d(eo[:, :3]), "name": np.array(block.frames, dtype=str),
                   "omega": eo[:, 3], "phi": eo[:, 4], "kappa": eo[:, 5], "sigma_x0": result.eo_sigma[:, 0],
                   "sigma_y0": result.eo_sigma[:, 1], "sigma_z0": result.eo_sigma[:, 2],
                   "sigma_rx_deg": result.eo_sigma[:, 3], "sigma_ry_deg": result.eo_sigma[:, 4],
                   "sigma_rz_deg": result.eo_sigma[:, 5], "observations": n_used},
        "residuals": {"geometry": _points3d(result.point_xyz[block.obs_point[o_live]]),
                      "frame": np.array(block.frames, dtype=object)[block.obs_frame[o_live]].astype(str),
                      "point": ids[block.obs_point[o_live]].astype(str),
                      "col": block.obs_pixel[o_live, 0], "row": block.obs_pixel[o_live, 1],
                      "col_adjusted": adjusted[o_live, 0], "row_adjusted": adjusted[o_live, 1],
                      "dx_px": result.residuals[o_live, 0], "dy_px": result.residuals[o_live, 1],
                      "status": result.status[o_live], "w": result.w_test[o_live]},
    }


def report(result, block, crs, inputs: dict, stages: dict | None = None) -> dict:
    """The JSON report of one adjustment; ``stages``: seconds of the run's stages so far
    (:func:`~fotogeo.tools.triangulate.statistics.stage_timings`; the outputs' are added when written)."""
    from ...crs import short_name
    from ...orientation.ground_sigma import covariance_header, frame_covariance_entry
    cam = result.camera
    return {"fotogeo": "triangulate", **inputs, "crs": crs_text(crs), "crs_name": short_name(crs),
            "units": "ground: metres in crs; image: pixels (corner convention); residual = projected − measured",
            "sigma0": result.sigma0, "covariance_scale": result.stats.get("covariance_scale"),
            "statistics": result.stats,
            "camera": {"focal_length": cam.focal_length, "principal_point": list(cam.principal_point),
                       **result.distortion, "sigma": result.interior_sigma},
            "fixed_parameters": list(result.fixed), "correlations": list(result.correlations),
            "blunders": list(result.blunders),
            "frames": [{"name": n, "X": e.X, "Y": e.Y, "Z": e.Z, "omega": e.omega, "phi": e.phi, "kappa": e.kappa,
                        "sigma": dict(zip(("X0", "Y0", "Z0", "rx_deg", "ry_deg", "rz_deg"), map(float, s))),
                        **frame_covariance_entry(result, j)}
                       for j, (n, e, s) in enumerate(zip(block.frames, result.eo, result.eo_sigma))],
            **covariance_header(result),
            "iterations": result.iterations,
            "timings_s": stage_timings(stages, result.timings) if stages is not None else dict(result.timings),
            "point_sigma_by_role": point_sigma_by_role(result),
            "sigma_warnings": unchecked_lines(result.stats.get("variance_components") or {}),
            "matching_summary": matching_summary(inputs.get("matching"), result),
            "residuals_by_size": residuals_by_size(result, block),
            "notes": {"residuals_by_size": f"image residuals v = projected − measured of the observations still in "
                                           f"the block, largest |v| first (px), with the adjusted image coordinate "
                                           f"measured + v; the largest {LARGEST} here, every one in block.gpkg "
                                           f"(layer residuals)",
                      "point_sigma_by_role": "mean a-posteriori σ of the adjusted points per type (m) and their RMS",
                      "timings_s": "wall-clock seconds of the run's stages; adjustment_steps: the adjustment's own"}}


def _rmse_text(s: dict) -> str:
    z = f" Z {s['rmse_z_m']:.3f}" if np.isfinite(s.get("rmse_z_m", np.nan)) else " Z –"
    return f"RMSE X {s['rmse_x_m']:.3f} Y {s['rmse_y_m']:.3f}{z} m"


def accuracy_lines(rep: dict) -> list:
    """The accuracy of one adjustment in words, for the command line and the QGIS log: the check points'
    errors, the control points placed by the images alone (errors in metres, like the check points'),
    and — labelled as such — the control's adjusted − given, which its σ keeps small."""
    st = rep["statistics"]
    lines = []
    if st["check"].get("n"):
        lines.append(f"check points (n={st['check']['n']}, not used in the adjustment): {_rmse_text(st['check'])}")
    ci = st.get("control_images") or {}
    if ci.get("n"):
        z = f"; Z from the {ci['n_z']} seen at an angle" if ci.get("n_z", ci["n"]) < ci["n"] else ""
        lines.append(f"control points placed by the images alone (n={ci['n']}): {_rmse_text(ci)}{z}")
    if st["control"].get("n"):
        sig = rep.get("automatic_control_sigma_m") or {}
        held = (f"; automatic control σ {sig['xy']:.3g} m X, Y and {sig['z']:.3g} m Z" if sig.get("xy") else "")
        lines.append(f"control adjusted − given (σ-weighted: as far as their σ let them move{held}): "
                     f"{_rmse_text(st['control'])}")
    return lines


def dropped_lines(rep: dict) -> list:
    """The frames left out as undetermined (``report.json`` ``dropped_frames``, the default
    ``undetermined="drop"``), loudly: one headline "N of M frames dropped (undetermined): name — reason; …" with
    how to stop the run instead, for the first lines of the command line's summary and a warning in the QGIS log
    (whose caller's words turn the flag into the dialog's label). Empty when no frame was dropped."""
    dropped = rep.get("dropped_frames") or []
    if not dropped:
        return []
    which = "; ".join(f"{d['name']} — {d['reason']}" for d in dropped)
    return [f"{len(dropped)} of {rep['statistics']['n_frames'] + len(dropped)} frames dropped (undetermined): "
            f"{which}; --undetermined fail stops the run instead"]


#: the observation groups of :mod:`fotogeo.orientation.bundle_variance` in words, with the unit of their σ
_GROUPS = {"image": ("image points", "px"), "control": ("control coordinates", "m"),
           "position_prior": ("GPS positions", "m"), "attitude_prior": ("attitude priors", "deg")}
#: what to do when a group drives σ0, in the command line's words
_DRIVEN = {"image": "the image points' a-priori sigma is too small (matched tie points carry least-squares "
                    "matching's formal sigma, which is optimistic)",
           "control": "the control coordinates' sigma is too small or a control point is wrong: check the GCPs or "
                      "give --control-sigma-xy/--control-sigma-z",
           "position_prior": "the GPS positions are further off than their sigma says: give a realistic "
                             "--eo-sigma-position/--eo-sigma-height, or control points",
           "attitude_prior": "the attitude priors are further off than their sigma says: give a realistic "
                             "--eo-sigma-angle"}


#: the options that give each group's σ, for the warning of :func:`unchecked_lines`
_GIVE = {"control": "--control-sigma-xy/--control-sigma-z (or the GCP file's sigma columns)",
         "position_prior": "--eo-sigma-position/--eo-sigma-height", "attitude_prior": "--eo-sigma-angle"}


def unchecked_lines(groups: dict) -> list:
    """A warning for each prior group (control, GPS, attitude) whose σ0 the adjustment cannot estimate: its
    redundancy (:mod:`fotogeo.orientation.bundle_variance`) below 1, i.e. the images measure those coordinates
    less precisely than their a-priori σ, so no residual can show that σ too small — a σ of 3 cm for GCPs
    0.5 m off under a 1.7 m GSD left every frame e/σ 1.67 (``benchmarks/triangulate_sigma_bench.py``). Every
    σ reported then rests on the given one."""
    out = []
    for key, g in groups.items():
        s0 = g.get("sigma0")
        if key not in _GIVE or (s0 is not None and np.isfinite(s0)):
            continue
        name, unit = _GROUPS[key]
        prior = f" ({g['a_priori']:.3g} {unit})" if g.get("a_priori") else ""
        out.append(f"warning: the {name}' given sigma{prior} cannot be checked by this block (redundancy "
                   f"{g.get('redundancy', 0.0):.2f} of {g.get('n', 0)}: the images measure them less precisely "
                   f"than that sigma); every sigma reported takes it as right, and an error above it stays in the "
                   f"frames unseen — give their real accuracy with {_GIVE[key]}")
    return out


def variance_lines(rep: dict) -> list:
    """σ0 per observation group (``statistics.variance_components``, :mod:`fotogeo.orientation.bundle_variance`)
    in words: each group's σ0 and what its observations measure in their unit, a group the images cannot check
    said so; and, when one group drives σ0, which one, what it does to the σ reported and what to do."""
    st = rep.get("statistics") or {}
    groups = st.get("variance_components") or {}
    if not groups:
        return []
    parts = []
    for key, g in groups.items():
        name, unit = _GROUPS.get(key, (key, ""))
        s0, prior = g.get("sigma0"), g.get("a_priori", g.get("a_priori_px"))
        if s0 is None or not np.isfinite(s0):
            parts.append(f"{name} not checked by the other observations (redundancy {g['redundancy']:.1f})")
        elif prior:
            parts.append(f"{name} {s0:.2f} (a priori {prior:.3g} {unit}, measured ~{s0 * prior:.3g} {unit})")
        else:
            parts.append(f"{name} {s0:.2f}")
    lines = ["sigma0 by observation group: " + "; ".join(parts)]
    image = groups.get("image") or {}
    if image.get("factor"):
        given = image.get("a_priori_px", 0.0) / image["factor"]
        lines.append(f"image points' sigma estimated from their residuals: {given:.3g} px given (least-squares "
                     f"matching's formal sigma for matched tie points) gave them a sigma0 of "
                     f"{image['sigma0_given']:.2f}; weighted as {image.get('a_priori_px', 0.0):.3g} px instead "
                     f"(variance component), so a prior's sigma is not scaled by it")
    lines += unchecked_lines(groups)
    top = dominant_group(groups)
    blind = (st.get("reweighting") or {}).get("uncheckable")
    if blind:  # the misfit shows in the groups checked, the cause may be one nothing checks
        lines.append(unattributed_line(groups, blind, top))
    elif top is not None:
        s0, f = groups[top]["sigma0"], (st.get("group_factors") or {}).get(top)
        solves = (st.get("group_factors") or {}).get("solves")
        done = (f"its weights were divided by {f:.3g}² and the block solved again (statistics.group_factors): the "
                f"orientations and their sigma come from the re-weighted groups" if f and solves else
                f"every sigma reported is scaled by sigma0 {float(rep.get('sigma0', s0)):.3g}, so what the other "
                f"observations hold (e.g. an attitude held by its prior) may read up to that many times less "
                f"precise than it is")
        lines.append(f"sigma0 is driven by the {_GROUPS.get(top, (top,))[0]} ({s0:.2f}): {_DRIVEN.get(top, '')}; "
                     + done)
        unchecked = [_GROUPS.get(k, (k,))[0] for k, g in groups.items()
                     if g.get("sigma0") is None or not np.isfinite(g["sigma0"])]
        if unchecked:  # an error in a group nothing checks shows in the others
            lines[-1] += f" (or the {', '.join(unchecked)}, which nothing checks, are wrong)"
    if (st.get("reweighting") or {}).get("converged") is False:
        last = ", ".join(f"{_GROUPS.get(k, (k,))[0]} {v:.2f}" for k, v in st["reweighting"]["sigma0_last"].items())
        lines.append(f"warning: the re-weighting of the observation groups did not converge in "
                     f"{st['group_factors']['solves']} solves (last sigma0 by group: {last}): the orientations and "
                     f"their sigma are the last solve's")
    return lines


def unattributed_line(groups: dict, blind: list, top: str | None) -> str:
    """The report's line when the misfit cannot be attributed (:func:`~fotogeo.orientation.bundle_result.uncheckable`):
    the groups above their σ, the uncheckable ones as a possible cause with their option, and what was done."""
    high = [f"{_GROUPS.get(k, (k,))[0]} {g['sigma0']:.2f}" for k, g in groups.items()
            if g.get("sigma0") is not None and np.isfinite(g["sigma0"]) and g["sigma0"] > 1.05]
    who = "; ".join(f"the {_GROUPS.get(k, (k,))[0]} (redundancy {groups[k].get('redundancy', 0.0):.2f}, "
                    f"{_GIVE.get(k, 'its sigma')})" for k in blind)
    said = f"sigma0 by group {', '.join(high)} exceeds the a-priori sigma" if high else "sigma0 exceeds 1"
    return (f"warning: the misfit cannot be attributed: {said}, but a group nothing checks may be the cause "
            f"rather than {_GROUPS.get(top, ('those groups',))[0] if top else 'those groups'} — {who}: check that "
            f"sigma; the orientations are those of the given weights (not re-weighted), their sigma widened per "
            f"group (statistics.covariance_rule)")


def held_fixed_line(fixed) -> str:
    """One line for the interior parameters the adjustment held fixed, each with why in short: its multiple
    correlation and largest partner (the correlation rule), or its t (not significant); the report has the
    full reasons (the console's and the QGIS log's line)."""
    parts = []
    for f in fixed:
        if "multiple_correlation" in f:
            parts.append(f"{f['parameter']} (correlation {f['multiple_correlation']:.4f}, most with {f['partner']} "
                         f"{f['correlation']:+.2f})")
        elif "t" in f:
            parts.append(f"{f['parameter']} (not significant, {f['t']:.2g} sigma)")
        else:
            parts.append(f["parameter"])
    return f"held fixed (report.html says why): {', '.join(parts)}"
