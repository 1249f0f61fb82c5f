"""The triangulation tool: a block of frames oriented together by bundle adjustment (paths in, folder out).

``triangulate(frames, camera, eo, observations, folder, gcps=...)`` reads

* ``frames`` — the frame rasters (their names key everything else; their size must be the
  camera's);
* ``camera`` — the interior orientation YAML: pinhole, or orthority's ``brown`` with distortion
  (:func:`fotogeo.io.camera.read_camera_with_distortion`; the ``camera.yaml`` a self-calibrating
  run writes is a valid camera of the next run);
* ``eo`` — the approximate exterior orientation, ``name X Y Z omega phi kappa`` lines in the
  map CRS (metres, PATB degrees), e.g. from GNSS/INS; optional with control: a frame it lacks
  (or every frame, ``eo=None``) is resected against its ≥ 4 GCPs
  (:mod:`fotogeo.tools.triangulate.inputs`);
* ``observations`` — the image measurements of the tie points, a table ``frame, point, col,
  row[, sigma]`` (:func:`fotogeo.io.block.read_image_observations`); ``None``: the overlapping
  frames are matched (:mod:`fotogeo.tools.triangulate.match`: footprints at the mean GCP
  height, SURF on pyramid level 1, epipolar RANSAC, multi-ray tracks thinned to Gruber positions,
  LSM transfer at full resolution with each observation's σ; the pairs as Dask tasks with ``scheduler``
  or ``workers``, :mod:`fotogeo.tools.triangulate.pairs`);
* ``gcps`` — ground control: ODM/OpenSfM's ``gcp_list.txt`` (:func:`fotogeo.io.block.read_gcp_list`)
  or a point layer / CSV in any CRS, one row per (point, frame) measurement with ``id, frame,
  col, row, z[, role]`` (:func:`fotogeo.io.block.read_control_table`), transformed into the map
  CRS; check points: the ``role`` field, the names in ``check_points`` and a seeded spread
  hold-out of ``check_fraction`` of the control;
* ``reference`` (with ``dem``) — orthophoto(s) on which control is found automatically
  (:func:`fotogeo.tools.triangulate.control.automatic_control`), merged with ``gcps`` and weighted
  with ``reference_sigma_xy`` / ``reference_sigma_z``;

runs :func:`fotogeo.orientation.bundle.adjust_block` in the map CRS (projected, metric) and
writes into ``folder``, as one set (nothing on an error or a cancel;
:mod:`fotogeo.tools.triangulate.outputs`):

* ``exterior_orientation.txt`` — the adjusted orientations, in the input's format;
* ``camera.yaml`` — the interior orientation the adjustment used, adjusted with ``self_calibration``, else the
  given or EXIF/XMP camera (orthority's YAML, :func:`fotogeo.io.block.write_interior_orientation`), so that the
  folder alone orients the frames for ``dsm --orientation`` and ``ortho``;
* ``block.gpkg`` — layers ``tie_points`` (3-D, σ, rays), ``control`` (control and check points
  at their adjusted position, ``adjusted − given`` and role), ``frames`` (projection centres,
  angles, σ), ``residuals`` (every image observation at its ground point: frame, pixel, adjusted
  pixel, residual vector in px, status, standardised residual) and ``footprints`` (frame outlines on
  the DEM or the mean height, :mod:`fotogeo.tools.triangulate.ortho`);
* ``report.json`` — σ₀, image RMS, control/check RMSE per axis, interior parameters estimated,
  held fixed and why, blunders culled, image residuals sorted by size with the adjusted image
  coordinates, mean σX σY σZ per point type, matching statistics, the timings of every stage
  (:mod:`fotogeo.tools.triangulate.statistics`); ``report.html`` — the same with plots
  (:mod:`fotogeo.tools.triangulate.report`);
* with ``orthorectify``: ``<frame>_ortho.tif``, each frame on the DEM through its adjusted orientation;
* with ``mosaic`` (orthorectifies too): ``mosaic.tif`` and its seamlines ``mosaic.gpkg``, the orthophotos mosaicked
  by :func:`fotogeo.tools.ortho.mosaic.mosaic` (seamlines, balancing, feathering) on one pixel lattice (``resolution``,
  else the median GSD of the frames); written after the other outputs, so a failing mosaic is reported
  (``report.json`` ``mosaic.error``, a warning) and loses none of them; the orthophotos, their σ rasters and the
  mosaic compressed with ``compress`` (:mod:`fotogeo.io.compression`);
* with ``dsm`` (a path): the surface model of the adjusted frames, made as ``fotogeo dsm`` makes it
  (:mod:`fotogeo.tools.triangulate.surface`), written last in the same way (``report.json`` ``dsm``).
"""
from __future__ import annotations

