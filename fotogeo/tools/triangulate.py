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
  (:mod:`fotogeo.tools.triangulate_inputs`);
* ``observations`` — the image measurements of the tie points, a table ``frame, point, col,
  row[, sigma]`` (:func:`fotogeo.io.block.read_image_observations`); ``None``: the overlapping
  frames are matched (:mod:`fotogeo.tools.triangulate_match`: footprints at the mean GCP
  height, SURF on pyramid level 1, epipolar RANSAC, multi-ray tracks thinned to Gruber positions,
  LSM transfer at full resolution with each observation's σ);
* ``gcps`` — ground control: ODM/OpenSfM's ``gcp_list.txt`` (:func:`fotogeo.io.block.read_gcp_list`)
  or a point layer / CSV in any CRS, one row per (point, frame) measurement with ``id, frame,
  col, row, z[, role]`` (:func:`fotogeo.io.block.read_control_table`), transformed into the map
  CRS; check points: the ``role`` field, the names in ``check_points`` and a seeded spread
  hold-out of ``check_fraction`` of the control;
* ``reference`` (with ``dem``) — orthophoto(s) on which control is found automatically
  (:func:`fotogeo.tools.triangulate_control.automatic_control`), merged with ``gcps`` and weighted
  with ``reference_sigma_xy`` / ``reference_sigma_z``;

runs :func:`fotogeo.orientation.bundle.adjust_block` in the map CRS (projected, metric) and
writes into ``folder``, as one set (nothing on an error or a cancel;
:mod:`fotogeo.tools.triangulate_outputs`):

* ``exterior_orientation.txt`` — the adjusted orientations, in the input's format;
* ``camera.yaml`` — with ``self_calibration``: the adjusted interior orientation (orthority's
  YAML, :func:`fotogeo.io.block.write_interior_orientation`);
* ``block.gpkg`` — layers ``tie_points`` (3-D, σ, rays), ``control`` (control and check points
  at their adjusted position, ``adjusted − given`` and role), ``frames`` (projection centres,
  angles, σ), ``residuals`` (every image observation at its ground point: frame, pixel,
  residual vector in px, status, standardised residual) and ``footprints`` (frame outlines on
  the DEM or the mean height, :mod:`fotogeo.tools.triangulate_ortho`);
* ``report.json`` — σ₀, image RMS, control/check RMSE per axis, interior parameters estimated,
  held fixed and why, blunders culled, timings; ``report.html`` — the same with plots
  (:mod:`fotogeo.tools.triangulate_report`);
* with ``orthorectify``: ``<frame>_ortho.tif``, each frame on the DEM through its adjusted orientation.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.block import frame_key, read_image_observations
from ..io.raster import check_output
from ..orientation.bundle import Block, BundleOptions, adjust_block
from ..progress import as_progress
from .boundary import tool
from ..io.block import split_check_points
from .triangulate_inputs import add_automatic_control, frame_names, orientations, read_block_control, read_camera
from .triangulate_outputs import CAMERA_FILE, FILES, output_paths, report, write_outputs

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


def _matched(frames, names, cam, eos, gcp, prog):
    """Image observations (with LSM's σ) from matching the overlapping frames
    (:func:`fotogeo.tools.triangulate_match.matched_observations`)."""
    from .triangulate_match import matched_observations
    height = float(np.mean(gcp.ground[:, 2])) if gcp is not None else 0.0
    return matched_observations(frames, names, cam, eos, height, progress=prog)


@tool("TRIANGULATE", outputs=("folder",))
def triangulate(frames, camera, eo, observations, folder, *, gcps=None, crs=None, gcp_crs=None, check_points=None,
                self_calibration=None, control_sigma_xy: float = 0.05, control_sigma_z: float = 0.05,
                image_sigma: float = 1.0, eo_sigma_position=None, eo_sigma_angle=None, snooping: bool = True,
                max_correlation: float = 0.999, check_fraction: float = 0.0, seed: int = 0, dem=None,
                orthorectify: bool = False, resolution=None, resampling: str = "nearest", reference=None,
                reference_sigma_xy: float = 0.5, reference_sigma_z: float = 1.0, overwrite: bool = False,
                progress=None) -> dict:
    """Adjust the block (module docstring); returns the report dict."""
    prog = as_progress(progress).with_own_timings()
    frames = [Path(f) for f in ([frames] if isinstance(frames, (str, Path)) else frames)]
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"output folder {str(folder)!r} does not exist; create it first")
    if eo is None and not gcps:
        raise InputError("give the approximate exterior orientation (--eo) or ground control (--gcps) to resect "
                         "the frames")
    inputs = [*frames, camera, eo, observations, gcps, dem, *_as_list(reference)]  # observations None: matched
    finals = output_paths(folder, names=[frame_key(f) for f in frames], self_calibration=self_calibration,
                          orthorectify=orthorectify)
    for path in finals.values():
        check_output(path, inputs, overwrite, "output")
    cam, distortion = read_camera(camera)
    names = frame_names(frames, cam)
    gcp, map_crs, eos, check_ids, auto = _control(frames, names, cam, distortion, eo, gcps, crs, gcp_crs, check_points,
                                            check_fraction, seed, reference, dem, prog.stage(0.0, 0.2, "control"))
    matching = None
    if observations is not None:
        obs = read_image_observations(observations)
    else:
        obs, matching = _matched(frames, names, cam, eos, gcp, prog.stage(0.2, 0.5, "matching the frames"))
    ids, xyz, sig, role, f_obs, p_obs, px, s_obs = _points(names, obs, gcp, check_ids, control_sigma_xy,
                                                          control_sigma_z, image_sigma)
    automatic = np.isin(np.array(ids, dtype=object), list(auto)) & (role == "control")
    sig[automatic] = [reference_sigma_xy, reference_sigma_xy, reference_sigma_z]
    block = Block(cam, tuple(names), eos, f_obs, p_obs, px, ids, xyz, sig, role, s_obs, distortion=distortion,
                  crs=map_crs)
    eo_sigma = None
    if eo_sigma_position is not None or eo_sigma_angle is not None:
        eo_sigma = (eo_sigma_position or 1e6, eo_sigma_angle or 1e3)
    opts = BundleOptions(self_calibration=tuple(self_calibration or ()), eo_sigma=eo_sigma, snooping=snooping,
                         max_correlation=max_correlation)
    prog(0.5, "inputs read")
    result = adjust_block(block, opts, progress=prog.stage(0.5, 0.8, "bundle adjustment"))
    rep = report(result, block, map_crs, {"frames": [str(f) for f in frames], "camera": str(camera),
                                         "eo": str(eo) if eo else None, "gcps": str(gcps) if gcps else None,
                                         "observations": str(observations) if observations else None,
                                         "dem": str(dem) if dem else None, "folder": str(folder),
                                         "reference": [str(r) for r in _as_list(reference)] or None,
                                         "automatic_control": len(auto), "check_points": sorted(map(str, check_ids)),
                                         "matching": matching, "resected_frames": _resected(eo, names)})
    write_outputs(finals, result, block, frames, rep, dem=dem, resolution=resolution, resampling=resampling,
                  overwrite=overwrite, progress=prog.stage(0.8, 1.0, "writing the outputs"))
    prog(1.0, "done")
    return rep


