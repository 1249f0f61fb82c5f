"""The inputs of ``fotogeo triangulate``: camera, frames, control, check points and the approximate orientation.

* **Camera**: :func:`fotogeo.io.camera.read_camera_with_distortion` (pinhole, or orthority's
  ``brown`` with ``k1, k2, p1, p2, k3`` — the ``camera.yaml`` a self-calibrating run writes);
  the distortion is the bundle adjustment's starting (or fixed) value.
* **Control**: :func:`fotogeo.io.block.read_control` (``gcp_list.txt`` or a point layer / CSV in
  any CRS), transformed into the map CRS (``crs``, else the control's own CRS; it must be
  projected). Measurements outside their frame are skipped by name (orient's rule), refused when none remain;
  a frame's measurements read on a copy of it of another size or turned are refused naming the frame and the copy
  (orient's check, :func:`fotogeo.tools.common.checks.copy_check`).
* **Automatic control** (``reference`` orthophoto(s) and ``dem``): the GCPs that
  :func:`fotogeo.tools.triangulate.control.automatic_control` finds by matching every frame to the
  reference (named ``auto…``), merged with the surveyed ones; they need the approximate
  orientation of every frame (the ``--eo`` file or resection against surveyed GCPs).
* **Check points**: the file's ``check`` roles, the names given, and a seeded, spread hold-out
  of ``check_fraction`` of the control (:func:`fotogeo.io.block.split_check_points`); without a
  ``check_fraction`` (None) :func:`check_fraction_for` holds out a fifth where there is control to spare.
* **Approximate orientation**: the ``--eo`` file; a frame it lacks (or every frame, without
  one) is oriented by single-frame space resection against its control points
  (:class:`fotogeo.models.collinearity.Collinearity`, ≥ 4 points; the measured pixels are first
  freed of the camera's distortion, :func:`fotogeo.orientation.bundle_jacobian.undistort_rays`).
"""
from __future__ import annotations

import warnings

import numpy as np

from ...crs import parse_crs, require_projected
from ...errors import FotogeoWarning, InputError, ModelError
from ...geometry.brown import TERMS
from ...io.block import GcpList, control_in, frame_key, read_control, split_check_points
from ...io.camera import read_camera_with_distortion, read_exterior_orientation
from ...io.gcps import skip_outside
from ...io.raster import open_raster
from ..common.checks import camera_fit, check_camera_size, copy_check, distinct_files

#: the order of ``Block.distortion`` (Brown's terms, :mod:`fotogeo.geometry.brown`)
DISTORTION_ORDER = TERMS


def read_camera(camera):
    """``(FrameCamera, distortion (k1, k2, k3, p1, p2))`` from a YAML path or a FrameCamera object."""
    if hasattr(camera, "focal_length"):
        return camera, (0.0,) * 5
    cam, dist = read_camera_with_distortion(camera)
    return cam, tuple(dist[k] for k in DISTORTION_ORDER)


def frame_names(frames, camera) -> list:
    """The frames' keys (file stems), each frame checked against the camera's image size."""
    names = [frame_key(f) for f in frames]
    distinct_files(frames, names, "frames")
    for f in frames:
        info = open_raster(f, "frame")
        check_camera_size(camera, info.width, info.height, f)
    return names


def read_block_control(gcps, crs, gcp_crs, camera, names, check_points, distortion=None):
    """``(GcpList in the map CRS, map CRS, check-point names)``; ``gcps`` None: ``(None, crs, names)``.
    The check points are the names given and the file's ``check`` roles (the hold-out comes later,
    :func:`check_point_names`). ``distortion``: the camera's Brown terms, removed from the pixels before the check
    of each frame's measurements for a copy's reading (:func:`_in_frames`)."""
    ids = {c.strip() for c in (check_points or "").split(",") if c.strip()}
    if not gcps:
        if not crs:
            raise InputError("give the map CRS (crs=..., --crs) or ground control (--gcps) that carries one")
        if ids:
            raise InputError("check_points: names given but no ground control (--gcps)")
        map_crs = parse_crs(crs, "map CRS")
        require_projected(map_crs, "map CRS of the block")
        return None, map_crs, set()
    gcp = read_control(gcps, gcp_crs, crs)
    map_crs = parse_crs(crs if crs else gcp.crs, "map CRS")
    require_projected(map_crs, "map CRS of the block (give a projected one with --crs)")
    gcp = control_in(gcp, map_crs)
    gcp = _in_frames(gcp, names, camera, gcps, distortion)
    _same_ground_per_name(gcp, gcps)
    unknown = sorted(ids - set(gcp.name))
    if unknown:
        raise InputError(f"check_points: {', '.join(unknown[:10])} are not GCP names of {str(gcps)!r}")
    return gcp, map_crs, split_check_points(gcp, ids, 0.0, None)


