"""The start of a block that only a reference orthophoto and a DEM place: every frame registered to the reference.

``fotogeo triangulate FRAMES --camera C --reference ORTHO... --dem DEM`` with neither ``--eo`` nor
``--gcps`` (and frames without GPS) has no approximate orientation. It does not need one: the
automatic control (:func:`fotogeo.tools.triangulate.control.control_and_fits`) matches every frame to
the reference tiles under its footprint — the frame raster's own approximate georeference, else
every tile — gives the matches their DEM heights and fits the registration's terrain model with the
camera (``register --dem --model collinearity``: homography RANSAC, Tukey refit, DLT relief filter,
then space resection on the inliers). That resection *is* the frame's pose; the same matches are the
block's control, so nothing is matched twice.

A pose is a start only when the registration determines it (:func:`pose_problem`): the fit
succeeded, its angle σ (from the resection's covariance) is at most :data:`MAX_ANGLE_SIGMA`, its
position σ is finite, and the camera lies above the terrain under it. A frame that fails is named
with the reason and dropped (``undetermined="drop"``, the default, while the rest can be a block:
:func:`~fotogeo.tools.triangulate.determinacy.why_not_dropped`), or refused (``"fail"``); every
frame's registration (tiles, matches, inliers, σ0, position and angle σ) is reported under
``start.registration`` of ``report.json``.

**Frames with GPS** (``--reference`` and ``--dem``, no ``--eo``, no ``--gcps``): the GPS gives a position
but often no attitude (or a gimbal/autopilot tag that can be wrong). Every frame is registered the
same way, its tiles chosen around its GPS position (its footprint when the files carry an attitude,
else every tile a camera tilted up to 45° there could see,
:func:`fotogeo.tools.triangulate.control.reach_disc`), and the start becomes the GPS position with the
registration's attitude (:func:`with_registered_attitude`) — for a frame whose files carry no attitude,
and for one whose tag the registration contradicts by more than :data:`CONTRADICTED_DEG` (its attitude
prior is then dropped). The position stays the GPS's, so its GNSS prior keeps meaning what it says. A
frame the reference cannot place keeps its GPS start (level, κ measured on the images) and is named
in its row; nothing is refused for it.
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, replace

import numpy as np

from ...errors import InputError, MatchingError, ModelError
from ...geometry.attitude import rotation_angle
from .determinacy import frames_text, why_not_dropped

#: the largest angle σ (degrees) of a registration pose that can start the adjustment
MAX_ANGLE_SIGMA = 1.0
#: a frame's attitude tag further than this (degrees, the rotation between the two) from its registration's
#: attitude is contradicted: three times the σ of a gimbal or autopilot tag (sources.ATTITUDE_SIGMA)
CONTRADICTED_DEG = 15.0


@dataclass(frozen=True)
class RegistrationStart:
    """The frames that keep a pose, their poses (in frame order), the control, the report rows, the dropped."""

    frames: list
    names: list
    eos: tuple
    control: object  # GcpList of the kept frames
    rows: list
    dropped: list


def pose_problem(fit, dem) -> str:
    """Why a frame's registration (:class:`~fotogeo.tools.triangulate.control.FrameFit`) cannot start the
    adjustment, or ``""`` (module docstring)."""
    if fit is None:
        return "not registered to the reference"
    if fit.model is None:
        return f"not registered to the reference ({fit.reason})"
    eo = fit.model.frame.eo
    std = np.asarray(fit.model.info.get("std", [np.inf] * 6), dtype=np.float64)
    if not np.isfinite([eo.X, eo.Y, eo.Z, eo.omega, eo.phi, eo.kappa]).all():
        return "its registration gives no finite pose"
    if not np.all(np.isfinite(std[3:])) or std[3:].max() > MAX_ANGLE_SIGMA:
        angle = f"{std[3:].max():.3g}°" if np.all(np.isfinite(std[3:])) else "undetermined"
        return f"its registration does not determine the attitude (angle σ {angle} from {fit.inliers} inliers)"
    if not np.all(np.isfinite(std[:3])):
        return f"its registration does not determine the position (position σ undetermined from {fit.inliers} inliers)"
    ground = dem.heights(np.array([[eo.X, eo.Y]]))[0]
    if np.isfinite(ground) and eo.Z <= ground:
        return f"its registration puts the camera below the terrain ({eo.Z:.0f} m, terrain {ground:.0f} m)"
    return ""


def _row(name, fit, problem) -> dict:
    row = {"name": name, "tiles": list(fit.tiles) if fit else [], "matches": fit.matches if fit else 0,
           "inliers": fit.inliers if fit else 0, "status": "dropped" if problem else "start", "reason": problem}
    if fit is not None and fit.model is not None:
        info, eo = fit.model.info, fit.model.frame.eo
        std = [float(v) for v in info.get("std", [np.nan] * 6)]
        row.update(sigma0_px=round(float(info.get("sigma0", np.nan)), 3),
                   position_sigma_m=round(float(np.linalg.norm(std[:3])), 3),
                   angle_sigma_deg=round(float(np.max(std[3:])), 4),
                   pose=[round(float(v), 4) for v in (eo.X, eo.Y, eo.Z, eo.omega, eo.phi, eo.kappa)])
    return row


def registration_start(frames, names, camera, reference, dem, crs, *, undetermined: str = "drop",
                       progress=None, gps=None) -> RegistrationStart:
    """Every frame's pose from its registration to ``reference`` with ``dem``, and the block's control
    (module docstring); frames that fail are dropped (``undetermined="drop"``), or refused. ``gps``:
    ``(eos, level)`` of the images' GPS start — the tiles are chosen around it, the start is
    :func:`with_registered_attitude` and a frame that fails keeps its GPS start."""
    from ...geometry.dem import Dem, DemSampler
    from ...io.raster import read_dem
    from .control import control_and_fits
    d = dem if isinstance(dem, Dem) else read_dem(dem)
    hints, level = gps if gps is not None else ([None] * len(names), None)
    gcp, fits = control_and_fits(frames, names, camera, list(hints), reference, d, crs, progress=progress,
                                 level=level)
    sampler = DemSampler(d, crs)
    problems = {n: pose_problem(fits.get(n), sampler) for n in names}
    rows = [_row(n, fits.get(n), problems[n]) for n in names]
    if gps is not None:
        return _over_gps(frames, names, hints, level, fits, problems, rows, gcp)
    bad = {n: p for n, p in problems.items() if p}
    refusal = why_not_dropped(len(names), len(names) - len(bad)) if undetermined == "drop" else None
    if bad and (undetermined != "drop" or refusal):
        text = frames_text(bad)
        raise MatchingError(f"no approximate orientation for frame(s) {text} — the start comes from registering "
                            f"each frame to the reference (no --eo, no --gcps){f', and {refusal}' if refusal else ''}; "
                            f"check that the orthophoto and the DEM cover them, give their --eo lines or GCPs"
                            f"{'' if refusal else ', or leave them out (--undetermined drop)'}", frames=bad)
    keep = [k for k, n in enumerate(names) if n not in bad]
    kept = {names[k] for k in keep}
    sel = np.array([f in kept for f in gcp.frame], dtype=bool)
    gcp = replace(gcp, name=gcp.name[sel], ground=gcp.ground[sel], pixel=gcp.pixel[sel], frame=gcp.frame[sel],
                  role=None if gcp.role is None else gcp.role[sel])
    return RegistrationStart([frames[k] for k in keep], [names[k] for k in keep],
                             tuple(fits[names[k]].model.frame.eo for k in keep), gcp, rows,
                             [{"name": n, "reason": why} for n, why in bad.items()])


def with_registered_attitude(gps_eo, pose, level: bool) -> tuple:
    """``(start, why or "")``: the GPS position with the registration's attitude when the frame's files carry
    none (``level``) or their tag is more than :data:`CONTRADICTED_DEG` from it; else the GPS start as it is."""
    registered = replace(gps_eo, omega=pose.omega, phi=pose.phi, kappa=pose.kappa)
    if level:
        return registered, "registration (no attitude in the files)"
    turn = rotation_angle(gps_eo.rotation, pose.rotation)
    if turn > CONTRADICTED_DEG:
        return registered, f"registration (the files' attitude is {turn:.1f}° from it)"
    return gps_eo, ""


def _over_gps(frames, names, hints, level, fits, problems, rows, gcp) -> RegistrationStart:
    """The GPS start with the registrations' attitudes (:func:`with_registered_attitude`); every frame kept."""
    eos = []
    for k, (n, row) in enumerate(zip(names, rows)):
        if problems[n]:
            eos.append(hints[k])
            row.update(status="gps", attitude="level start (κ from the images)" if level[k] else "the files' tags")
            continue
        pose = fits[n].model.frame.eo
        eo, why = with_registered_attitude(hints[k], pose, bool(level[k]))
        eos.append(eo)
        row.update(attitude=why or "the files' tags (the registration agrees)",
                   gps_offset_m=round(float(np.linalg.norm(pose.centre - hints[k].centre)), 2))
    return RegistrationStart(list(frames), list(names), tuple(eos), gcp, rows, [])


