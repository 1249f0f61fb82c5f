"""The interior-orientation tool: scanned film frames + a calibration report → pixel → photo transforms.

Per scan (:mod:`fotogeo.matching.fiducials`, :mod:`fotogeo.orientation.interior`):

1. the report's layout predicts each fiducial mark for each scan rotation in 90° steps (or the
   given one); NCC with the mark's template in each search region, LSM to sub-pixel; the rotation
   whose marks are found best is kept (a tie between rotations under which the layout maps onto
   itself is reported: the layout cannot tell them apart);
2. an affine fit of the marks found gives the small rotation and the scale; every mark is measured
   again at its predicted position with the template turned by that rotation;
3. the affine or projective pixel → photo transform, residuals per mark; fewer marks than
   ``min_fiducials`` or a residual above ``max_residual_px`` refuse the scan, naming the marks;
4. optionally the scan resampled to the standard frame with a pinhole camera YAML (what
   ``orient`` and ``triangulate`` read).

Several scans must share one scan pixel size (1 %): a mixed set is refused.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...io.calibration_report import read_calibration_report
from ...io.interior_json import interior_record
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, open_raster, read_decimated
from ...matching.fiducials import MarkShape, mark_template, measure_marks, predict
from ...options.interior import INTERIOR
from ...orientation.interior import fit_interior
from ...progress import as_progress
from ..common.boundary import tool
from .frame import write_standard_frame

#: relative spread of the scans' pixel sizes above which a set of scans is refused
MIXED_RESOLUTION = 0.01
#: the scan rotations tried, degrees (the report's layout turned by each, as --rotation gives them)
ROTATIONS = (0.0, 90.0, 180.0, 270.0)


@tool(INTERIOR)
def interior(scans, camera_report, output, *, model: str = "affine", scan_pixel_um=None, rotation: str = "auto",
             search_mm: float = 10.0, max_residual_px: float = 1.0, min_fiducials: int = 4, resample: bool = False,
             resample_pixel_um=None, overwrite: bool = False, progress=None) -> list[dict]:
    """Interior orientation of each scan (module docstring). ``output``: a JSON file for one scan, a folder
    for several (``<scan stem>.json`` each). Returns the JSON records."""
    prog = as_progress(progress)
    scans = [scans] if isinstance(scans, (str, Path)) else list(scans)
    if not scans:
        raise InputError("give at least one scan")
    report = read_calibration_report(camera_report)
    if min_fiducials > len(report.fiducials_mm):
        raise InputError(f"min_fiducials {min_fiducials} asks for more marks than the {len(report.fiducials_mm)} of "
                         f"the camera report; give at most {len(report.fiducials_mm)}", option="min_fiducials")
    targets = _targets(scans, output, [camera_report, *scans], overwrite)
    results = []
    for k, scan in enumerate(scans):
        step = prog.stage(k / len(scans), (k + 1) / len(scans), Path(scan).name)
        results.append(orient_scan(scan, report, model=model, scan_pixel_um=scan_pixel_um, rotation=rotation,
                                   search_mm=search_mm, max_residual_px=max_residual_px,
                                   min_fiducials=min_fiducials, progress=step))
    _check_resolutions(results)
    with AtomicOutputs(overwrite) as out:
        for (rec, io, img), target in zip(results, targets):
            if resample:
                rec["standard_frame"] = write_standard_frame(out, target, rec["scan"], io, report, resample_pixel_um)
            Path(out.temp(target)).write_text(json.dumps(rec, indent=1, ensure_ascii=False))
        out.commit()
    return [r[0] for r in results]


def _targets(scans, output, inputs, overwrite) -> list[Path]:
    """The JSON path of each scan, checked before anything is read."""
    output = Path(output)
    if len(scans) == 1 and output.suffix.lower() == ".json":
        check_output(output, inputs, overwrite, "output")
        return [output]
    if output.exists() and not output.is_dir():
        raise InputError(f"output {str(output)!r} is a file; several scans need a folder (one JSON per scan)")
    if output.suffix.lower() == ".json" and not output.is_dir():  # not a folder named like a file
        raise InputError(f"output {str(output)!r} names a JSON file, but {len(scans)} scans need a folder (one "
                         "<scan>.json each); give a folder, or one scan per run")
    stems = [Path(s).stem for s in scans]
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise InputError(f"scans {', '.join(dup)} share a name; their JSON files would overwrite each other")
    output.mkdir(parents=True, exist_ok=True)
    return [check_output(output / f"{s}.json", inputs, overwrite, "output") for s in stems]


def scan_pixel_mm(scan, given_um) -> float:
    """The scan pixel size in mm: ``given_um``, else the TIFF resolution tags (pixels per inch or cm)."""
    if given_um:
        return float(given_um) / 1000.0
    import rasterio
    with rasterio.open(scan) as ds:
        tags = ds.tags()
    res, unit = tags.get("TIFFTAG_XRESOLUTION"), str(tags.get("TIFFTAG_RESOLUTIONUNIT", ""))
    try:
        per = float(res)
    except (TypeError, ValueError):
        per = 0.0
    if per > 1.0 and (unit.startswith("2") or unit.startswith("3")):
        return (25.4 if unit.startswith("2") else 10.0) / per
    raise InputError(f"scan {str(scan)!r} carries no resolution tags; give its pixel size: scan_pixel_um (e.g. 21 "
                     "for a 1200 dpi scan)", option="scan_pixel_um")


def _read_grey(scan) -> np.ndarray:
    info = open_raster(scan, "scan")
    bands, mask, _ = read_decimated(info, info.width * info.height, "scan")
    return np.where(mask, bands.astype(np.float32).mean(axis=0), np.nan)


def _templates(report, shape, mm, theta, polarity):
    """Per mark the candidate templates at rotation ``theta`` (both polarities for ``auto``)."""
    out = []
    for x, y in mm:
        q = (-np.sign(x - mm[:, 0].mean()) or 1.0, np.sign(y - mm[:, 1].mean()) or 1.0)
        ts = [mark_template(shape, theta, q, bright=b) for b in ((True, False) if polarity == "auto"
                                                                 else (polarity == "bright",))]
        out.append(ts)
    return out


def orient_scan(scan, report, *, model="affine", scan_pixel_um=None, rotation="auto", search_mm=10.0,
                max_residual_px=1.0, min_fiducials=4, progress=None):
    """``(record, InteriorOrientation, grey image)`` of one scan (module docstring, steps 1–3)."""
    prog = as_progress(progress)
    p = scan_pixel_mm(scan, scan_pixel_um)
    img = _read_grey(scan)
    ids = list(report.fiducials_mm)
    mm = np.array([report.fiducials_mm[i] for i in ids], float)
    shape = MarkShape(report.mark, report.mark_size_mm / p, report.mark_width_mm / p)
    warnings = []
    reach = max(3, int(round(search_mm / p)))
    tried = []  # the four rotations measured once: the choice, the given one's check and the mirror test use them
    for th in ROTATIONS:
        tried.append(_hypothesis(img, report, shape, mm, p, th, reach))
        prog(len(tried) / 5.0, f"rotation {th:g}°: {tried[-1][0]} marks")
    tried.sort(key=lambda t: (-t[0], -t[1], t[2]))
    chosen = tried[0] if rotation == "auto" else next(t for t in tried if t[2] == float(rotation) % 360.0)
    n, rho, theta, res = chosen
    others = [t for t in tried if t is not chosen]
    if rotation != "auto":
        _check_given_rotation(scan, chosen, others, len(ids))
    if n < len(ids):
        _check_not_mirrored(scan, img, report, shape, mm, p, ROTATIONS, reach, n)
    # a rotation as good (auto: as many marks, NCC within 0.01) or, given, clearly better (NCC 0.01 above)
    alike = [t for t in others if t[0] == n and (t[1] > rho + 0.01 if rotation != "auto" else abs(t[1] - rho) < 0.01)]
    if alike and n:
        warnings.append(_ambiguous(theta, alike, n, rho, given=rotation != "auto"))
    found = [k for k, r in enumerate(res) if r.ok]
    if len(found) >= 3:  # refine: templates turned by the fitted rotation, search at the predicted marks
        io0 = fit_interior([ids[k] for k in found], np.array([res[k].xy for k in found]), mm[found], "affine")
        fine = MarkShape(report.mark, report.mark_size_mm / io0.pixel_size_mm, report.mark_width_mm / io0.pixel_size_mm)
        reach = int(np.ceil(3 + 2 * io0.residual_lengths.max()))  # a mark off the layout is still found, and named
        res = measure_marks(img, io0.to_pixel(mm), _templates(report, fine, mm, io0.rotation_deg, report.polarity),
                            reach, report.mark)
    marks = {ids[k]: r for k, r in enumerate(res)}
    missing = {i: r.status for i, r in marks.items() if not r.ok}
    _check_found(scan, model, marks, missing, min_fiducials)
    if missing:
        warnings.append(f"fiducial mark(s) not found: {', '.join(f'{i} ({s})' for i, s in missing.items())}")
    use = [i for i in ids if i not in missing]
    io = fit_interior(use, np.array([marks[i].xy for i in use]), np.array([report.fiducials_mm[i] for i in use]),
                      model)
    _check_residuals(scan, io, max_residual_px)
    if abs(io.pixel_size_mm / p - 1) > 0.01:
        warnings.append(f"the marks give a scan pixel of {io.pixel_size_mm * 1000:.2f} µm, {io.pixel_size_mm / p - 1:+.1%} "
                        f"from the {p * 1000:g} µm given: check the scan resolution and that the report is this camera's")
    prog(1.0, f"{len(use)} marks, RMS {io.rms_px:.3f} px")
    return interior_record(scan, report, io, marks, missing, warnings), io, img


def _hypothesis(img, report, shape, mm, p, theta, reach):
    """``(marks found, their mean NCC, theta, results)`` of the marks measured where the layout ``mm`` puts them
    on a scan turned by ``theta``."""
    res = measure_marks(img, predict(mm, p, (img.shape[1], img.shape[0]), theta),
                        _templates(report, shape, mm, theta, report.polarity), reach, report.mark)
    ok = [r.ok for r in res]
    return sum(ok), float(np.mean([r.ncc for r in res if r.ok])) if any(ok) else 0.0, theta, res


def _check_given_rotation(scan, given, others, n_marks: int) -> None:
    """Refuse a given rotation that the marks contradict: turned by another multiple of 90° the layout finds more
    marks (the transform fitted at the given one would turn every photo coordinate by a multiple of 90°, with
    only a "mark not found" note). Under as many marks with a clearly better match (mean NCC 0.01 above, the
    threshold of an automatic tie) the given rotation is kept with a warning (:func:`_ambiguous`)."""
    n, _, theta, _ = given
    best = max(others, key=lambda t: (t[0], t[1]))
    if best[0] > n:
        raise InputError(f"rotation {theta:g}° contradicts the fiducial marks of scan {str(scan)!r}: turned by "
                         f"{best[2]:g}° the report's layout finds {best[0]} of {n_marks} marks, at {theta:g}° "
                         f"{n}; give {best[2]:g} (or auto)", option="rotation")


def _ambiguous(theta, alike, n, rho, given: bool) -> str:
    """The one warning of a rotation the marks cannot tell: the ``alike`` hypotheses find as many marks ``n`` as
    the rotation kept, ``theta`` (mean NCC ``rho``)."""
    turned = ", ".join(f"{t[2]:g}° (NCC {t[1]:.2f})" for t in alike)
    return (f"rotation ambiguous: turned by {turned} the layout finds as many marks ({n}) as at {theta:g}° "
            f"(NCC {rho:.2f}); {theta:g}° kept " + ("as given" if given else "(give rotation / --rotation)"))


def _check_not_mirrored(scan, img, report, shape, mm, p, thetas, reach, n):
    """Refuse a mirror-image scan (film scanned through its base): the layout flipped left-right finds more
    marks than the best unflipped rotation's ``n``. A layout symmetric under the flip cannot tell it from a
    rotation, and the transform fitted to a mirrored scan's marks under a rotation would mirror every photo
    coordinate, so such a scan is refused rather than fitted."""
    flipped = mm * np.array([-1.0, 1.0])
    m = max(_hypothesis(img, report, shape, flipped, p, th, reach)[0] for th in thetas)
    if m > n:
        raise InputError(f"scan {str(scan)!r} is a mirror image (film scanned through its base?): the "
                         f"report's layout flipped left-right finds {m} of {len(mm)} fiducial marks, unflipped {n}; "
                         "flip the scan left-right (an image editor's 'flip horizontal') and run again")


def _check_found(scan, model, marks, missing, min_fiducials):
    need = max(min_fiducials, 3 if model == "affine" else 4)
    if len(marks) - len(missing) >= need:
        return
    found = [i for i in marks if i not in missing]
    raise InputError(f"scan {str(scan)!r}: {len(found)} of {len(marks)} fiducial marks found "
                     f"({', '.join(found) or 'none'}), at least {need} needed; not found: "
                     f"{', '.join(f'{i} ({s})' for i, s in missing.items())}. Check that the camera report matches "
                     "the scan (layout, mark type, scan pixel size) and that the marks are not cut off")


def _check_residuals(scan, io, max_residual_px):
    bad = np.flatnonzero(io.residual_lengths > max_residual_px)
    if bad.size:
        worst = ", ".join(f"{io.ids[k]} ({io.residual_lengths[k]:.2f} px)" for k in bad)
        raise InputError(f"scan {str(scan)!r}: fiducial mark(s) {worst} do not fit the camera report's layout "
                         f"({io.model} residual above max_residual_px = {max_residual_px:g}): a damaged mark or the "
                         "report of another camera; marks used: " + ", ".join(io.ids))


def _check_resolutions(results):
    sizes = {r[0]["scan"]: r[0]["scan_pixel_um"] for r in results}
    v = np.array(list(sizes.values()), float)
    if len(v) > 1 and (v.max() - v.min()) / np.median(v) > MIXED_RESOLUTION:
        raise InputError("the scans have different pixel sizes (" + ", ".join(
            f"{Path(s).name} {u:.2f} µm" for s, u in sizes.items()) + "); orient scans of one resolution together")
