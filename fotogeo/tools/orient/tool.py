"""The orientation tools: GCPs + image (paths) → fitted model, report, error vectors, exports,
rectified raster; and the model comparison table.

``orient(image, gcps, model=...)`` reads the GCPs (:mod:`fotogeo.io.gcps`), fits the model on
the control points with data snooping (:mod:`fotogeo.orientation`), and writes what is asked.
``model="auto"`` fits every candidate the GCPs allow and keeps the simplest within 5 % of the
best check RMSE (:func:`fotogeo.orientation.adjustment.select_model`; the report's
``model_selection`` lists the candidates and says why). It returns an
:class:`~fotogeo.tools.common.results.Orientation` (which reads like the report dict) and writes:

* ``report`` — JSON: model and coefficients, ``control`` / ``check`` statistics
  (``n``, ``rms_x_px``, ``rms_y_px``, ``rms_xy_px``, min, max, median; ``*_mm`` with a scan
  pixel size), per-point residuals, blunders, warnings; a path ending in ``.html`` gets the same as one
  readable page (:mod:`fotogeo.tools.orient.report`);
* ``vectors`` — GeoPackage, layers ``gcps`` (points with residuals) and ``error_vectors``
  (lines from each GCP to where the model puts its measured image point on the ground,
  with ``dx``, ``dy``, ``length`` in map units and ``dx_px``, ``dy_px``; ``exaggeration`` and
  ``legend``, :mod:`fotogeo.io.vector`: ``auto`` draws one image pixel of residual as 3 % of the
  GCPs' extent, the same factor for every model fitted to the same GCPs);
* ``plot`` — PNG: the residual vectors over the image, coloured by role, labelled with the GCP
  ids, drawn with the same exaggeration as the vectors, with a scale bar of the residuals;
* ``points`` — QGIS Georeferencer ``.points`` file with the residuals;
* ``rpc`` — for the RFM models: a GeoTIFF copy of the image carrying the model as GDAL RPC
  metadata (RPC00B, refitted in lon/lat/h), usable by ``gdalwarp -rpc`` and QGIS;
* ``gcp_tiff`` — for ``poly1``–``poly3``: a GeoTIFF copy of the image carrying the control
  points as GDAL GCPs, so that ``gdalwarp -order N`` / QGIS reproduce the fitted polynomial
  (GDAL fits the same least-squares polynomial of total degree N to the same points);
* ``rectify`` — the image resampled to a map grid in the GCPs' CRS through the model,
  heights from ``dem`` or ``height`` for 3-D models, window by window (:mod:`fotogeo.tools.orient.rectify`).
"""
from __future__ import annotations

import warnings
from pathlib import Path

import cv2
import numpy as np
from affine import Affine

from ...errors import FotogeoWarning, InputError
from ...io.camera import load_camera
from ...io.gcps import inside_image, read_gcps
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, RasterInfo, open_raster, read_decimated
from ...io.report import write_json
from ...io.vector import error_vectors, exaggeration_value, legend_text, nominal_scale, write_layers
from ...geometry.georeference import Georeference
from ...models import get_model
from ...orientation.adjustment import fit_orientation, select_model
from ...orientation.copy_reading import CLICK_SIGMA_PX
from ...progress import as_progress
from ..common.checks import camera_fit, check_camera_size, check_gcp_crs, inside_fitted
from ..common.boundary import OUTPUTS, tool
from ..common.gcp_style import legend_class
from .rectify import mean_height, rectify_grid, rectify_image
from ..common.results import Orientation



