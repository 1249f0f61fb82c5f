"""The triangulation tool: a block of frames oriented together by bundle adjustment (paths in, folder out).

``triangulate(frames, camera, eo, observations, folder, gcps=...)`` reads

* ``frames`` — the frame rasters (their names key everything else; their size must be the
  camera's);
* ``camera`` — the interior orientation YAML (:func:`fotogeo.io.camera.read_interior_orientation`);
* ``eo`` — the approximate exterior orientation, ``name X Y Z omega phi kappa`` lines in the
  map CRS (metres, PATB degrees), e.g. from GNSS/INS;
* ``observations`` — the image measurements of the tie points, a table ``frame, point, col,
  row[, sigma]`` (:func:`fotogeo.io.block.read_image_observations`); ``None``: the overlapping
  frames are matched (:mod:`fotogeo.tools.triangulate_match`: footprints at the mean GCP
  height, SURF pairs, epipolar RANSAC, multi-ray tracks);
* ``gcps`` — ground control in ODM/OpenSfM's ``gcp_list.txt`` (the CRS line, then ``X Y Z
  im_x im_y image_name name``, :func:`fotogeo.io.block.read_gcp_list`); the GCPs named in
  ``check_points`` are held out as check points;

runs :func:`fotogeo.orientation.bundle.adjust_block` in the map CRS (projected, metric) and
writes into ``folder``, as one set (nothing on an error or a cancel):

* ``exterior_orientation.txt`` — the adjusted orientations, in the input's format;
* ``camera.yaml`` — with ``self_calibration``: the adjusted interior orientation (orthority's
  YAML, :func:`fotogeo.io.block.write_interior_orientation`);
* ``block.gpkg`` — layers ``tie_points`` (3-D, σ, rays), ``control`` (control and check points
  at their adjusted position, ``adjusted − given`` and role), ``frames`` (projection centres,
  angles, σ) and ``residuals`` (every image observation at its ground point: frame, pixel,
  residual vector in px, status, standardised residual);
* ``report.json`` — σ₀, image RMS, control/check RMSE per axis, interior parameters estimated,
  held fixed and why, blunders culled, timings.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..crs import parse_crs, require_projected
from ..errors import FotogeoWarning, InputError
from ..io.block import (frame_key, read_gcp_list, read_image_observations, write_exterior_orientation,
                        write_interior_orientation)
from ..io.camera import load_camera, read_exterior_orientation
from ..io.raster import AtomicOutputs, check_output, open_raster
from ..io.report import write_json
from ..io.vector import write_layers
from ..orientation.bundle import Block, BundleOptions, adjust_block
from ..progress import as_progress
from .boundary import tool
from .checks import check_camera_size

FILES = ("exterior_orientation.txt", "block.gpkg", "report.json")
CAMERA_FILE = "camera.yaml"  # written with self-calibration


def _frames(frames, camera):
    names = [frame_key(f) for f in frames]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"frames: the names {', '.join(dup)} occur twice; every frame needs its own file name")
    for f in frames:
        info = open_raster(f, "frame")
        check_camera_size(camera, info.width, info.height, f)
    return names


def _orientations(eo, names):
    table = read_exterior_orientation(eo)
    missing = [n for n in names if n not in table]
    if missing:
        raise InputError(f"exterior orientation {str(eo)!r} lacks the frame(s) {', '.join(missing[:10])}; "
                         f"give one 'name X Y Z omega phi kappa' line per frame (name = the file name's stem)")
    return tuple(table[n] for n in names)


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
        inside = np.array([f in index for f in gcp.frame], dtype=bool)
        if (~inside).any():
            warnings.warn(f"{int((~inside).sum())} GCP measurement(s) in images that are not frames of the block "
                          f"ignored: {', '.join(sorted(set(gcp.frame[~inside]))[:5])}", FotogeoWarning, stacklevel=3)
        for k in np.flatnonzero(inside):
            j = where[gcp.name[k]]
            xyz[j] = gcp.ground[k]
            role[j] = "check" if gcp.name[k] in check_ids else "control"
        f_obs += [index[f] for f in gcp.frame[inside]]
        p_obs += [where[n] for n in gcp.name[inside]]
        px.append(gcp.pixel[inside])
        s_obs.append(np.full(int(inside.sum()), image_sigma))
    sig[role == "control"] = [sigma_xy, sigma_xy, sigma_z]
    unknown_checks = sorted(set(check_ids) - set(gcp.name if gcp is not None else []))
    if unknown_checks:
        raise InputError(f"check_points: {', '.join(unknown_checks[:10])} are not GCP names of the GCP list")
    return (tuple(ids), xyz, sig, role.astype(str), np.array(f_obs, dtype=np.intp), np.array(p_obs, dtype=np.intp),
            np.concatenate(px), np.concatenate(s_obs))


def _matched(frames, names, cam, eos, gcp, prog):
    """Image observations from matching the overlapping frames (:mod:`fotogeo.tools.triangulate_match`)."""
    from ..io.block import ImageObservations
    from .triangulate_match import match_block
    height = float(np.mean(gcp.ground[:, 2])) if gcp is not None else 0.0
    frame, track, pixel, report = match_block(frames, cam, eos, height, progress=prog)
    obs = ImageObservations(np.array([names[f] for f in frame], dtype=object),
                            np.array([f"tie{t}" for t in track], dtype=object), pixel, None)
    return obs, report


@tool("TRIANGULATE", outputs=("folder",))
def triangulate(frames, camera, eo, observations, folder, *, gcps=None, crs=None, check_points=None,
                self_calibration=None, control_sigma_xy: float = 0.05, control_sigma_z: float = 0.05,
                image_sigma: float = 1.0, eo_sigma_position=None, eo_sigma_angle=None, snooping: bool = True,
                max_correlation: float = 0.999, overwrite: bool = False, progress=None) -> dict:
    """Adjust the block (module docstring); returns the report dict."""
    prog = as_progress(progress).with_own_timings()
    frames = [Path(f) for f in ([frames] if isinstance(frames, (str, Path)) else frames)]
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"output folder {str(folder)!r} does not exist; create it first")
    inputs = [*frames, camera, eo, observations, gcps]  # observations None: matched
    finals = [folder / name for name in FILES] + ([folder / CAMERA_FILE] if self_calibration else [])
    for path in finals:
        check_output(path, inputs, overwrite, "output")
    cam = load_camera(camera)
    names = _frames(frames, cam)
    eos = _orientations(eo, names)
    gcp = read_gcp_list(gcps) if gcps else None
    matching = None
    if observations is not None:
        obs = read_image_observations(observations)
    else:
        obs, matching = _matched(frames, names, cam, eos, gcp, prog.stage(0.05, 0.5, "matching the frames"))
    map_crs = parse_crs(crs if crs else (gcp.crs if gcp is not None else None), "map CRS") if (crs or gcp) else None
    if map_crs is None:
        raise InputError("give the map CRS (crs=..., --crs) or a GCP list whose first line is the CRS")
    require_projected(map_crs, "map CRS of the block")
    check_ids = {c.strip() for c in (check_points or "").split(",") if c.strip()}
    ids, xyz, sig, role, f_obs, p_obs, px, s_obs = _points(names, obs, gcp, check_ids, control_sigma_xy,
                                                          control_sigma_z, image_sigma)
    block = Block(cam, tuple(names), eos, f_obs, p_obs, px, ids, xyz, sig, role, s_obs, crs=map_crs)
    eo_sigma = None
    if eo_sigma_position is not None or eo_sigma_angle is not None:
        eo_sigma = (eo_sigma_position or 1e6, eo_sigma_angle or 1e3)
    opts = BundleOptions(self_calibration=tuple(self_calibration or ()), eo_sigma=eo_sigma, snooping=snooping,
                         max_correlation=max_correlation)
    prog(0.5, "inputs read")
    result = adjust_block(block, opts, progress=prog.stage(0.5, 0.9, "bundle adjustment"))
    from .triangulate_outputs import block_layers, report
    rep = report(result, block, map_crs, {"frames": [str(f) for f in frames], "camera": str(camera), "eo": str(eo),
                                         "gcps": str(gcps) if gcps else None,
                                         "observations": str(observations) if observations else None,
                                         "folder": str(folder), "matching": matching})
    with AtomicOutputs(overwrite) as out:
        write_exterior_orientation(out.temp(finals[0]), names, result.eo,
                                   f"fotogeo triangulate: adjusted exterior orientation, CRS {map_crs.to_string()}\n"
                                   f"name X Y Z omega phi kappa (metres, PATB degrees)")
        write_layers(out.temp(finals[1]), block_layers(result, block), map_crs)
        write_json(out.temp(finals[2]), rep)
        if self_calibration:
            write_interior_orientation(out.temp(finals[3]), "adjusted", result.camera, result.distortion)
        out.commit()
    prog(1.0, "done")
    return rep
