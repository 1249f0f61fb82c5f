"""The registration tool: reference orthophoto + target image (paths) → georeferenced raster.

``register(reference, target, output)`` runs the pipeline of the source paper (Dihkan
2019) with fotogeo's additions:

1. read both images (decimated to ``max_match_pixels`` for matching), PCA band fusion;
2. keypoints + descriptors (SURF by default), SSD matching with the ratio test;
3. tie points: target pixels ↔ reference map coordinates, transformed into the output CRS
   (``"auto"`` = the UTM zone of the reference centre);
4. RANSAC + robust refit of the model (projective by default), check points held out;
5. window-by-window resampling of every band of the target onto the output grid;
6. outputs written atomically: ``OUT.tif``, ``OUT.gpkg`` (layers ``tie_points`` and
   ``error_vectors``) and ``OUT.json`` (the report).
"""
from __future__ import annotations

import platform
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..crs import pixel_size_in, require_projected, resolve_crs, to_lonlat, transform_points
from ..errors import InputError, MatchingError, ModelError
from ..geometry.georeference import Georeference
from ..io.raster import AtomicOutputs, check_output, open_raster, read_dem
from ..io.report import write_json
from ..io.vector import error_vectors, write_layers
from ..io.warp import grid_covering, warp_to_grid
from ..models import get_model
from ..models.robust import fit_tie_points
from ..models.stats import residual_stats, rmse
from ..options import PLANAR_MODELS, RegisterOptions  # declared in the option table
from ..orientation.terrain import TERRAIN_MODELS
from ..pixels import outline, pixel_to_map
from ..progress import as_progress
from .checks import check_camera_size, check_output_grid
from .match import HINT, find_tie_points
from .boundary import tool


@dataclass(frozen=True)
class Registration:
    """What :func:`register` produced: paths, the fitted model and the report dict."""

    output: Path
    vectors: Path
    report_path: Path
    model: object
    report: dict = field(repr=False)
    georeference: Georeference | None = field(default=None, repr=False)  # target pixels <-> output map


def _versions() -> dict:
    import cv2
    import pyproj
    import rasterio
    return {"fotogeo": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "opencv": cv2.__version__, "rasterio": rasterio.__version__, "gdal": rasterio.__gdal_version__,
            "pyproj": pyproj.__version__}