@tool("ORIENT", "GCP", rasters={"image": None, "dem": None}, outputs=OUTPUTS + ("points",))
def orient(image, gcps, *, model: str = "auto", report=None, vectors=None, plot=None, points=None, rpc=None,
           gcp_tiff=None, rectify=None, dem=None, height=None, scan_pixel_um=None, snooping: bool = True,
           remove_blunders: bool = False, image_sigma=None, exaggeration="auto", resolution=None,
           resampling: str = "nearest", crs=None, layer=None, fields=None, camera=None, overwrite: bool = False,
           progress=None) -> Orientation:
    """Fit ``model`` (a name, or ``"auto"``) to the GCPs of ``image`` and write the requested
    outputs; ``image`` None is a numbers-only resection (GCPs' pixel positions + ``camera``, whose image size is
    the image's; no plot, RPC/GCP copies or rectified raster); returns an :class:`~fotogeo.tools.common.results.Orientation` (``result["check"]`` reads the report).

    ``camera`` (a :class:`~fotogeo.geometry.camera.FrameCamera` or an interior-orientation YAML file)
    is needed by ``collinearity`` only. ``image_sigma``: the a priori σ of the GCPs' image positions (the
    click precision, px) for the blunder test (:mod:`fotogeo.orientation.blunders`); None: estimated.
    """
    prog = as_progress(progress)
    camera = load_camera(camera)
    if model != "auto":
        get_model(model).options_from(camera=camera)  # fails early, naming a missing camera
    outs = {k: v for k, v in dict(report=report, vectors=vectors, plot=plot, points=points, rpc=rpc,
                                  gcp_tiff=gcp_tiff, rectify=rectify).items() if v}
    _check_outputs(model, outs, [p for p in (image, gcps, dem) if p is not None], overwrite)
    info = open_raster(image, "image") if image is not None else _image_from_camera(camera, outs)
    g = read_gcps(gcps, layer=layer, crs=crs, raster=image if info.georeferenced else None, dem=dem,
                  height=height, **(fields or {}))
    check_gcp_crs(g, gcps)
    if image is not None:
        check_camera_size(camera, info.width, info.height, image)
    g, skipped = _inside(g, info, gcps, model, camera, image_sigma)
    prog(0.1, "GCPs read")
    scale_mm = scan_pixel_um / 1000.0 if scan_pixel_um else None
    selection = None
    if model == "auto":
        model, selection = select_model(g.ground, g.pixel, g.role, g.ids, camera=camera,
                                        progress=prog.stage(0.1, 0.2, "choosing the model"))
    fit = fit_orientation(model, g.ground, g.pixel, g.role, g.ids, snooping=snooping,
                          remove_blunders=remove_blunders, scale_mm=scale_mm, camera=camera,
                          image_sigma=image_sigma, progress=prog.stage(0.2, 0.3, "fitting the model"))
    prog(0.3, "model fitted")
    on_ground, d_ground = ground_residuals(fit.model, g.ground, g.pixel, g.crs)
    rep = _report(image, gcps, model, g, fit, d_ground, scan_pixel_um)
    rep.update(skipped=skipped, heights=g.heights, hints=_height_hint(g, fit, camera, image_sigma))
    for h in rep["hints"]:
        warnings.warn(h, FotogeoWarning, stacklevel=2)
    if selection:
        rep["model_selection"] = selection
    rep["exaggeration"] = _exaggeration(exaggeration, g)
    rep["notes"] = _notes(rep)
    grid = rectify_grid(rectify, info, fit.model, g.crs, g.ground, dem, height, resolution) if rectify else None
    with AtomicOutputs(overwrite) as out:
        if vectors:
            _write_vectors(out.temp(vectors), g, fit, on_ground, d_ground, rep["exaggeration"])
        if plot:
            _plot(out.temp(plot), info, g, fit, rep["exaggeration"])
        if points:
            from ...io.points import pixel_to_source, write_points
            src = pixel_to_source(g.pixel, info.transform if info.georeferenced else None)
            write_points(out.temp(points), g.ground[:, :2], src, enabled=fit.role == "control",
                         residual=fit.residual, crs=g.crs.to_wkt())
        if rpc:
            from ...io.rpc import write_rpc_geotiff
            from ...orientation.rpc import fit_rpc
            ctrl = fit.role == "control"
            rpc_model, _ = fit_rpc(g.ground[ctrl], g.pixel[ctrl], g.crs, model=model)
            tmp = out.temp(rpc)
            write_rpc_geotiff(image, tmp, rpc_model)
            rep["rpc"] = {"path": str(rpc), **rpc_model.to_gdal_metadata()}
        if gcp_tiff:
            ctrl = fit.role == "control"
            _write_gcp_tiff(image, out.temp(gcp_tiff), g.pixel[ctrl], g.ground[ctrl], g.ids[ctrl], g.crs)
            rep["gcp_tiff"] = {"path": str(gcp_tiff), "order": int(model[-1]), "gcps": int(ctrl.sum())}
        prog(0.4, "vectors and exports written")
        if rectify:
            rep["rectified"] = rectify_image(out.temp(rectify), info, g.crs, grid, resampling,
                                             prog.stage(0.4, 0.98, "rectifying"))
        if report and str(report).lower().endswith((".html", ".htm")):
            from .report import write_report_html
            write_report_html(out.temp(report), rep)
        elif report:
            write_json(out.temp(report), rep)
        prog(1.0, "done")
        out.commit()
    geo = Georeference(fit.model, heights=mean_height(g.ground), crs=g.crs)
    return Orientation(fit.model, geo, rep, {k: Path(v) for k, v in outs.items()})