def _control(frames, names, cam, distortion, eo, gcps, crs, gcp_crs, check_points, check_fraction, seed, reference,
             dem, prog):
    """``(control GcpList or None, map CRS, approximate orientations, check-point names, automatic control
    names)``: the surveyed
    control, the approximate orientation (resection where ``eo`` lacks a frame), the automatic control from
    ``reference`` (:mod:`fotogeo.tools.triangulate_inputs`) and the check points."""
    gcp, map_crs, given_checks = read_block_control(gcps, crs, gcp_crs, cam, names, check_points)
    eos = orientations(eo, names, cam, distortion, gcp, given_checks)
    auto = set()
    if _as_list(reference):
        surveyed = set(gcp.name) if gcp is not None else set()
        gcp = add_automatic_control(gcp, frames, names, cam, eos, _as_list(reference), dem, map_crs, prog)
        auto = set(gcp.name) - surveyed
    check_ids = split_check_points(gcp, given_checks, check_fraction or 0.0, seed) if gcp is not None else set()
    return gcp, map_crs, eos, check_ids, auto


def _as_list(paths) -> list:
    """``None`` → [], one path → [path], a sequence → a list."""
    if not paths:
        return []
    return [paths] if isinstance(paths, (str, Path)) else list(paths)


def _resected(eo, names) -> list:
    """The frames whose approximate orientation came from space resection (not in ``eo``)."""
    from ..io.camera import read_exterior_orientation
    table = read_exterior_orientation(eo) if eo else {}
    return [n for n in names if n not in table]