import re
from contextlib import contextmanager
from functools import partial
from pathlib import Path

import numpy as np

from ...errors import InputError, ModelError, OutputError
from ...io.block import check_frame_names, frame_key, read_image_observations
from ...io.compression import check_compression
from ...io.output_checks import GEOTIFF_SUFFIXES, check_outputs
from ...io.qml import check_style, check_styles_no_input, dsm_style_path, warn_earlier_style
from ...orientation.bundle import CHECK_START, Block, BundleOptions
from ...progress import as_progress
from ..common.boundary import tool
from ...io.block import split_check_points
from .control import reference_sigmas
from .determinacy import adjust_determined
from .exif_focal import check_exif_focal, focal_hypotheses
from .inputs import add_automatic_control, check_fraction_for, orientations, read_block_control
from .outputs import CAMERA_FILE, FILES, output_paths, report, write_outputs
from .refusal import reporting_refusal
from .register import saying_none_registered
from .sources import block_start
from .surface import block_dsm

__all__ = ["CAMERA_FILE", "FILES", "triangulate"]


def _points(names, obs, gcp, check_ids, sigma_xy, sigma_z, image_sigma):
    """Merge tie points and GCPs into the Block's point and observation arrays."""
    index = {n: j for j, n in enumerate(names)}
    unknown = sorted(set(obs.frame) - set(index))
    if unknown:
        raise InputError(f"image observations name frame(s) not given: {', '.join(unknown[:10])}")
    ids, where = [], {}
    for p in list(obs.point) + list(gcp.name if gcp is not None else []):
        if p not in where:
            where[p] = len(ids)
            ids.append(p)
    P = len(ids)
    xyz, sig, role = np.full((P, 3), np.nan), np.full((P, 3), np.nan), np.full(P, "tie", dtype=object)
    f_obs = [index[f] for f in obs.frame]
    p_obs = [where[p] for p in obs.point]
    px = [obs.pixel]
    s_obs = [obs.sigma if obs.sigma is not None else np.full(len(obs.frame), image_sigma)]
    if gcp is not None:
        for k in range(len(gcp.name)):
            j = where[gcp.name[k]]
            xyz[j] = gcp.ground[k]
            role[j] = "check" if gcp.name[k] in check_ids else "control"
        f_obs += [index[f] for f in gcp.frame]
        p_obs += [where[n] for n in gcp.name]
        px.append(gcp.pixel)
        s_obs.append(np.full(len(gcp.name), image_sigma))
    sig[role == "control"] = [sigma_xy, sigma_xy, sigma_z]
    return (tuple(ids), xyz, sig, role.astype(str), np.array(f_obs, dtype=np.intp), np.array(p_obs, dtype=np.intp),
            np.concatenate(px), np.concatenate(s_obs))


def _matched(frames, names, cam, eos, height, start, match, prog):
    """Image observations (with LSM's σ) from matching the overlapping frames
    (:func:`fotogeo.tools.triangulate.match.matched_observations`); ``(obs, report, eos, height)``, the
    orientations and height measured on the images when ``start`` asks for them. The epipolar RANSAC sees
    the measured pixels, distortion included (why: :mod:`fotogeo.tools.triangulate.match`)."""
    from .match import matched_observations
    obs, rep = matched_observations(frames, names, cam, eos, height, start=start, progress=prog, **match)
    st = rep.get("start") or {}
    eos, height = st.pop("eos", eos), st.pop("height", height)
    return obs, rep, tuple(eos), height