def ground_residuals(model, ground, pixel, crs):
    """``(on_ground, d_ground)``: where ``model`` (ground → image) puts each measured image point
    ``pixel`` on the ground at the GCP's own height ``ground[:, 2]`` (2-D models ignore it), and
    that minus the GCP's map position (map units; NaN where the model gives no ground point)."""
    on_ground = Georeference(model, heights=ground[:, 2], crs=crs).pixel_to_map(pixel)
    return on_ground, on_ground - ground[:, :2]


#: outputs drawn over or copied from the image raster: not available in a numbers-only resection
RASTER_OUTPUTS = ("plot", "rpc", "gcp_tiff", "rectify")


def _inside(g, info, gcps, model: str, camera, image_sigma):
    """:func:`~fotogeo.io.gcps.inside_image` of the GCPs; with a camera (collinearity or ``auto``) the fit tells
    positions read on a copy of another size or turned (refused, naming it) from a crop's
    (:mod:`fotogeo.orientation.copy_reading`), and the span rule is kept only where too few lie inside to tell."""
    if camera is None or model not in ("collinearity", "auto"):
        return inside_image(g, info.width, info.height, f"{gcps}", *_needed(model))
    return inside_fitted(g, info.width, info.height, f"{gcps}", *_needed(model), camera_fit(camera, image_sigma))


def _needed(model: str) -> tuple[int, str]:
    """How many control points ``model`` needs and its name, for refusing GCPs that leave too few inside."""
    if model == "auto":
        return get_model("similarity").min_points, "the simplest model (similarity)"
    return get_model(model).min_points, f"model {model!r}"


#: a 2-D model's RMSE above this many times the GCPs' image σ (given, else :data:`NOMINAL_SIGMA_PX`) is a
#: hint of relief the model cannot follow
HINT_FACTOR = 3.0
#: the click precision (px) assumed for that hint when ``image_sigma`` is not given
NOMINAL_SIGMA_PX = CLICK_SIGMA_PX


def _height_hint(g, fit, camera, image_sigma) -> list[str]:
    """One line naming ``--dem`` when the GCPs have no heights and a 2-D model was fitted although a 3-D one
    may be called for: a frame camera was given (a perspective image over relief), or the model's error (check
    RMSE, else control RMSE) exceeds :data:`HINT_FACTOR` × the GCPs' image σ — relief displacement left in
    the residuals, which a DEM (or a height column) lets a 3-D model (DLT, RFM, collinearity) take up."""
    if g.has_heights or fit.model.src_dims != 2:
        return []
    rms = fit.stats.get("check", {}).get("rms_xy_px") or fit.stats.get("control", {}).get("rms_xy_px")
    limit = HINT_FACTOR * (image_sigma or NOMINAL_SIGMA_PX)
    if camera is None and not (rms and rms > limit):
        return []
    which = "check" if fit.stats.get("check", {}).get("rms_xy_px") else "control"
    why = ("a frame camera was given" if camera is not None else
           f"its {which} RMSE {rms:.2f} px > {HINT_FACTOR:g} × the GCPs' image σ "
           f"{image_sigma or NOMINAL_SIGMA_PX:g} px{'' if image_sigma else ' (assumed; --image-sigma)'}")
    return [f"the GCPs have no heights, so a 2-D model was fitted ({why}): relief displacement may be left in "
            f"its residuals; a DEM (--dem) or a height column (--z-field) gives the GCPs heights for a 3-D model "
            f"(dlt, rfm, collinearity)"]