def _same_ground_per_name(gcp: GcpList, path, tolerance: float = 1e-3) -> None:
    """Every measurement of one GCP must give the same ground coordinates (within ``tolerance`` m)."""
    order = np.argsort(gcp.name.astype(str), kind="stable")
    names, start = np.unique(gcp.name[order].astype(str), return_index=True)
    lo = np.minimum.reduceat(gcp.ground[order], start, axis=0)
    hi = np.maximum.reduceat(gcp.ground[order], start, axis=0)
    bad = names[(hi - lo).max(axis=1) > tolerance]
    if len(bad):
        raise InputError(f"GCP file {str(path)!r}: point(s) {', '.join(bad[:10])} have different ground coordinates "
                         f"in different rows; give each id one X, Y, Z (or different ids)")


def add_automatic_control(gcp, frames, names, camera, eos, reference, dem, map_crs, progress) -> GcpList:
    """``gcp`` (or None) plus the automatic control from ``reference`` and ``dem`` (module docstring)."""
    from dataclasses import replace

    from .control import automatic_control
    if dem is None:
        raise InputError("automatic control (--reference) needs the DEM (--dem) for the heights of its points")
    refs = [reference] if isinstance(reference, (str, bytes)) or not hasattr(reference, "__iter__") else list(reference)
    auto = automatic_control(frames, names, camera, eos, refs, dem, map_crs, progress=progress)
    auto = replace(auto, crs=map_crs, role=None if gcp is None or gcp.role is None else
                   np.full(len(auto.name), "control", dtype=object))
    if gcp is None:
        return auto
    clash = sorted(set(auto.name) & set(gcp.name))
    if clash:
        raise InputError(f"GCP names {', '.join(clash[:5])} are used by the automatic control (auto…); rename them")
    role = None if gcp.role is None else np.concatenate([gcp.role, auto.role])
    return GcpList(map_crs, np.concatenate([gcp.name, auto.name]), np.vstack([gcp.ground, auto.ground]),
                   np.vstack([gcp.pixel, auto.pixel]), np.concatenate([gcp.frame, auto.frame]), role)


def _in_frames(gcp: GcpList, names, camera, path, distortion=None) -> GcpList:
    """Drop (with a warning) measurements in images that are not frames, and those outside their frame by the one
    rule of every GCP tool (:func:`fotogeo.io.gcps.skip_outside`: skipped by name, refused when none remain), after
    the one check of each frame's measurements for pixels read on a copy of another size or turned
    (:func:`fotogeo.tools.common.checks.copy_check` with the camera's collinearity fit, as ``orient``)."""
    from dataclasses import replace
    inside = np.array([f in set(names) for f in gcp.frame], dtype=bool)
    if not inside.any():
        raise InputError(f"GCP file {str(path)!r}: no measurement names a frame of the block (its frames: "
                         f"{', '.join(sorted(set(gcp.frame))[:5])}); the frame field holds the frame's file name")
    if (~inside).any():
        warnings.warn(f"{int((~inside).sum())} GCP measurement(s) in images that are not frames of the block "
                      f"ignored: {', '.join(sorted(set(gcp.frame[~inside]))[:5])}", FotogeoWarning, stacklevel=3)
        keep = np.flatnonzero(inside)
        gcp = replace(gcp, name=gcp.name[keep], ground=gcp.ground[keep], pixel=gcp.pixel[keep],
                      frame=gcp.frame[keep], role=None if gcp.role is None else gcp.role[keep])
    w, h = camera.image_size
    roles = np.full(len(gcp.name), "control", dtype=object) if gcp.role is None else gcp.role
    fit = camera_fit(camera, distortion=distortion)
    # the span rule stays for every frame but those whose fit confirms a crop: a mask, one per measurement
    span = np.ones(len(gcp.name), dtype=bool)
    for f in dict.fromkeys(gcp.frame):
        mine = gcp.frame == f
        span[mine] = copy_check(gcp.ground[mine], gcp.pixel[mine], roles[mine] == "control", w, h,
                                f"GCP file {str(path)!r}, frame {f}", fit)
    keep, skipped = skip_outside([f"{n} in {f}" for n, f in zip(gcp.name, gcp.frame)], gcp.pixel, roles, w, h,
                                 f"GCP file {str(path)!r}", needed_by="the block", points=gcp.name, span=span)
    if skipped:
        keep = np.flatnonzero(keep)
        gcp = replace(gcp, name=gcp.name[keep], ground=gcp.ground[keep], pixel=gcp.pixel[keep],
                      frame=gcp.frame[keep], role=None if gcp.role is None else gcp.role[keep])
    return gcp