def output_grid(geo, width: int, height: int, res: float):
    """Output transform, width and height covering the target footprint under a planar ``geo``
    (a model that folds the image or maps it to a sliver of its bounding box is refused; the
    grid's size is checked by :func:`~fotogeo.tools.checks.check_output_grid`)."""
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
def register(reference, target, output, *, vectors=None, report=None, overwrite: bool = False,
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
    """
    opts = options or RegisterOptions(**kwargs)
    if options is not None and kwargs:
        raise InputError("give either options= or keyword options, not both")
    opts.validate()
    prog = as_progress(progress).with_own_timings()
    output, vectors, report = _check_outputs(opts, reference, target, output, vectors, report, dem, overwrite)
    ref = open_raster(reference, "reference")
    tgt = open_raster(target, "target")
    if not ref.georeferenced:
        raise InputError(f"reference {str(reference)!r} has no georeference (CRS and geotransform); "
                         f"register against a georeferenced orthophoto, or georeference it first")
    centre = pixel_to_map(ref.transform, [[ref.width / 2, ref.height / 2]])
    crs = require_projected(resolve_crs(opts.dst_crs, ref.crs, centre), "output CRS",
                            tuple(to_lonlat(ref.crs, centre)[0]))
    if dem is not None and camera is not None:
        from ..io.camera import load_camera
        camera = load_camera(camera)
        check_camera_size(camera, tgt.width, tgt.height, target)
    with AtomicOutputs(overwrite) as out:
        with prog.timed("total"):
            ref_px = pixel_size_in(ref.transform, ref.crs, crs, ref.width / 2, ref.height / 2)
            res = opts.resolution or ref_px
            src, ref_xy, counts = _tie_points(opts, ref, tgt, prog, tie_points)
            dst = transform_points(ref.crs, crs, pixel_to_map(ref.transform, ref_xy))
            with prog.stage(0.55, 0.6, "fitting the model").timed("fit"):
                try:
                    gf = (_planar(opts, src, dst, ref_px, tgt, crs, res) if dem is None else
                          _terrain(opts, src, dst, ref_px, tgt, crs, res, dem, camera))
                except MatchingError as e:
                    raise MatchingError(f"{e} — registering {str(target)!r} to {str(reference)!r}; {HINT}") from None
            check_output_grid(output, gf.width, gf.height, bands=tgt.count, dtype=tgt.dtype,
                              source_pixels=tgt.width * tgt.height, resolution=res,
                              what=f"the registered raster {str(output)!r}")
            rep = _report(opts, ref, tgt, crs, ref_px, res, counts, gf)
            stage = prog.stage(0.6, 0.95, "resampling")
            with stage.timed("resample"):
                written = warp_to_grid(tgt.path, out.temp(output), gf.georeference.map_to_pixel, crs=crs,
                                       transform=gf.transform, width=gf.width, height=gf.height,
                                       resampling=opts.resampling, block=gf.block, src_nodata=opts.target_nodata,
                                       progress=stage)
                rep["output_grid"].update(written)
            prog.stage(0.95, 1.0, "writing tie points and report")
            _write_vectors(out.temp(vectors), gf, src, dst, ref_xy, ref_px, crs, opts.exaggeration)
        rep["timings_s"] = {k: round(v, 4) for k, v in prog.timings.items()}
        write_json(out.temp(report), rep)
        prog(1.0, "done")
        out.commit()
    return Registration(output, vectors, report, gf.model, rep, gf.georeference)


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


def _tie_points(opts, ref, tgt, prog, tie_points):
    """Matched (target pixels, reference pixels, counts), or the ``tie_points`` given."""
    if tie_points is None:
        return find_tie_points(ref, tgt, opts, prog.stage(0.0, 0.55, "matching"))
    src, ref_xy = (np.asarray(a, float).reshape(-1, 2) for a in tie_points)
    if len(src) != len(ref_xy):
        raise InputError("tie_points must be two (N, 2) arrays of equal length: target and reference pixels")
    counts = {"keypoints": {"reference": None, "target": None}, "matches": len(src),
              "pca_explained_variance": None, "tie_points_given": True}
    return src, ref_xy, counts


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


def _planar(opts, src, dst, ref_px, tgt, crs, res) -> GeoFit:
    fit = fit_tie_points(get_model(opts.model or "projective"), src, dst, threshold=opts.ransac_threshold * ref_px,
                         min_sigma=ref_px, check_fraction=opts.check_fraction, rng=opts.seed,
                         is_valid=_unfolded(tgt.width, tgt.height))
    geo = Georeference(fit.model, crs=crs, direction="image-to-ground")
    transform, width, height = output_grid(geo, tgt.width, tgt.height, res)
    details = {"ransac": {"inliers": fit.ransac_inliers, "trials": fit.ransac_trials,
                          "threshold_m": opts.ransac_threshold * ref_px},
               "robust_sigma_m": fit.sigma, "model_matrix": fit.model.world_matrix().tolist()}
    return GeoFit(geo, fit.role, fit.residual_xy, None, transform, width, height,
                  _block(res, geo.ground_sample_distance(tgt.width, tgt.height)), details)


def _terrain(opts, src, dst, ref_px, tgt, crs, res, dem, camera) -> GeoFit:
    from ..geometry.dem import Dem, DemSampler
    from ..io.camera import load_camera
    from ..orientation.terrain import fit_terrain
    d = dem if isinstance(dem, Dem) else read_dem(dem)
    sampler = DemSampler(d, crs)
    z = sampler.heights(dst)
    n_h = int(np.isfinite(z).sum())
    if n_h < 12:
        raise InputError(f"the DEM {d.path!r} gives heights for only {n_h} of {len(z)} tie points: it must cover "
                         f"the overlap of the images (nodata holes are skipped)")
    fit = fit_terrain(src, np.column_stack([dst, z]), model=opts.model or "auto", camera=load_camera(camera),
                      threshold_m=opts.ransac_threshold * ref_px, min_sigma_m=ref_px,
                      check_fraction=opts.check_fraction, rng=opts.seed, is_valid=_unfolded(tgt.width, tgt.height))
    geo = Georeference(fit.model, heights=sampler, crs=crs)
    XY = geo.footprint(tgt.width, tgt.height)
    if not np.isfinite(XY).any():
        raise ModelError("the target footprint does not meet the DEM under the fitted model; does the DEM cover it?")
    transform, width, height = grid_covering(XY[np.isfinite(XY).all(axis=1)], res)
    info = getattr(fit.model, "info", {})
    details = {"terrain": {"dem": str(d.path), "tie_points_without_height": int(len(z) - n_h),
                           "prefilter_inliers": fit.prefilter_inliers, "candidates": fit.candidates,
                           "chosen": fit.model.name, "chosen_because": fit.chosen_because,
                           "robust_sigma_px": fit.sigma_px,
                           "control_rmse_target_px": rmse(fit.residual_px[fit.role == "control"], None),
                           "check_rmse_target_px": rmse(fit.residual_px[fit.role == "check"], None),
                           "model_info": {k: v for k, v in info.items() if isinstance(v, (int, float, str, list, bool))}}}
    return GeoFit(geo, fit.role, fit.residual_m, z, transform, width, height,
                  _block(res, geo.ground_sample_distance(tgt.width, tgt.height)), details)


def _stats(resid: np.ndarray, px: float) -> dict:
    """Residual statistics of one role in output CRS units (m) and reference pixels (px)."""
    s = residual_stats(resid)
    if s["n"] == 0:
        return s
    return {"n": s["n"], "rmse_m": s["rms_xy"], "rmse_px": s["rms_xy"] / px, "rms_x_m": s["rms_x"],
            "rms_y_m": s["rms_y"], "median_m": s["median"], "max_m": s["max"]}


def _report(opts, ref, tgt, crs, ref_px, res, counts, gf):
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


def _write_vectors(path, fit, src, dst, ref_xy, ref_px, crs, exaggeration):
    import shapely
    keep = fit.inliers
    idx = np.flatnonzero(keep)
    d = fit.residual_m[keep]
    pts = dst[keep]
    length = np.hypot(d[:, 0], d[:, 1])
    common = {"id": idx.astype(np.int64), "role": fit.role[keep],
              "ref_x": pts[:, 0], "ref_y": pts[:, 1], "ref_col": ref_xy[keep, 0], "ref_row": ref_xy[keep, 1],
              "target_col": src[keep, 0], "target_row": src[keep, 1]}
    if fit.z is not None:
        common["z"] = fit.z[keep]
    layers = {
        "tie_points": {**common, "dx": d[:, 0], "dy": d[:, 1], "residual": length,
                       "residual_px": length / ref_px, "geometry": shapely.points(pts)},
        "error_vectors": {"id": common["id"], "role": common["role"], "dx": d[:, 0], "dy": d[:, 1],
                          "length": length, "exaggeration": np.full(len(idx), float(exaggeration)),
                          "geometry": error_vectors(pts, pts + d, exaggeration)},
    }
    write_layers(path, layers, crs.to_wkt())