def _image_from_camera(camera, outs: dict) -> RasterInfo:
    """A numbers-only resection (no image raster): the image's size from ``camera``, no georeference."""
    if camera is None:
        raise InputError("give the image (IMAGE before GCPS), or --camera for a numbers-only resection (the image "
                         "size is the camera's)")
    needing = [k for k in RASTER_OUTPUTS if k in outs]
    if needing:
        flags = ", ".join("--" + k.replace("_", "-") for k in needing)
        raise InputError(f"{flags} {'needs' if len(needing) == 1 else 'need'} the image raster; give IMAGE before GCPS (a numbers-only resection writes "
                         f"--report, --vectors and --points)")
    w, h = (int(v) for v in camera.image_size)
    return RasterInfo(None, w, h, 0, "uint8", None, Affine.identity(), None)


def _check_outputs(model: str, outs: dict, inputs: list, overwrite: bool) -> None:
    """Refuse, before any work, exports the model cannot give and output paths that clash or exist."""
    if model == "auto" and ("gcp_tiff" in outs or "rpc" in outs):
        raise InputError("--gcp-tiff and --rpc export one model kind (polynomials, RFMs): name the model instead "
                         "of 'auto'")
    if "gcp_tiff" in outs and model not in ("poly1", "poly2", "poly3"):
        raise InputError(f"a GCP GeoTIFF reproduces polynomial models only (poly1, poly2, poly3 = gdalwarp -order "
                         f"1-3); model {model!r} is not one")
    for k, v in outs.items():
        check_output(v, inputs, overwrite, k)
    if len({Path(v).resolve() for v in outs.values()}) < len(outs):
        raise InputError("two outputs have the same path; give each its own")
    if "rpc" in outs and (not model.startswith("rfm") or model.endswith("-i2g")):
        raise InputError(f"--rpc exports a ground-to-image RFM; model {model!r} is not one (use rfm, rfm-common, "
                         f"rfm-poly)")


def _exaggeration(option, g) -> dict:
    """The report's ``exaggeration``: k for the error vectors and the plot, the same for every model
    fitted to these GCPs — ``auto`` takes one image pixel on the ground (the GCPs' own scale,
    spread of ground over spread of pixels) as the typical vector."""
    ground, pixel = g.ground[:, :2], g.pixel
    spread_px = float(np.sqrt(np.var(pixel, axis=0).sum()))
    gsd = float(np.sqrt(np.var(ground, axis=0).sum())) / spread_px if spread_px > 0 else 0.0
    k, how = exaggeration_value(option, gsd, ground)
    scale = nominal_scale(ground)
    return {"factor": k, "chosen": how, "ground_per_pixel": gsd, "map_scale": scale,
            "legend": legend_text(k, scale, "ground units" if g.crs.is_geographic else "m")}


def _notes(rep) -> dict:
    """What each number of the orientation report means."""
    return {
        "residual": "model(ground) minus the measured image position, in image pixels (corner convention); "
                    "dx_ground, dy_ground: where the model puts the measured pixel on the ground minus the GCP",
        "control": "residuals at the GCPs the model was fitted to: an optimistic measure",
        "check": "residuals at GCPs held out of the fit: the accuracy estimate, including the GCPs' own "
                 "measurement errors (image and map)",
        "blunder": "control points data snooping (Baarda 1968) removed (remove_blunders)",
        "flag": "the blunder test of each control point: 'blunder' (|w| above the critical value), 'suspect' (above "
                "it, but the redundancy is too low to call it a blunder), 'not testable' (its own redundancy too low)",
        "w": "standardised residual of the point (its residual over its standard deviation, both directions)",
        "redundancy": "the point's redundancy number (0: the fit follows it wherever it is, 1: fully checked)",
        "mdb_px": "minimal detectable blunder (Baarda 1968): an error of the point's image position this large (pixels, "
                  "least favourable direction) is flagged with 80 % probability; a smaller one may go unnoticed",
        "exaggeration": f"error vectors and plot drawn {rep['exaggeration']['legend']} ({rep['exaggeration']['chosen']})",
        **({"model_selection": f"auto: {rep['model_selection']['because']}"} if "model_selection" in rep else {}),
    }