def _dem_source(dem, crs, camera, eos):
    """The DEM ``dem`` (None: none given) as a height source in the map CRS ``crs``, read once for
    :func:`start_height` and :func:`_measure`: only its window under the frames ``eos``
    (:func:`~fotogeo.tools.triangulate.ortho.dem_near_frames`; a regional DEM is not read whole)."""
    if dem is None:
        return None
    from .ortho import dem_near_frames
    return dem_near_frames(dem, crs, camera, eos)


def _measure(start, height, source):
    """The start's ``measure`` callable (:meth:`~fotogeo.tools.triangulate.sources.BlockStart.measure`) with the
    DEM height ``source`` (:func:`_dem_source`; None: none) the level frames' attitudes are measured on
    (:func:`fotogeo.tools.triangulate.guided.measured_attitudes`: on a plane, the ground points of steep oblique
    rays over relief are metres off)."""
    measure = start.measure(height)
    if measure is not None and source is not None:
        measure.terrain = source
    return measure


def _match_options(detection_level, gruber_cells, points_per_region, lsm_window, scheduler=None,
                   workers=None) -> dict:
    """The tie-point matching settings of the option table as :func:`block_tie_points` arguments."""
    return {"level": detection_level, "cells": int(gruber_cells), "per_region": points_per_region or None,
            "half_window": int(lsm_window) // 2, "scheduler": scheduler or None, "workers": workers or None}


@contextmanager
def _saying_what_was_lost(lost: dict, camera_from_files: bool = False):
    """A refusal naming frames whose files' metadata could not be read says what was lost (their attitude…); so
    does any refusal of a run whose camera was read from those files (``camera_from_files``: no camera file), for
    every such frame, when it names none of them (an adjustment that did not converge)."""
    try:
        yield
    except (ModelError, InputError) as exc:
        named = [n for n in lost if n in exc.frames] if exc.frames else \
            [n for n in lost if re.search(rf"(?<![\w-]){re.escape(n)}(?![\w-])", str(exc))]
        if not named and camera_from_files:
            named = list(lost)
        if not named:
            raise
        said = _grouped({n: lost[n] for n in named})  # first: the cause before the symptom
        raise type(exc)(f"{said} (repair the files or give the attitude another way: --geoinfo, --eo); {exc}",
                        option=exc.option, frames=exc.frames, also=exc.also) from None


@contextmanager
def _naming_given_inputs(advice: str):
    """An adjustment that did not converge asks to check the inputs this run was given (``advice``), not a
    camera file or an orientation file it had none of."""
    try:
        yield
    except ModelError as exc:
        if CHECK_START not in str(exc):
            raise
        raise ModelError(str(exc).replace(CHECK_START, advice), option=exc.option, frames=exc.frames,
                         also=exc.also) from None


def _grouped(lost: dict) -> str:
    """``{frame: what was lost}`` said once per distinct reason, its frames named before it (the first 5)."""
    by = {}
    for n, why in lost.items():
        by.setdefault(why, []).append(n)
    return "; ".join(f"{', '.join(ns[:5])}{f' and {len(ns) - 5} more' if len(ns) > 5 else ''}: {why}"
                     for why, ns in by.items())


def _overlap_advice(eo, camera, gcp) -> str:
    """What to check when a frame's approximate footprint overlaps no other: the source the orientation came from."""
    if eo is not None:
        return f"check the orientation file (--eo {eo})"
    if camera is not None:
        return "check the camera (--camera) and the images' GPS and attitude" + (" or the GCPs" if gcp else "")
    return ("check the camera read from the images' EXIF/XMP (its focal length; or give --camera) and their GPS and "
            "attitude")


@tool("TRIANGULATE", outputs=("folder",))
def triangulate(frames, camera, eo, observations, folder, *, gcps=None, crs=None, gcp_crs=None, check_points=None,
                self_calibration=None, control_sigma_xy: float = 0.05, control_sigma_z: float = 0.05,
                image_sigma: float = 1.0, eo_sigma_position=None, eo_sigma_angle=None, eo_sigma_height=None,
                snooping: bool = True, max_correlation: float = 0.999, check_fraction=None, seed: int = 0,
                dem=None, orthorectify: bool = False, mosaic: bool = False, dsm=None, qgis_style: bool = True,
                resolution=None,
                uncertainty: bool = False, dem_sigma=None, compress: str = "deflate",
                resampling: str = "nearest", reference=None, reference_sigma_xy=None, reference_sigma_z=None, geoinfo=None,
                sfm_frame: str = "auto", undetermined: str = "drop", max_angle_sigma: float = 0.5, min_frame_points: int = 6,
                detection_level=None, gruber_cells: int = 3, points_per_region: int = 25, lsm_window: int = 21,
                scheduler=None, workers=None, overwrite: bool = False, progress=None) -> dict:
    """Adjust the block (module docstring); returns the report dict."""
    prog = as_progress(progress).with_own_timings()
    frames = [Path(f) for f in ([frames] if isinstance(frames, (str, Path)) else frames)]
    folder = Path(folder)
    check_frame_names(frames)
    inputs = [*frames, camera, eo, observations, gcps, dem, geoinfo, *_as_list(reference)]
    with _output_folder(folder):
        return _triangulate(frames, camera, eo, observations, folder, inputs, prog, locals())


def _triangulate(frames, camera, eo, observations, folder, inputs, prog, kw) -> dict:
    """The body of :func:`triangulate` once the output folder exists (``kw``: its keyword arguments)."""
    kw["compress"] = check_compression(kw["compress"])  # before anything is written
    finals = output_paths(folder, names=[frame_key(f) for f in frames],
                          orthorectify=kw["orthorectify"], mosaic=kw["mosaic"], uncertainty=kw["uncertainty"])
    style = dsm_style_path(kw["dsm"]) if kw["dsm"] and kw["qgis_style"] else None
    if style is not None:
        check_style(kw["dsm"], kw["overwrite"])
    dsm_files = [(kw["dsm"], "DSM", GEOTIFF_SUFFIXES), (style, "QGIS style of the DSM", None)]
    check_outputs([(p, "output", None) for p in finals.values()] + dsm_files, inputs, kw["overwrite"])
    if style is not None:
        check_styles_no_input(kw["dsm"], [*frames, kw["dem"], *_as_list(kw["reference"])])
    elif kw["dsm"]:  # after the outputs' checks, as dsm
        warn_earlier_style(kw["dsm"])
    with prog.timed("inputs"):
        start = block_start(frames, camera, eo, kw["gcps"], kw["crs"], kw["gcp_crs"], kw["reference"], kw["dem"],
                            kw["geoinfo"], kw["sfm_frame"])
    cam, distortion = start.camera, start.distortion
    with prog.timed("control"):
        frames, names, gcp, map_crs, eos, check_ids, auto, dropped = _control(frames, start, kw,
                                                                              prog.stage(0.0, 0.2, "control"))
    matching = None
    if observations is not None:
        with prog.timed("inputs"):
            obs = read_image_observations(observations)
    else:
        with prog.timed("matching"), saying_none_registered(start):
            needed = gcp is None or start.measure(0.0) is not None  # the DEM's mean height, or the level frames'
            src = _dem_source(kw["dem"], map_crs, cam, eos) if needed else None
            height = start_height(gcp, kw["dem"], map_crs, eos, cam, source=src)
            obs, matching, eos, height = _matched(
                frames, names, cam, eos, height, _measure(start, height, src),
                _match_options(kw["detection_level"], kw["gruber_cells"], kw["points_per_region"], kw["lsm_window"],
                               kw["scheduler"], kw["workers"]) | {"advice": _overlap_advice(eo, camera, gcp)},
                prog.stage(0.2, 0.5, "matching the frames"))
    ids, xyz, sig, role, f_obs, p_obs, px, s_obs = _points(names, obs, gcp, check_ids, kw["control_sigma_xy"],
                                                          kw["control_sigma_z"], kw["image_sigma"])
    automatic = np.isin(np.array(ids, dtype=object), list(auto)) & (role == "control")
    ref_sigma = (reference_sigmas(kw["reference"], kw["dem"], map_crs, kw["reference_sigma_xy"], kw["reference_sigma_z"])
                 if auto else (None, None))
    sig[automatic] = [ref_sigma[0], ref_sigma[0], ref_sigma[1]]
    block = Block(cam, tuple(names), eos, f_obs, p_obs, px, ids, xyz, sig, role, s_obs, distortion=distortion,
                  crs=map_crs)
    eo_sigma = start.eo_sigma(kw["eo_sigma_position"], kw["eo_sigma_height"], kw["eo_sigma_angle"])
    interior = start.interior_to_estimate(kw["self_calibration"], len(names))
    opts = BundleOptions(self_calibration=interior, eo_sigma=eo_sigma,
                         snooping=kw["snooping"], max_correlation=kw["max_correlation"])
    prog(0.5, "inputs read")
    refused = reporting_refusal(finals["json"], matching, names, {"frames": [str(f) for f in frames],
                                                                   "folder": str(folder)})
    given = _naming_given_inputs(_overlap_advice(eo, camera, gcp) + (", and the image observations (--observations)"
                                                                      if observations is not None else
                                                                      ", and the tie points"))
    final = {}  # the options of the block adjust_determined returns
    with refused, prog.timed("adjustment"), _saying_what_was_lost(start.lost, bool(start.camera_source)), given, \
            saying_none_registered(start):
        result, block, quality, undetermined, restarted = adjust_determined(block, opts, kw, prog.stage(
            0.5, 0.8, "bundle adjustment"), dropped_before=len(dropped),
            sigma_source=start.sigma_source(kw["eo_sigma_position"], kw["eo_sigma_height"]), final=final)
        check_exif_focal(start.camera_source, block.camera, result.stats, bool(kw["self_calibration"]), result.fixed,
                         refit=partial(focal_hypotheses, block, final["opts"]),
                         lens_modelled=bool(opts.self_calibration) or any(block.distortion))
    rep = report(result, block, map_crs, {"frames": [str(f) for f in frames], "camera": str(camera) if camera else None,
                                         "eo": str(eo) if eo else None, "gcps": str(kw["gcps"]) if kw["gcps"] else None,
                                         "observations": str(observations) if observations else None,
                                         "dem": str(kw["dem"]) if kw["dem"] else None, "folder": str(folder),
                                         "reference": [str(r) for r in _as_list(kw["reference"])] or None,
                                         "automatic_control": len(auto), "check_points": sorted(map(str, check_ids)),
                                         "automatic_control_sigma_m": {"xy": ref_sigma[0], "z": ref_sigma[1]},
                                         "matching": matching, "resected_frames": start.resected,
                                         "start": start.summary(), "frame_quality": quality.rows(),
                                         "dropped_frames": dropped + undetermined,
                                         "restarted_frames": restarted}, stages=dict(prog.timings))
    write_outputs(finals, result, block, [f for f in frames if frame_key(f) in block.frames], rep,
                  dem=kw["dem"], resolution=kw["resolution"], resampling=kw["resampling"],
                  overwrite=kw["overwrite"], progress=prog.stage(0.8, 1.0, "writing the outputs"), dem_sigma=kw["dem_sigma"],
                  compress=kw["compress"],
                  surface=None if kw["dsm"] is None else partial(block_dsm, kw["dsm"], finals, block.crs, kw["dem"],
                                                                 kw["overwrite"], qgis_style=kw["qgis_style"]))
    prog(1.0, "done")
    return rep


def _control(frames, start, kw, prog):
    """``(frames, names, control GcpList or None, map CRS, approximate orientations, check-point names, automatic
    control names, frames dropped)``: the surveyed control, the approximate orientation (the start's, else
    resection where ``eo`` lacks a frame, else registration to ``reference``,
    :mod:`fotogeo.tools.triangulate.register`), the automatic control from ``reference``
    (:mod:`fotogeo.tools.triangulate.inputs`) and the check points."""
    cam, names = start.camera, start.names
    gcp, map_crs, given_checks = read_block_control(kw["gcps"], start.crs, kw["gcp_crs"], cam, names,
                                                    kw["check_points"], start.distortion)
    auto, dropped = set(), []
    reference, dem = _as_list(kw["reference"]), kw["dem"]
    if start.registration is not None:
        from .register import registration_start
        reg = registration_start(frames, names, cam, reference, dem, map_crs, undetermined=kw["undetermined"],
                                 progress=prog, gps=start.gps_hints())
        frames, names, eos, gcp, dropped = reg.frames, reg.names, reg.eos, reg.control, reg.dropped
        if start.over_gps:
            start.take_registration(reg)
        start.registration[:], start.names = reg.rows, list(names)
        auto, reference = set(gcp.name), []
    elif start.eos:
        eos = tuple(start.eos[n] for n in names)
    else:
        eos = orientations(kw["eo"], names, cam, start.distortion, gcp, given_checks)
        start.resected = _resected(kw["eo"], names)
    if reference:
        surveyed = set(gcp.name) if gcp is not None else set()
        gcp = add_automatic_control(gcp, frames, names, cam, eos, reference, dem, map_crs, prog)
        auto = set(gcp.name) - surveyed
    check_ids = (split_check_points(gcp, given_checks, check_fraction_for(kw["check_fraction"], gcp, given_checks), kw["seed"]) if gcp is not None
                 else set())
    return frames, names, gcp, map_crs, eos, check_ids, auto, dropped


def start_height(gcp, dem, crs, eos, camera, *, source=None):
    """The terrain height for footprints and the LSM start: the mean GCP height, else the mean DEM height
    under the frames' image centres, else None (measured on the images,
    :mod:`fotogeo.tools.triangulate.start`). ``source``: the DEM already read (:func:`_dem_source`)."""
    if gcp is not None:
        return float(np.mean(gcp.ground[:, 2]))
    if dem is not None:
        src = _dem_source(dem, crs, camera, eos) if source is None else source
        if src is not None:
            xy = np.array([[e.X, e.Y] for e in eos])
            h = src.heights_and_gradient(xy)[0]
            if np.isfinite(h).any():
                return float(np.nanmean(h))
    return None


@contextmanager
def _output_folder(folder: Path):
    """The output folder, created (with its parents) when missing and removed again when the run fails
    before writing anything into it."""
    made = []
    for parent in reversed([folder, *folder.parents]):
        if not parent.exists():
            made.append(parent)
    try:
        for d in made:
            d.mkdir()
    except OSError as e:
        raise OutputError(f"cannot create the output folder {str(folder)!r} ({e.strerror or e}); choose another "
                          f"folder (-o)") from None
    try:
        yield folder
    except BaseException:
        for d in reversed(made):
            try:
                d.rmdir()
            except OSError:
                break
        raise


def _as_list(paths) -> list:
    """``None`` → [], one path → [path], a sequence → a list."""
    if not paths:
        return []
    return [paths] if isinstance(paths, (str, Path)) else list(paths)


def _resected(eo, names) -> list:
    """The frames whose approximate orientation came from space resection (not in ``eo``)."""
    from ...io.camera import read_exterior_orientation
    table = read_exterior_orientation(eo) if eo else {}
    return [n for n in names if n not in table]
