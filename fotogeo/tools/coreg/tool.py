"""The co-registration tool: reference + target (paths) → the target corrected on its own grid.

Area-based co-registration for multi-temporal and multi-sensor pairs of one area, where
feature matching fails (seasonal change, clouds, other sensors): a grid of windows over the
overlap, phase correlation and least-squares matching on a radiometry-robust representation,
outliers rejected against a global model and the neighbours, then a smooth displacement
field (global model + thin-plate spline), refined in passes on the deformed target
(:mod:`fotogeo.coreg`). Like AROSICS' ``COREG_LOCAL`` (Scheffler et al. 2017) the output is
the target resampled in its own grid: ``corrected(p) = target(p + D(p))``.

The reference may have another CRS or pixel size: it is read on the target's grid window by
window (:mod:`fotogeo.tools.coreg.files`). Memory is bounded by a strip of windows and a block of
the output, never by the image. Too few reliable windows are refused with one line saying
how many windows were valid and what to try: never a wild field.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...coreg.grid import window_grid
from ...coreg.pipeline import CoregOptions, Coregistration, coregister_strips, status_counts
from ...crs import transform_points
from ...errors import InputError, MatchingError, RasterError
from ...io.report import write_json
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, gdal_env, open_raster
from ...io.warp import default_nodata
from ...options.coreg import COREG
from ...pixels import map_to_pixel, outline, pixel_to_map
from ...progress import as_progress
from ..common.boundary import OUTPUTS, tool
from .files import RasterStrips, write_corrected, write_field, write_shifts

NOTES = {
    "shift": "window shift (dx, dy) in target pixels: target = reference + shift at the window's information "
             "centroid (corner convention)",
    "before": "the shifts of the reliable windows measured on the uncorrected target (pass 1): the "
              "misregistration; CE90 = 90th percentile of the shift length",
    "after": "the reliable windows' measured shifts minus the final field at their positions (px): what the "
             "field leaves; last_pass = shifts measured on the target corrected by the previous pass's field",
    "field": "corrected(p) = target(p + D(p)), D = global model - p + thin-plate spline (target px)",
    "windows": "total = grid windows in the overlap; valid = passed phase correlation, LSM and checks in the "
               "last pass; reliable = valid and not rejected as outliers (used by the field)",
}


def shift_stats(v) -> dict:
    """``n``, mean dx/dy, median, RMS, CE90 (90th percentile) and max of the lengths of ``v`` (N, 2), px."""
    v = np.asarray(v, dtype=np.float64).reshape(-1, 2)
    v = v[np.isfinite(v).all(axis=1)]
    if not len(v):
        return {"n": 0}
    r = np.hypot(v[:, 0], v[:, 1])
    return {"n": int(len(v)), "mean_dx": float(v[:, 0].mean()), "mean_dy": float(v[:, 1].mean()),
            "median": float(np.median(r)), "rms": float(np.sqrt((r ** 2).mean())),
            "ce90": float(np.percentile(r, 90)), "max": float(r.max())}


def overlap_box(strips: RasterStrips):
    """The box ``(col0, row0, col1, row1)`` of target pixels the reference covers (or None)."""
    ref, tgt = strips.ref, strips.tgt
    XY = pixel_to_map(ref.transform, outline(ref.width, ref.height))
    if ref.crs != tgt.crs:
        XY = transform_points(ref.crs, tgt.crs, XY)
    px = map_to_pixel(tgt.transform, XY)
    px = px[np.isfinite(px).all(axis=1)]
    if not len(px):
        return None
    c0, r0 = np.maximum(px.min(axis=0), 0)
    c1, r1 = np.minimum(px.max(axis=0), [tgt.width, tgt.height])
    return (float(c0), float(r0), float(c1), float(r1)) if c1 > c0 and r1 > r0 else None


def _options(values: dict) -> CoregOptions:
    names = set(CoregOptions.__dataclass_fields__)
    return CoregOptions(**{k: v for k, v in values.items() if k in names}, workers=int(values["threads"]))


def _grid(strips: RasterStrips, opts: CoregOptions, reference, target, window_option=None):
    box = overlap_box(strips)
    grid = window_grid(box, opts.grid_spacing, opts.window) if box else None
    if grid is None or not len(grid):
        raise MatchingError(f"reference {str(reference)!r} and target {str(target)!r} do not overlap: 0 valid windows "
                            f"of 0; check that both cover the same area (CRS, georeference)")
    if window_option:
        check_window_fits(opts.window, box, window_option)
    return grid, box


def check_window_fits(window: int, box, name: str) -> None:
    """Refuse a matching window larger than the overlap ``box`` (target pixels) before any matching: such windows
    are mostly nodata and every one of them fails. ``name``: the option, named in the caller's words.

    >>> check_window_fits(512, (0, 0, 448.0, 600.0), "window")
    Traceback (most recent call last):
    ...
    fotogeo.errors.InputError: window 512 is larger than the overlap of reference and target (448 × 600 target pixels); use 448 or less (e.g. 256)
    """
    w, h = int(box[2] - box[0]), int(box[3] - box[1])
    side = min(w, h) - min(w, h) % 2
    if window > side:
        example = 2 ** int(np.log2(max(side, 2)))  # the largest power of two that fits
        raise InputError(f"{name} {window} is larger than the overlap of reference and target ({w} × {h} target "
                         f"pixels); use {side} or less" + (f" (e.g. {example})" if 16 <= example < side else ""),
                         option=name)


def _report(res: Coregistration, grid, box, opts: CoregOptions, strips: RasterStrips, paths: dict, timings) -> dict:
    ok = res.reliable
    after = res.windows.shift[ok] - res.field.at(res.windows.position[ok])
    first_ok = res.first.status == "ok"
    px = float(np.sqrt(abs(strips.tgt.transform.determinant)))
    rep = {**{k: (str(v) if v is not None else None) for k, v in paths.items()},
           "windows": {"total": len(grid), "valid": int(res.windows.ok.sum()), "reliable": int(ok.sum()),
                       "valid_first_pass": int(first_ok.sum()), "status": status_counts(res.filtered.status)},
           "grid": {"spacing": opts.grid_spacing, "window": opts.window, "rows": grid.shape[0],
                    "cols": grid.shape[1], "box": [float(b) for b in box]},
           "representation": opts.representation, "lsm_representation": opts.lsm_representation or opts.representation,
           "passes": res.passes, "smoothing": opts.smoothing,
           "global_model": res.field.model.to_dict(),
           "before": shift_stats(res.first.shift[first_ok & ok]), "after": shift_stats(after),
           "pixel_size": px,
           "reference_resampling": "none (same grid)" if strips.offset is not None else strips.resampling.name,
           "timings_s": {k: round(v, 3) for k, v in timings.items()}, "notes": NOTES}
    rep["after_map_units"] = {k: (v * px if k not in ("n",) else v) for k, v in rep["after"].items()}
    if res.passes > 1:
        rep["after"]["last_pass"] = shift_stats(res.delta[ok])
    return rep


@dataclass
class CoregRun:
    """One co-registration run: its report and what the windows layer is written from."""

    report: dict
    result: Coregistration
    crs: object
    transform: object

    def write_shifts(self, path, layer: str = "windows", append: bool = False) -> None:
        """The windows as a point layer ``layer`` of the GeoPackage ``path`` (added to it with ``append``)."""
        res = self.result
        resid = res.windows.shift - res.field.at(res.windows.position)
        write_shifts(path, res.windows, res.filtered.status, resid, self.crs, self.transform, layer=layer,
                     append=append)


def run_coregistration(reference, target, opts: CoregOptions, *, output=None, field=None, resampling="cubic",
                       reference_band=1, target_band=1, reference_nodata=None, target_nodata=None,
                       progress=None, window_option: str | None = None) -> CoregRun:
    """Match the windows and fit the field; write ``output`` (the corrected target) and ``field``
    to the paths given, as they are (the caller makes them atomic). The core of :func:`coregister`
    and of ``register(local=True)``. ``window_option``: the option that set the window size, when it is the
    user's: a window larger than the overlap is then refused up front, naming it."""
    prog = as_progress(progress)
    t0 = time.perf_counter()
    with gdal_env(), RasterStrips(reference, target, reference_band=reference_band, target_band=target_band,
                                  reference_nodata=reference_nodata, target_nodata=target_nodata) as strips:
        grid, box = _grid(strips, opts, reference, target, window_option)
        H, W = strips.shape
        res = coregister_strips(grid, strips, W, H, opts, progress=prog.stage(0.0, 0.85, "matching windows"))
        timings = {"matching": time.perf_counter() - t0, **res.timings}
        t1 = time.perf_counter()
        if output is not None:
            nodata = default_nodata(strips.tgt_nodata, strips.tgt.dtypes[0])
            write_corrected(strips, res.field, output, resampling=resampling, nodata=nodata,
                            progress=prog.stage(0.85, 0.98, "writing the corrected target"))
        if field is not None:
            write_field(field, res.field, strips.tgt.crs, strips.tgt.transform)
        timings["writing"] = time.perf_counter() - t1
        timings["total"] = time.perf_counter() - t0
        paths = {"reference": reference, "target": target, "output": output, "field": field}
        report = _report(res, grid, box, opts, strips, {k: (Path(v) if v else None) for k, v in paths.items()},
                         timings)
        return CoregRun(report, res, strips.tgt.crs, strips.tgt.transform)