def _report(image, gcps, model, g, fit, d_ground, scan_pixel_um) -> dict:
    scale_mm = scan_pixel_um / 1000.0 if scan_pixel_um else None
    return {"fotogeo": "orient", "image": str(image) if image is not None else None, "gcps": str(gcps), "model_name": model,
            "crs": g.crs.to_string(), "n_gcps": len(g), **fit.stats, "snooping": fit.snooping,
            "blunder_test": fit.blunder_test,
            "warnings": fit.warnings, "model": fit.model.to_dict(),
            "model_info": {k: v for k, v in getattr(fit.model, "info", {}).items()
                           if isinstance(v, (int, float, str, list, bool))},
            "scan_pixel_um": scan_pixel_um, "units": "pixels (corner convention); ground units of the GCP CRS",
            "points": [{"id": i, "role": r, "col": float(p[0]), "row": float(p[1]), "dx_px": float(v[0]),
                        "dy_px": float(v[1]), "dx_ground": float(dg[0]), "dy_ground": float(dg[1]),
                        "w": _num(w), "redundancy": _num(rn), "mdb_px": _num(mb), "flag": fl,
                        **({"dx_mm": float(v[0] * scale_mm), "dy_mm": float(v[1] * scale_mm)} if scale_mm else {})}
                       for i, r, p, v, dg, w, rn, fl, mb in zip(g.ids, fit.role, g.pixel, fit.residual, d_ground, fit.w,
                                                                fit.redundancy, fit.flag, _mdb(fit))]}


def _mdb(fit) -> np.ndarray:
    return fit.mdb if fit.mdb is not None else np.full(len(fit.role), np.nan)


def _num(v):
    return float(v) if np.isfinite(v) else None


def _write_gcp_tiff(src_path, dst_path, pixel, ground, ids, crs):
    """Copy ``src_path`` with GDAL GCPs (pixel/line in the corner convention, as GDAL's are)."""
    from rasterio.control import GroundControlPoint
    from rasterio.crs import CRS as RioCRS

    from ...io.raster import geotiff_profile, ropen
    gcps = [GroundControlPoint(row=float(p[1]), col=float(p[0]), x=float(q[0]), y=float(q[1]),
                               z=float(q[2]) if np.isfinite(q[2]) else 0.0, id=str(i))
            for p, q, i in zip(pixel, ground, ids)]
    with ropen(src_path) as src:
        prof = geotiff_profile(src.profile)
        for k in ("transform", "crs", "photometric", "jpeg_quality", "jpegtablesmode"):
            prof.pop(k, None)
        if src.count == 3 and src.dtypes[0] == "uint8":
            prof["photometric"] = "RGB"
        with ropen(dst_path, "w", **prof, gcps=gcps, crs=RioCRS.from_wkt(crs.to_wkt())) as dst:
            for _, win in src.block_windows(1):
                dst.write(src.read(window=win), window=win)


def _write_vectors(path, g, fit, on_ground, d_ground, exaggeration: dict):
    import shapely
    k, legend = exaggeration["factor"], exaggeration["legend"]
    d_px = fit.residual
    common = {"id": g.ids.astype(object), "role": fit.role.astype(object), "col": g.pixel[:, 0],
              "row": g.pixel[:, 1], "z": g.ground[:, 2], "dx_px": d_px[:, 0], "dy_px": d_px[:, 1],
              "residual_px": np.hypot(*d_px.T), "w": fit.w, "redundancy": fit.redundancy,
              "mdb_px": _mdb(fit), "flag": fit.flag.astype(object), "class": legend_class(fit.role, fit.flag).astype(object)}
    layers = {"gcps": {**common, "geometry": shapely.points(g.ground[:, :2])},
              "error_vectors": {**common, "dx": d_ground[:, 0], "dy": d_ground[:, 1],
                                "length": np.hypot(*d_ground.T), "exaggeration": np.full(len(g), k),
                                "legend": [legend] * len(g),
                                "geometry": error_vectors(g.ground[:, :2], on_ground, k)}}
    write_layers(path, layers, g.crs.to_wkt(), {"error_vectors": f"Error vectors drawn {legend}."})