def orientations(eo, names, camera, distortion, gcp: GcpList | None, check_ids) -> tuple:
    """The approximate orientation of every frame: from ``eo``, else by space resection (module docstring)."""
    table = read_exterior_orientation(eo) if eo else {}
    missing = [n for n in names if n not in table]
    if missing and gcp is None:
        raise InputError(f"exterior orientation {str(eo)!r} lacks the frame(s) {', '.join(missing[:10])}; "
                         f"give one 'name X Y Z omega phi kappa' line per frame (name = the file name's stem), "
                         f"or ground control (--gcps) to resect them")
    usable = np.array([n not in check_ids for n in gcp.name]) if gcp is not None else None
    few = [n for n in missing if np.count_nonzero(usable & (gcp.frame == n)) < 4]
    if few:
        src = f"are not in {str(eo)!r}" if eo else "have no approximate orientation (no --eo)"
        counts = [f"{n} ({np.count_nonzero(usable & (gcp.frame == n))})" for n in few[:10]]
        raise InputError(f"frame(s) {', '.join(counts)} {src} and fewer than 4 control points to resect them; "
                         f"give --eo lines for them or measure more GCPs in them")
    for n in missing:
        table[n] = resect(camera, distortion, gcp.ground[usable & (gcp.frame == n)],
                          gcp.pixel[usable & (gcp.frame == n)], n)
    if gcp is not None:
        check_orientation_near_control(table, [n for n in names if n not in missing], gcp, eo)
    return tuple(table[n] for n in names)


def check_orientation_near_control(table, names, gcp: GcpList, eo, ratio: float = 5.0) -> None:
    """Refuse approximate orientations that cannot have seen their GCPs: a frame whose projection centre
    lies more than ``ratio`` flying heights (above its GCPs) from the mean of the GCPs it measured, or
    below them — the mark of an orientation file and a GCP file in different CRSs (or a wrong line)."""
    far = []
    for n in names:
        sel = gcp.frame == n
        if not sel.any():
            continue
        e, ground = table[n], gcp.ground[sel]
        height = e.Z - float(np.mean(ground[:, 2]))
        dist = float(np.hypot(e.X - ground[:, 0].mean(), e.Y - ground[:, 1].mean()))
        if not height > 0 or dist > ratio * height:
            far.append(f"{n} ({dist:.0f} m from its GCPs, {height:.0f} m above them)")
    if far:
        raise InputError(f"exterior orientation {str(eo)!r} and the GCPs do not fit together: frame(s) "
                         f"{', '.join(far[:5])}{' …' if len(far) > 5 else ''}; are both in the map CRS (--crs, "
                         f"--gcp-crs), and are the GCPs' frame names right?")


def resect(camera, distortion, ground, pixel, name):
    """The exterior orientation of one frame from ≥ 4 control points (module docstring)."""
    from ...models.collinearity import Collinearity
    from ...orientation import bundle_jacobian as bj
    interior = np.array([camera.focal_length, *camera.principal_point, *distortion], dtype=np.float64)
    rays = bj.undistort_rays(np.asarray(pixel, np.float64), interior, bj.pixel_scale(camera))
    pinhole = rays @ camera.K[:2].T  # K·(u, v, 1): the pixel a distortion-free camera would see
    ground = np.asarray(ground, np.float64)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                model = Collinearity.estimate(ground, pinhole, camera=camera)
            except ModelError:  # a DLT start over flat ground can mirror the camera: start from PnP on 5 spread points
                model = Collinearity.estimate(ground, pinhole, _spread_five(pinhole), camera=camera)
    except (ModelError, InputError) as exc:
        raise InputError(f"frame {name}: no approximate orientation from its {len(ground)} control points "
                         f"({str(exc)[:120]}); give its --eo line") from None
    if not np.isfinite(model.params[:6]).all() or model.info.get("sigma0", 0.0) > 50.0:
        raise InputError(f"frame {name}: the resection against its {len(ground)} control points does not fit "
                         f"(σ0 {model.info.get('sigma0', float('nan')):.1f} px); check their measurements or "
                         f"give its --eo line")
    return model.frame.eo


def _spread_five(pixel) -> np.ndarray:
    """Weights selecting 5 spread points (the four extremes of col ± row and the one nearest the centre);
    fewer than the DLT needs, so :class:`~fotogeo.models.collinearity.Collinearity` starts from PnP."""
    s, d = pixel[:, 0] + pixel[:, 1], pixel[:, 0] - pixel[:, 1]
    centre = np.argmin(np.hypot(*(pixel - pixel.mean(axis=0)).T))
    w = np.zeros(len(pixel))
    w[[np.argmin(s), np.argmax(s), np.argmin(d), np.argmax(d), centre]] = 1.0
    return w


#: without a check fraction: this share of the control is held out when at least
#: :data:`SPARE_CONTROL` points measured in two frames or more are there to hold out
AUTO_CHECK_FRACTION = 0.2
SPARE_CONTROL = 10


def check_fraction_for(fraction, gcp: GcpList | None, check_ids) -> float:
    """The check fraction: ``fraction`` when given; else 0 when check points are given (named or by role)
    or fewer than :data:`SPARE_CONTROL` control points are measured in two frames or more (a check point
    is intersected from its rays alone), else :data:`AUTO_CHECK_FRACTION`."""
    if fraction is not None:
        return float(fraction)
    if gcp is None or check_ids or (gcp.role is not None and (gcp.role == "check").any()):
        return 0.0
    _, rays = np.unique(gcp.name.astype(str), return_counts=True)
    return AUTO_CHECK_FRACTION if np.count_nonzero(rays >= 2) >= SPARE_CONTROL else 0.0