def none_registered(rows, level) -> str:
    """What happened when the frames' GPS start was registered to the reference and no frame registered while
    ``level`` (frame names) have no attitude in their files (:func:`_over_gps`' rows, all "gps"): the frames tried
    with their matches and inliers, the first reasons, and the fix; ``""`` when a frame registered (its attitude
    serves the level frames: :func:`fotogeo.tools.triangulate.guided.measured_attitudes`) or none is level."""
    if not rows or not level or any(r.get("status") != "gps" for r in rows):
        return ""
    tried = ", ".join(f"{r['name']} {r.get('matches', 0)}/{r.get('inliers', 0)}" for r in rows[:4])
    more = f" and {len(rows) - 4} more" if len(rows) > 4 else ""
    first = str(rows[0].get("reason", "")).replace("not registered to the reference", "").strip(" ()")
    return (f"no frame registered to the reference ({len(rows)} tried, matches/inliers: {tried}{more}; "
            f"{rows[0]['name']}: {(first or 'not registered')[:60]}): the {len(level)} frame(s) without attitude "
            f"tags started level, none of known attitude to measure theirs — give a reference showing their ground, "
            f"their attitude (gimbal tags, --geoinfo, --eo) or GCPs")


@contextmanager
def saying_none_registered(start):
    """A refusal raised inside, in a block started from the images' GPS whose registration to the reference placed
    no frame while some have no attitude (:func:`none_registered`), says that first: the refusal itself (angle σ,
    too few ties) is its consequence."""
    try:
        yield
    except (ModelError, MatchingError, InputError) as exc:
        rows = start.registration if getattr(start, "over_gps", False) else None
        said = none_registered(rows, [n for n in start.names if start.level.get(n)])
        if not said:
            raise
        raise type(exc)(f"{said}; then: {exc}", option=exc.option, frames=exc.frames, also=exc.also) from None