#: the plot's colours (BGR) per legend class (:func:`fotogeo.tools.common.gcp_style.legend_class`) and their names
PLOT_COLOURS = {"control": ((180, 120, 31), "blue"), "check": ((28, 26, 227), "red"),
                "suspect": ((0, 140, 255), "orange"), "blunder": ((200, 0, 200), "magenta")}  # the QGIS style's
_HEADER_PX = 34


def _plot(path, info, g, fit, exaggeration: dict, size: int = 1000):
    """PNG of the residual vectors over a grey thumbnail of the image: drawn ``exaggeration``
    times (the factor of the error-vector layer, the same for every model on these GCPs),
    coloured by legend class (a flagged point in its class's colour, whatever its role), each labelled
    with its GCP id; the legend in a white band above the image (nothing under it), a scale bar below."""
    bands, _, (fx, fy) = read_decimated(info, size * size, "image")
    img = bands[:3].mean(axis=0)
    lo, hi = np.percentile(img, [1, 99])
    grey = np.clip((img - lo) / max(hi - lo, 1e-9) * 200 + 30, 0, 255).astype(np.uint8)
    image = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    k = exaggeration["factor"]
    font, aa = cv2.FONT_HERSHEY_SIMPLEX, cv2.LINE_AA
    classes = legend_class(fit.role, fit.flag)
    for p, v, c, i in zip(g.pixel, fit.residual, classes, g.ids):
        a = (p[0] / fx, p[1] / fy)
        b = (a[0] + k * v[0] / fx, a[1] + k * v[1] / fy)
        colour = PLOT_COLOURS.get(c, ((0, 0, 0), ""))[0]
        cv2.circle(image, (int(a[0]), int(a[1])), 3, colour, -1, aa)
        cv2.arrowedLine(image, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), colour, 2, aa, tipLength=0.25)
        cv2.putText(image, str(i), (int(a[0]) + 5, int(a[1]) - 5), font, 0.4, colour, 1, aa)
    _scale_bar(image, k, fx, exaggeration.get("ground_per_pixel"))
    canvas = np.full((image.shape[0] + _HEADER_PX, max(image.shape[1], 420), 3), 255, np.uint8)
    canvas[_HEADER_PX:, :image.shape[1]] = image
    x = 10
    cv2.putText(canvas, f"vectors x{k:g}", (x, 22), font, 0.5, (0, 0, 0), 1, aa)
    x += 110
    for c in [c for c in PLOT_COLOURS if c in set(classes)]:  # only the classes drawn: no empty legend entry
        colour = PLOT_COLOURS[c][0]
        cv2.circle(canvas, (x + 5, 17), 5, colour, -1, aa)
        cv2.putText(canvas, c, (x + 14, 22), font, 0.5, colour, 1, aa)
        x += 24 + 10 * len(c)
    if not cv2.imwrite(str(path) if str(path).endswith(".png") else str(path) + ".png", canvas):
        raise InputError(f"could not write the plot {path}")
    if not str(path).endswith(".png"):
        Path(str(path) + ".png").replace(path)


def _scale_bar(canvas, k: float, fx: float, ground_per_pixel=None):
    """A bar in the bottom-left corner: the drawn length of a residual of L image pixels (L from
    the 1-2-5 series, the bar about a tenth of the plot wide)."""
    from ...io.vector import nice_number
    h, w = canvas.shape[:2]
    L = nice_number(0.1 * w * fx / k)
    length = int(round(L * k / fx))
    x0, y0 = 15, h - 20
    text = f"{L:g} px residual" + (f" (~{L * ground_per_pixel:.3g} ground units)" if ground_per_pixel else "")
    (tw, _), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
    cv2.rectangle(canvas, (x0 - 5, y0 - 28), (x0 + max(length, tw) + 5, y0 + 8), (255, 255, 255), -1)
    cv2.line(canvas, (x0, y0), (x0 + length, y0), (0, 0, 0), 3)
    for x in (x0, x0 + length):
        cv2.line(canvas, (x, y0 - 6), (x, y0 + 6), (0, 0, 0), 2)
    cv2.putText(canvas, text, (x0, y0 - 12), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