def coreg_options(**values) -> CoregOptions:
    """The method's settings from option values by name (missing ones: the table's defaults)."""
    return _options({**{name: o.default for name, o in COREG.items()}, **values})


@tool(COREG, rasters={"reference": "reference_nodata", "target": "target_nodata"},
      outputs=OUTPUTS + ("shifts", "field"))
def coregister(reference, target, output=None, *, grid_spacing: int = 64, window: int = 128,
               representation: str = "orientation", lsm_representation: str | None = None,
               smoothing: float = 1.0, iterations: int = 2,
               model: str = "affine", ransac_threshold: float = 3.0, max_shift: float = 5.0,
               min_peak_ratio: float = 1.5, min_correlation: float = 0.2, min_windows: int = 10,
               reference_band: int = 1, target_band: int = 1, reference_nodata=None, target_nodata=None,
               resampling: str = "cubic", field_step: int = 16, seed: int = 0, threads: int = 1,
               shifts=None, field=None, report=None, overwrite: bool = False, progress=None) -> dict:
    """Co-register ``target`` to ``reference``; write the corrected target to ``output``.

    ``output`` (GeoTIFF, the target's grid, CRS, bands and data type; None: measure only),
    ``shifts`` (GeoPackage, layer ``windows``: one point per window with ``dx``, ``dy`` in
    target px, ``reliability``, ``status``, correlations, σ, residual), ``field`` (2-band
    float32 GeoTIFF of the displacement ``D`` in target px on a grid of ``field_step`` px),
    ``report`` (JSON: the returned report; its ``summary`` the command line's lines).
    Options: see :data:`~fotogeo.options.COREG` and :mod:`fotogeo.coreg`. Returns the report
    (dict). Raises :class:`~fotogeo.errors.MatchingError` when the images do not overlap or
    too few windows are reliable.
    """
    prog = as_progress(progress).with_own_timings()
    check_window(window, "window")
    outs = {"output": output, "shifts": shifts, "field": field, "report": report}
    for role, path in outs.items():
        if path is not None:
            check_output(path, [reference, target], overwrite, role)
    for role, path in (("reference", reference), ("target", target)):
        info = open_raster(path, role)
        if not info.georeferenced:
            raise RasterError(f"{role} {str(path)!r} has no georeference (CRS and geotransform); co-registration "
                              f"needs both images on the map")
    opts = _options(dict(locals()))
    with AtomicOutputs(overwrite) as atomic:
        run = run_coregistration(reference, target, opts, output=output and atomic.temp(output),
                                 field=field and atomic.temp(field), resampling=resampling,
                                 reference_band=reference_band, target_band=target_band,
                                 reference_nodata=reference_nodata, target_nodata=target_nodata, progress=prog,
                                 window_option="window")
        if shifts is not None:
            run.write_shifts(atomic.temp(shifts))
        rep = run.report
        rep.update({k: (str(v) if v is not None else None) for k, v in outs.items()})
        rep["summary"] = summary_lines(rep)
        if report is not None:
            write_json(atomic.temp(report), rep)
        atomic.commit()
    prog(1.0, "done")
    return rep


def summary_lines(rep: dict) -> list[str]:
    """The lines the command line prints after a co-registration (units named)."""
    w, b, a = rep["windows"], rep["before"], rep["after"]
    nan = float("nan")
    return [f"windows: {w['reliable']} reliable, {w['valid']} valid of {w['total']} ({w['status']})",
            f"shift before: median {b.get('median', nan):.3f} px, CE90 {b.get('ce90', nan):.3f} px; left by the "
            f"field: RMS {a.get('rms', nan):.3f} px, CE90 {a.get('ce90', nan):.3f} px "
            f"({a.get('rms', nan) * rep['pixel_size']:.3g} map units RMS)",
            f"global model {rep['global_model'].get('model', '?')}, {rep['passes']} passes, smoothing "
            f"{rep['smoothing']:g}; time {rep['timings_s'].get('total', nan):.1f} s"]


def check_window(window: int, name: str) -> None:
    """Window sides must be even: the window centres lie on pixel corners."""
    if window % 2:
        raise InputError(f"{name} must be an even number of pixels (the window centres lie on pixel corners); "
                         f"got {window}, use {window + 1}", option=name)
