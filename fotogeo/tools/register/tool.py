"""The registration tool: reference orthophoto + target image (paths) → georeferenced raster.

``register(reference, target, output)`` runs the pipeline of the source paper (Dihkan
2019) with fotogeo's additions:

1. read both images (decimated to ``max_match_pixels`` for matching), PCA fusion of the bands
   ``reference_bands`` / ``target_bands`` (all by default; empty or constant ones left out);
2. keypoints + descriptors (SURF by default), SSD matching with the ratio test; with ``refine``
   ``lsm`` (``auto``, the default) the consistent matches are refined by
   least-squares matching, each with its σ and status (:mod:`fotogeo.tools.register.points`);
3. tie points: target pixels ↔ reference map coordinates, transformed into the output CRS
   (``"auto"`` = the reference's CRS when it is projected, else the UTM zone of the reference
   centre; ``"reference"``; ``"utm"``, the source paper's rule — :func:`fotogeo.crs.choose_output_crs`);
4. RANSAC + robust refit of the model (projective by default), check points held out; the
   final least squares weights each point by the spatial balance and its LSM σ;
5. window-by-window resampling of every band of the target onto the output grid — aligned to
   the reference's pixel grid when the output CRS is the reference's (:func:`aligned_grid`);
6. outputs written atomically: ``OUT.tif`` (a Cloud Optimized GeoTIFF with ``cog=True``),
   ``OUT.gpkg`` (layers ``tie_points``, ``error_vectors`` and ``error_grid``, the mean residual
   per grid cell) and ``OUT.json`` (the report, whose ``notes`` explain every number: RMSE, CE90
   and CE95 per role, the tie points' own precision apart from the model's residuals).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...crs import choose_output_crs, pixel_size_in, require_projected, short_name, to_lonlat, transform_points
from ...errors import InputError, ModelError
from ...geometry.georeference import Georeference
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, open_raster, read_dem
from ...io.report import write_json
from ...io.warp import grid_covering, warp_to_grid
from ...models import get_model
from ...models.stats import rmse
from ...options import PLANAR_MODELS, RegisterOptions  # declared in the option table
from ...orientation.terrain import TERRAIN_MODELS
from ...pixels import map_to_pixel, outline, pixel_to_map
from ...progress import as_progress
from ..common.checks import check_camera_size, check_output_grid
from .match import band_numbers, select_bands
from ..common.boundary import tool
from .points import fit_points, refine_mode, tie_points as find_points, write_vectors
from ..coreg.tool import check_window
from .local import local_correction, matched_and_fitted
from .report import build_report, notes, precision, summary_lines
from ..common.results import Registration

__all__ = ["register", "Registration", "RegisterOptions", "aligned_grid", "summary_lines"]


def output_grid(geo, width: int, height: int, res: float):
    """Output transform, width and height covering the target footprint under a planar ``geo``
    (a model that folds the image or maps it to a sliver of its bounding box is refused; the
    grid's size is checked by :func:`~fotogeo.tools.common.checks.check_output_grid`)."""
    edge = outline(width, height, 65)
    if geo.model.folds(edge):  # final guard: RANSAC rejects folding samples, its refits are not checked
        raise ModelError("the fitted homography folds the target image (its horizon crosses the image): "
                         "the tie points are too few or badly spread — check that the images overlap, "
                         "or try --model affine")
    XY = geo.pixel_to_map(edge)
    if not np.isfinite(XY).all():
        raise ModelError("the fitted model maps part of the target footprint to infinity")
    transform, w, h = grid_covering(XY, res)
    # sanity: the footprint's area in output pixels against the target's own pixel count
    area = 0.5 * abs(np.dot(XY[:, 0], np.roll(XY[:, 1], 1)) - np.dot(XY[:, 1], np.roll(XY[:, 0], 1)))
    if w * h > max(64 * area / res ** 2, 1e4):
        raise ModelError(f"the fitted model gives an implausible output grid ({w}x{h}); "
                         f"the tie points are probably wrong — check that the images overlap")
    return transform, w, h


@tool("REGISTER", "REGISTER_TERRAIN", rasters={"reference": "reference_nodata", "target": "target_nodata", "dem": None})
def register(reference, target, output, *, vectors=None, report=None, field=None, overwrite: bool = False,
             options: RegisterOptions | None = None, progress=None, tie_points=None, dem=None, camera=None,
             **kwargs) -> Registration:
    """Register ``target`` to the georeferenced ``reference``; write ``output`` (GeoTIFF).

    Options come as a :class:`RegisterOptions` or as keyword arguments of the same names.
    ``vectors`` (GeoPackage) and ``report`` (JSON) default to ``output`` with ``.gpkg`` /
    ``.json``. ``progress(fraction, message) -> bool`` may cancel (return False): nothing is
    left behind then, and no input is modified. ``tie_points = (target_xy, reference_xy)``
    (full-resolution pixels, corner convention) skips detection and matching — for tie
    points from another matcher or measured by hand.

    With ``dem`` (a DEM path or :class:`~fotogeo.geometry.dem.Dem`) the registration is terrain-aware
    (:mod:`fotogeo.orientation.terrain`): each tie point gets its DEM height, a 3-D model (``model`` =
    ``auto``, ``dlt``, ``rfm``, ``rfm-common``, ``rfm-poly``, or ``collinearity`` with
    ``camera``, a FrameCamera or interior-orientation YAML) is fitted, and the output is
    orthorectified: every output pixel takes its height from the DEM.

    With ``local`` the registered raster is then corrected by a smooth displacement field
    measured on a grid of windows against the reference (:mod:`fotogeo.tools.register.local`);
    ``field`` (GeoTIFF, default ``output`` with ``_field.tif``) receives the field and ``vectors``
    a layer ``local_windows``. When feature matching fails on a georeferenced target, a grid of
    windows gives the tie points instead (``area_fallback``; the report's ``area_based`` says so).
    """
    opts = options or RegisterOptions(**kwargs)
    if options is not None and kwargs:
        raise InputError("give either options= or keyword options, not both")
    opts.validate()
    opts = replace(opts, **{f"{r}_bands": _band_text(getattr(opts, f"{r}_bands"), f"{r}_bands")
                            for r in ("reference", "target")})
    prog = as_progress(progress).with_own_timings()
    output, vectors, report = _check_outputs(opts, reference, target, output, vectors, report, dem, overwrite)
    field = _field_path(opts, output, field, [reference, target], overwrite)
    ref, tgt, crs, crs_rule, camera = _open_inputs(opts, reference, target, dem, camera)
    with AtomicOutputs(overwrite) as out:
        with prog.timed("total"):
            ref_px = pixel_size_in(ref.transform, ref.crs, crs, ref.width / 2, ref.height / 2)
            res = opts.resolution or _reference_step(ref, crs) or ref_px
            refine = refine_mode(opts.refine)
            fit = _fitter(opts, ref, ref_px, tgt, crs, res, dem, camera, prog)
            pts, dst, gf, refine = matched_and_fitted(
                reference, target, ref, tgt, opts, prog, lambda: find_points(opts, ref, tgt, prog, tie_points, refine),
                fit, tie_points, refine, ref_px)
            counts = pts.counts
            check_output_grid(output, gf.width, gf.height, bands=tgt.count, dtype=tgt.dtype,
                              source_pixels=tgt.width * tgt.height, resolution=res,
                              what=f"the registered raster {str(output)!r}")
            transform, width, height, aligned = aligned_grid(gf.transform, gf.width, gf.height, res, ref, crs)
            gf = replace(gf, transform=transform, width=width, height=height)
            rep = build_report(opts, ref, tgt, crs, ref_px, res, counts, gf)
            rep["refine"] = "given tie points (not refined)" if tie_points is not None else refine
            if "area_based" in counts:
                rep["area_based"] = counts["area_based"]
            rep["precision"] = precision(rep, None if pts.sigma_px is None else pts.sigma_px[gf.role == "check"])
            rep["output_crs_name"], rep["output_crs_rule"] = short_name(crs), crs_rule
            rep["output_grid"]["aligned_to_reference"] = aligned
            inverse_map, local = gf.georeference.map_to_pixel, None
            if opts.local:  # the field measured on a cubic registration, then one resampling through both
                local_stage = prog.stage(0.6, 0.8, "local co-registration")
                with local_stage.timed("local"):
                    local = _measure_local(reference, tgt, gf, crs, out, field, opts, local_stage)
                rep["local"] = local.report
                inverse_map = composed_map(gf, local.result.field)
            stage = prog.stage(0.8 if opts.local else 0.6, 0.95 if not opts.cog else 0.9, "resampling")
            with stage.timed("resample"):
                raster = out.temp(output)
                written = warp_to_grid(tgt.path, raster, inverse_map, crs=crs,
                                       transform=gf.transform, width=gf.width, height=gf.height,
                                       resampling=opts.resampling, block=gf.block, src_nodata=opts.target_nodata,
                                       progress=stage)
                rep["output_grid"].update(written)
            if opts.cog:
                from ...io.cog import convert_to_cog
                with prog.stage(0.9, 0.95, "writing the Cloud Optimized GeoTIFF").timed("cog"):
                    convert_to_cog(raster, opts.resampling)
            prog.stage(0.95, 1.0, "writing tie points and report")
            vectors_tmp = out.temp(vectors)
            rep["exaggeration"] = write_vectors(vectors_tmp, gf, pts, dst, ref_px, crs, opts.exaggeration)
            if opts.local:
                local.write_shifts(vectors_tmp, layer="local_windows", append=True)
            rep["notes"] = notes(rep, dem is not None)
        rep["timings_s"] = {k: round(v, 4) for k, v in prog.timings.items()}
        rep["summary"] = summary_lines(rep)
        write_json(out.temp(report), rep)
        prog(1.0, "done")
        out.commit()
    return Registration(output, vectors, report, gf.model, rep, gf.georeference)



def _open_inputs(opts, reference, target, dem, camera):
    """Both rasters opened and checked (bands in range, a georeferenced reference), the output CRS by its rule
    and the camera read: ``(ref, tgt, crs, crs_rule, camera)``, every refusal before any heavy work."""
    ref = open_raster(reference, "reference")
    tgt = open_raster(target, "target")
    for info, role in ((ref, "reference"), (tgt, "target")):
        select_bands(getattr(opts, f"{role}_bands"), info.count, role)  # out of range: refused before any work
    if not ref.georeferenced:
        raise InputError(f"reference {str(reference)!r} has no georeference (CRS and geotransform); "
                         f"register against a georeferenced orthophoto, or georeference it first")
    centre = pixel_to_map(ref.transform, [[ref.width / 2, ref.height / 2]])
    crs, crs_rule = choose_output_crs(opts.dst_crs, ref.crs, centre)
    require_projected(crs, "output CRS", tuple(to_lonlat(ref.crs, centre)[0]))
    if dem is not None and camera is not None:
        from ...io.camera import load_camera
        camera = load_camera(camera)
        check_camera_size(camera, tgt.width, tgt.height, target)
    return ref, tgt, crs, crs_rule, camera


def _north_up(ref, crs) -> bool:
    """Whether the output CRS is the reference's and the reference grid is north-up (no rotation)."""
    t = ref.transform
    return ref.crs == crs and t.b == 0 and t.d == 0 and t.a > 0 and t.e < 0


def _reference_step(ref, crs) -> float | None:
    """The reference's own pixel size as the default resolution, when the output grid can be
    aligned with it (same CRS, north-up, square pixels); None otherwise."""
    t = ref.transform
    return float(t.a) if _north_up(ref, crs) and math.isclose(t.a, -t.e, rel_tol=1e-9) else None


def aligned_grid(transform, width: int, height: int, res: float, ref, crs):
    """The output grid ``(transform, width, height)`` of pixel size ``res`` covering the given
    one, moved onto the reference's pixel grid; and whether it is aligned (the 4th value).

    When the output CRS is the reference's and the reference is north-up, the grid's origin
    (top-left corner) is put on a corner of a reference pixel — a whole number of reference
    pixels from the reference's origin — and the grid grows right and down to cover the
    footprint. With the default resolution (the reference's pixel size) or any whole multiple
    of it, every output pixel is then exactly a reference pixel or a block of them: the output
    overlays the reference without resampling (``aligned`` True). With another resolution only
    the origin is aligned (``aligned`` False). In another CRS, or under a rotated reference,
    the grid is the footprint's, its edges on multiples of ``res`` (``gdalwarp -tap``),
    unchanged (``aligned`` False).
    """
    from affine import Affine
    if not _north_up(ref, crs):
        return transform, width, height, False
    t = ref.transform
    a, e = t.a, -t.e
    x_min, y_max = transform.c, transform.f
    x_max, y_min = x_min + width * res, y_max - height * res
    x0 = t.c + math.floor((x_min - t.c) / a + 1e-9) * a
    y1 = t.f - math.floor((t.f - y_max) / e + 1e-9) * e
    w = int(math.ceil((x_max - x0) / res - 1e-9))
    h = int(math.ceil((y1 - y_min) / res - 1e-9))
    whole = all(round(res / step) >= 1 and abs(res / step - round(res / step)) < 1e-9 for step in (a, e))
    return Affine(res, 0, x0, 0, -res, y1), w, h, bool(whole)


def _fitter(opts, ref, ref_px, tgt, crs, res, dem, camera, prog):
    """``fit(tie points) -> (tie points used, their output-CRS positions, GeoFit)``: the 2-D or terrain model."""
    def fit(pts):
        if pts.usable is not None:  # LSM: the fit takes the converged points
            pts = pts.subset(pts.usable)
        dst = transform_points(ref.crs, crs, pixel_to_map(ref.transform, pts.ref_xy))
        stage = prog.stage(0.55, 0.6, "fitting the model")
        with stage.timed("fit"):
            gf = (_planar(opts, pts.src, dst, ref_px, tgt, crs, res, pts.sigma_px) if dem is None else
                  _terrain(opts, pts.src, dst, ref_px, tgt, crs, res, dem, camera, stage))
        return pts, dst, gf
    return fit


def _measure_local(reference, tgt, gf, crs, out, field, opts, prog):
    """The local field (:func:`~fotogeo.tools.register.local.local_correction`) measured on the target
    registered by ``gf`` with cubic resampling into a temporary raster (removed again)."""
    field_tmp = out.temp(field)
    measured = field_tmp.with_suffix(".registered.tif")  # a private name beside the outputs
    try:
        warp_to_grid(tgt.path, measured, gf.georeference.map_to_pixel, crs=crs, transform=gf.transform,
                     width=gf.width, height=gf.height, resampling="cubic", block=gf.block,
                     src_nodata=opts.target_nodata, progress=prog.stage(0.0, 0.3, "registering for the local field"),
                     overviews=False)
        run = local_correction(reference, measured, None, field_tmp, opts, prog.stage(0.3, 1.0, "local field"))
    finally:
        measured.unlink(missing_ok=True)
    for key in ("reference", "target", "output"):  # temporary paths; the report names the outputs
        run.report.pop(key, None)
    run.report["field"] = str(field)
    return run


def composed_map(gf, field):
    """Output map XY → target pixels through the local field, then the model: the output pixel ``p``
    takes the registered image at ``p + D(p)`` (``corrected(p) = registered(p + D(p))``)."""
    def inverse_map(XY):
        p = map_to_pixel(gf.transform, XY)
        return gf.georeference.map_to_pixel(pixel_to_map(gf.transform, p + field.at(p)))
    return inverse_map


def _field_path(opts, output, field, inputs, overwrite):
    """The displacement field's path with ``local`` (default beside the output), checked; else None."""
    check_window(opts.local_window, "local_window")  # the area-based fallback uses it too
    if not opts.local:
        if field is not None:
            raise InputError("a displacement field (--field) is written only with --local")
        return None
    field = Path(field) if field else output.with_name(output.stem + "_field.tif")
    check_output(field, inputs, overwrite, "displacement field")
    return field


def _check_outputs(opts, reference, target, output, vectors, report, dem, overwrite):
    """The three output paths (vectors and report default beside ``output``), checked."""
    output = Path(output)
    vectors = Path(vectors) if vectors else output.with_suffix(".gpkg")
    report = Path(report) if report else output.with_suffix(".json")
    if len({output.resolve(), vectors.resolve(), report.resolve()}) < 3:
        raise InputError("output raster, vectors and report must be three different paths")
    if dem is None and opts.model not in (None, *PLANAR_MODELS):
        raise InputError(f"model {opts.model!r} is a terrain model: it needs a DEM (dem=, --dem)")
    if dem is not None and opts.model not in (None, *TERRAIN_MODELS):
        raise InputError(f"with a DEM the model must be one of {', '.join(TERRAIN_MODELS)}; got {opts.model!r}")
    for p, role in ((output, "output raster"), (vectors, "vector output"), (report, "report")):
        check_output(p, [reference, target, dem if isinstance(dem, (str, Path)) else None], overwrite, role)
    return output, vectors, report


def _band_text(value, option: str) -> str | None:
    """A ``*_bands`` option as the report shows it (``"1,2,3"``); its syntax checked."""
    numbers = band_numbers(value, option)
    return None if numbers is None else ",".join(map(str, numbers))


@dataclass(frozen=True)
class GeoFit:
    """A fitted registration, 2-D or terrain-aware, in the form the outputs need."""

    georeference: Georeference  # target pixels <-> output map XY
    role: np.ndarray  # (N,) control / check / outlier (/ no_height)
    residual_m: np.ndarray  # (N, 2) model position − reference position, output CRS units
    z: np.ndarray | None  # (N,) tie point heights (terrain-aware only)
    transform: object
    width: int
    height: int
    block: int
    details: dict  # model-specific report entries

    @property
    def model(self):
        return self.georeference.model

    @property
    def inliers(self):
        return np.isin(self.role, ("control", "check"))


def _block(res, gsd):
    """Output window size keeping the source window read per block near 512² pixels."""
    gsd = gsd if np.isfinite(gsd) else res
    return int(min(1024, max(64, 512 / max(1.0, res / max(gsd, 1e-12)))))


def _unfolded(width: int, height: int):
    """RANSAC validity of a target pixel -> map homography: it must not fold the target image."""
    edge = outline(width, height, 65)
    return lambda model: not model.folds(edge)


def _planar(opts, src, dst, ref_px, tgt, crs, res, sigma_px=None) -> GeoFit:
    fit, weights = fit_points(get_model(opts.model or "projective"), src, dst,
                              None if sigma_px is None else sigma_px * ref_px, threshold=opts.ransac_threshold * ref_px,
                              min_sigma=ref_px, check_fraction=opts.check_fraction, rng=opts.seed,
                              is_valid=_unfolded(tgt.width, tgt.height),
                              precise=sigma_px is not None and bool(np.isfinite(sigma_px).all()),
                              unit=f"m = --ransac-threshold {opts.ransac_threshold:g} reference px")
    geo = Georeference(fit.model, crs=crs, direction="image-to-ground")
    transform, width, height = output_grid(geo, tgt.width, tgt.height, res)
    details = {"ransac": {"inliers": fit.ransac_inliers, "trials": fit.ransac_trials,
                          "threshold_m": opts.ransac_threshold * ref_px},
               "robust_sigma_m": fit.sigma, "model_matrix": fit.model.world_matrix().tolist()}
    if weights:
        details["fit_weights"] = weights
    return GeoFit(geo, fit.role, fit.residual_xy, None, transform, width, height,
                  _block(res, geo.ground_sample_distance(tgt.width, tgt.height)), details)


def _terrain(opts, src, dst, ref_px, tgt, crs, res, dem, camera, prog=None) -> GeoFit:
    from ...geometry.dem import Dem, DemSampler
    from ...io.camera import load_camera
    from ...orientation.terrain import fit_terrain
    from ..orient.rectify import check_terrain_heights
    d = dem if isinstance(dem, Dem) else read_dem(dem)
    sampler = DemSampler(d, crs)
    z = sampler.heights(dst)
    n_h = int(np.isfinite(z).sum())
    if n_h < 12:
        raise InputError(f"the DEM {d.path!r} gives heights for only {n_h} of {len(z)} tie points: it must cover "
                         f"the overlap of the images (nodata holes are skipped)")
    fit = fit_terrain(src, np.column_stack([dst, z]), model=opts.model or "auto", camera=load_camera(camera),
                      threshold_m=opts.ransac_threshold * ref_px, min_sigma_m=ref_px,
                      check_fraction=opts.check_fraction, rng=opts.seed, is_valid=_unfolded(tgt.width, tgt.height),
                      progress=prog)
    geo = Georeference(fit.model, heights=sampler, crs=crs)
    check_terrain_heights(geo, tgt.width, tgt.height, z, f"the DEM {d.path!r}", "the tie points")
    XY = geo.footprint(tgt.width, tgt.height)
    if not np.isfinite(XY).any():
        raise ModelError("the target footprint does not meet the DEM under the fitted model; does the DEM cover it?")
    transform, width, height = grid_covering(XY[np.isfinite(XY).all(axis=1)], res)
    info = getattr(fit.model, "info", {})
    details = {"terrain": {"dem": str(d.path), "tie_points_without_height": int(len(z) - n_h),
                           "prefilter_inliers": fit.prefilter_inliers, "candidates": fit.candidates,
                           "chosen": fit.model.name, "chosen_because": fit.chosen_because, "compared": fit.compared,
                           "robust_sigma_px": fit.sigma_px,
                           "control_rmse_target_px": rmse(fit.residual_px[fit.role == "control"], None),
                           "check_rmse_target_px": rmse(fit.residual_px[fit.role == "check"], None),
                           "model_info": {k: v for k, v in info.items() if isinstance(v, (int, float, str, list, bool))}}}
    return GeoFit(geo, fit.role, fit.residual_m, z, transform, width, height,
                  _block(res, geo.ground_sample_distance(tgt.width, tgt.height)), details)
