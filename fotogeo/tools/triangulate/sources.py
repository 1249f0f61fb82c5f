"""Where a block's camera, approximate orientation, map CRS and GNSS weights come from (``fotogeo triangulate``).

Every source ends in one :class:`~fotogeo.geometry.approx_block.ApproximateBlock`:

* ``--camera`` (orthority YAML) and ``--eo`` (``name X Y Z omega phi kappa`` lines) as before;
* nothing given: what the images carry — EXIF GPS, XMP attitude and calibration
  (:func:`fotogeo.io.exif_block.read_exif_block`), with senseFly's ``geoinfo.txt`` (``--geoinfo``) for
  the autopilot's attitude;
* a frame without a start and ≥ 4 GCPs is resected (:mod:`fotogeo.tools.triangulate.inputs`);
* no ``--eo``, no ``--gcps``, frames without GPS, and ``--reference`` with ``--dem``: every frame is
  registered to the reference and its pose taken from that fit (:mod:`fotogeo.tools.triangulate.register`;
  ``registration`` holds every frame's registration after the control step);
* the same with frames that carry GPS: every frame is registered around its GPS position, and a frame
  whose files carry no attitude (or one the registration contradicts) starts from the GPS position with
  the registration's attitude (``over_gps``; :meth:`BlockStart.take_registration`).

**The map CRS** (:func:`map_crs_rule`): ``--crs``; else the ground control's own CRS; else the
reference orthophoto's, then the DEM's, when projected; else the UTM zone of the images' GPS. The
rule used is stated in the report (``start.crs_rule``).

**Unknown attitude**: frames start level (ω = φ = 0) with κ along the flight direction
(capture order), and κ and the terrain height are then measured on the matched pairs
(:mod:`fotogeo.tools.triangulate.start`) before least-squares matching.

**GNSS weights** (:meth:`BlockStart.eo_sigma`): σ given on the command line win
(``--eo-sigma-position`` horizontal, ``--eo-sigma-height`` vertical, ``--eo-sigma-angle``); else
positions from the images' GPS get the σ of their accuracy tags (senseFly ``GPSXYAccuracy`` /
``GPSZAccuracy``, DJI RTK standard deviations) or :data:`GNSS_SIGMA` (a consumer receiver) and
attitudes from a gimbal/autopilot :data:`ATTITUDE_SIGMA`; unknown attitudes stay free.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...crs import parse_crs, require_projected
from ...errors import InputError
from ...geometry.camera import ExteriorOrientation
from ...io.block import frame_key
from ...options import AUTO_SELF_CALIBRATION

#: σ (horizontal, vertical) in metres of a GPS position without accuracy tags (consumer receiver)
GNSS_SIGMA = (5.0, 10.0)
#: σ in degrees of an attitude read from a gimbal or an autopilot
ATTITUDE_SIGMA = 5.0
#: the start's source when the camera comes from the images' files
EXIF_SOURCE = "the images' EXIF/XMP"


@dataclass
class BlockStart:
    """The camera, names, approximate orientations and CRS of a block before matching (module docstring)."""

    camera: object
    distortion: tuple
    names: list
    eos: dict  # name -> ExteriorOrientation of the frames that have a start
    crs: object
    crs_rule: str
    source: str
    sigmas: dict = field(default_factory=dict)  # name -> (σh, σv, σangle or None) of the images' own data
    level: dict = field(default_factory=dict)  # name -> True where the attitude was unknown (level start)
    resected: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    registration: list | None = None  # the frames' registration rows when the start comes from the reference
    heights: str = ""  # the GPS heights' reference and why, when the start comes from the images' GPS
    over_gps: bool = False  # registration around the images' GPS start (attitude from the reference)
    frame_reading: str = ""  # how an SfM --eo file's local frame was read and why (fotogeo.io.sfm_frame)
    interior_rule: str = ""  # which interior parameters the adjustment estimates and why (interior_to_estimate)
    lost: dict = field(default_factory=dict)  # frame -> what of its files' metadata could not be read
    tagged: dict = field(default_factory=dict)  # name -> True where the position σ is the images' accuracy tags'
    camera_source: str = ""  # how the images' EXIF gave the focal length (fotogeo.io.exif_camera.focal_of), else ""

    def measure(self, height):
        """The ``start`` callable of :func:`~fotogeo.tools.triangulate.match.block_tie_points`, or None when
        the orientations and the terrain height are known."""
        level = [bool(self.level.get(n)) for n in self.names]
        if not any(level) and height is not None:
            return None
        from .start import start_from_pairs

        def measure(eos, inliers):
            return start_from_pairs(tuple(eos), self.camera, inliers, estimate_kappa=level,
                                    estimate_height=height is None)
        measure.level = level  # per frame: no attitude yet, so none of its pairs is matched on the ground plane
        return measure

    def eo_sigma(self, position, height, angle):
        """The ``eo_sigma`` of :class:`~fotogeo.orientation.bundle.BundleOptions` (module docstring)."""
        m = len(self.names)
        if position is not None or height is not None or angle is not None:
            h = position if position is not None else np.inf
            v = height if height is not None else h
            a = angle if angle is not None else np.inf
            return np.tile([h, h, v, a, a, a], (m, 1)).astype(float)
        if not self.sigmas:
            return None
        rows = []
        for n in self.names:
            sh, sv, sa = self.sigmas.get(n, (np.inf, np.inf, None))
            rows.append([sh, sh, sv] + [sa if sa is not None else np.inf] * 3)
        return np.array(rows, dtype=float)

    def sigma_source(self, position, height) -> str | None:
        """Where the position priors' σ came from, as a refusal says it after the σ (:func:`~.determinacy.free_roll`):
        None when ``--eo-sigma-position`` gave it; ``--eo-sigma-height`` alone; the images' GNSS accuracy tags; or
        :data:`GNSS_SIGMA` for GPS without them (the images' own σ: no flag of the run to name)."""
        if position is not None:
            return None
        if height is not None:
            return f"with --eo-sigma-height {height:g} m holding the heights only (give --eo-sigma-position)"
        tags = [n for n in self.names if self.tagged.get(n)]
        if tags and len(tags) == len(self.names):
            return "from the images' GNSS accuracy tags"
        if tags:
            return (f"from the GNSS accuracy tags of {len(tags)} of the {len(self.names)} images, {GNSS_SIGMA[0]:g} m "
                    f"for the others' GPS")
        return f"for the images' GPS, {GNSS_SIGMA[0]:g} m when they carry no accuracy tag (a consumer receiver's)"

    def gps_hints(self):
        """``(eos, level)`` in frame order: the GPS start that chooses each frame's reference tiles, or None
        when the start has no GPS (the registration alone places the frames)."""
        if not self.over_gps:
            return None
        return [self.eos[n] for n in self.names], [bool(self.level.get(n)) for n in self.names]

    def take_registration(self, reg) -> None:
        """The GPS start with the attitudes the registration gave (:func:`~fotogeo.tools.triangulate.register.
        registration_start` with ``gps``): no longer level where it gave one, and no attitude prior where it
        contradicted the files' tag; the source says which frames."""
        rows = {r["name"]: r for r in reg.rows}
        took, contradicted = [], []
        for n, eo in zip(reg.names, reg.eos):
            why = rows[n].get("attitude", "")
            if not why.startswith("registration"):
                continue
            (took if self.level.get(n) else contradicted).append(n)
            self.eos[n], self.level[n] = eo, False
            sh, sv, _ = self.sigmas.get(n, (GNSS_SIGMA[0], GNSS_SIGMA[1], None))
            self.sigmas[n] = (sh, sv, None)
        self.registration[:] = reg.rows
        base = self.source.split("; orientation", 1)[0]
        n_reg = len(took) + len(contradicted)
        parts = [f"orientation from the images' GPS; attitude from registering the frames to the reference "
                 f"(--reference, --dem) for {n_reg} of {len(self.names)}" if n_reg else
                 "orientation from the images' GPS and attitude tags (their registration to the reference agrees)"]
        if contradicted:
            parts.append(f"their attitude tags contradicted by it: {', '.join(contradicted[:6])}")
        left = [n for n in self.names if self.level.get(n)]
        if left:
            parts.append(f"not registered, level start with κ from the images: {', '.join(left[:6])}")
        self.source = "; ".join([base, *parts])

    def interior_to_estimate(self, given, n_frames: int) -> tuple:
        """The interior parameters the adjustment estimates — ``given`` (``none``: the camera fixed); without
        it, :data:`~fotogeo.options.AUTO_SELF_CALIBRATION` for a camera guessed from the images' EXIF (no
        calibration in their files) in a block of 3 frames or more, else none. Why is kept in
        ``interior_rule`` (the report's ``start.self_calibration``)."""
        parameters, self.interior_rule = self._interior(tuple(given or ()), n_frames)
        return parameters

    def _interior(self, names: tuple, n_frames: int) -> tuple:
        if "none" in names:
            if len(names) > 1:
                raise InputError("--self-calibration none holds the camera fixed; give it alone, or the "
                                 "parameters to estimate without it")
            return (), "fixed (--self-calibration none)"
        if names:
            return names, "given (--self-calibration)"
        if not self.source.startswith(EXIF_SOURCE):
            return (), f"fixed: the camera of {self.source.split(';')[0]} (--self-calibration f,k1,... estimates it)"
        if any(self.distortion):
            return (), "fixed: the calibration the images carry (--self-calibration f,k1,... estimates it)"
        if n_frames < 3:
            return (), f"fixed: {n_frames} frames are too few to calibrate the camera from the images' EXIF"
        return AUTO_SELF_CALIBRATION, ("estimated: the camera is guessed from the images' EXIF (no calibration in "
                                       "their files); --self-calibration none holds it fixed")

    def summary(self) -> dict:
        out = {"source": self.source, "crs_rule": self.crs_rule, "notes": list(self.notes),
               "level_start_frames": [n for n in self.names if self.level.get(n)],
               "gnss_sigma_m": {n: list(map(_finite, self.sigmas[n][:2])) for n in self.names if n in self.sigmas}}
        if self.registration is not None:
            out["registration"] = self.registration
        if self.heights:
            out["heights"] = self.heights
        if self.frame_reading:
            out["sfm_frame"] = self.frame_reading
        if self.interior_rule:
            out["self_calibration"] = self.interior_rule
        return out


def _finite(x):
    return None if x is None or not np.isfinite(x) else float(x)


def _projected_crs_of(path, what):
    """The CRS of a raster when it is projected, else None."""
    from ...io.raster import open_raster
    info = open_raster(path, what)
    return info.crs if info.crs is not None and info.crs.is_projected else None


def map_crs_rule(crs, gcps, reference, dem, approx_crs) -> tuple:
    """``(CRS or None, rule)`` of the module docstring; None: the GCP file's CRS decides later."""
    if crs and str(crs).strip().lower() != "auto":
        return parse_crs(crs, "--crs"), "given (--crs)"
    if gcps:
        return None, "the ground control's CRS (--gcps)"
    for paths, what in ((reference, "reference orthophoto"), ([dem] if dem else [], "DEM")):
        for p in paths or []:
            c = _projected_crs_of(p, what)
            if c is not None:
                return c, f"the {what}'s CRS ({'--reference' if what.startswith('ref') else '--dem'})"
    if approx_crs is not None:
        return approx_crs, "the UTM zone of the images' GPS positions"
    return None, ""


def _from_images(frames, crs, geoinfo, need_position: bool, camera=None):
    """The ApproximateBlock of what the images carry (EXIF/XMP, and ``geoinfo``); frames without a GPS
    position are refused first when ``need_position`` (no --eo, no --gcps) and no geoinfo can give one.
    ``camera``: the ``--camera`` given (its EXIF counterpart is then not read)."""
    from ...io.exif import read_image_metadata
    from ...io.exif_block import read_exif_block
    if need_position and geoinfo is None:
        _refuse_without_gps([frame_key(f) for f in frames if read_image_metadata(str(f)).lon is None], len(frames))
    from .inputs import DISTORTION_ORDER, read_camera
    given = None
    if camera is not None:
        from ...geometry.approx_block import ApproxCamera
        cam, dist = read_camera(camera)
        given = ApproxCamera(cam, dict(zip(DISTORTION_ORDER, dist)), "--camera")
    return read_exif_block([str(f) for f in frames], crs=crs, geoinfo=geoinfo, camera=given)


def block_start(frames, camera, eo, gcps, crs, gcp_crs, reference, dem, geoinfo, sfm_frame="auto") -> BlockStart:
    """Read the camera and the approximate orientation (module docstring)."""
    from .inputs import frame_names, read_camera
    names = [frame_key(f) for f in frames]
    if reference and dem is None:
        raise InputError("automatic control (--reference) needs the DEM (--dem) for the heights of its points")
    approx = None
    by_registration = eo is None and not gcps and bool(reference) and geoinfo is None and not _all_have_gps(frames)
    sfm = _from_orientation_file(eo, crs, reference, dem, camera, frames, sfm_frame) if eo is not None else None
    if sfm is not None:
        return _start_from_file(frames, names, camera, sfm, crs, gcps, reference, dem, str(eo))
    if camera is None or (eo is None and not gcps and not by_registration):
        given = parse_crs(crs, "--crs") if crs and str(crs).lower() != "auto" else None
        approx = _from_images(frames, given or _first_projected(reference, dem), geoinfo,
                              eo is None and not gcps and not by_registration, camera)
    if approx is not None and eo is None and not gcps and not by_registration:
        _require_gps(names, approx)
    map_crs, rule = map_crs_rule(crs, gcps, reference, dem, approx.crs if approx is not None else None)
    if map_crs is None and not gcps:
        raise InputError("no map CRS: give --crs (a projected CRS such as a UTM zone), ground control (--gcps), a "
                         "projected reference orthophoto (--reference) or DEM (--dem), or images with GPS")
    if map_crs is not None:
        require_projected(map_crs, "map CRS of the block (--crs)")
    if camera is not None:
        cam, dist = read_camera(camera)
        source = "--camera"
    else:
        cam, dist = _single_camera(approx)
        source = EXIF_SOURCE
    frame_names(frames, cam)
    start = BlockStart(cam, dist, names, {}, map_crs, rule, source,
                       notes=list(approx.notes) if approx is not None else [],
                       lost=dict(approx.lost) if approx is not None else {},
                       camera_source=_camera_source(approx) if camera is None else "")
    if by_registration:
        start.registration = []
        start.source += "; orientation from registering every frame to the reference (--reference, --dem)"
    elif eo is None and approx is not None and not gcps:
        _start_from_images(start, approx, map_crs)
        if reference and dem is not None:  # the reference gives what the GPS lacks (module docstring)
            start.registration, start.over_gps = [], True
    else:
        start.source += f"; orientation from --eo {eo}" if eo is not None else "; orientation by resection on --gcps"
    return start


def _all_have_gps(frames) -> bool:
    """Whether every frame's EXIF carries a GPS position."""
    from ...io.exif import read_image_metadata
    return all(read_image_metadata(str(f)).lon is not None for f in frames)


def _first_projected(reference, dem):
    """The reference's, else the DEM's CRS when projected (the middle of :func:`map_crs_rule`), else None."""
    return map_crs_rule(None, None, reference, dem, None)[0]


def _single_camera(approx):
    """The one camera of the block; mixed cameras are named with their frames (one block per camera)."""
    used = {}
    for n, s in approx.shots.items():
        used.setdefault(s.camera_id, []).append(n)
    if len(used) > 1:
        groups = "; ".join(f"{cid}: {', '.join(sorted(v)[:4])}{' …' if len(v) > 4 else ''}" for cid, v in used.items())
        raise InputError(f"the frames come from {len(used)} cameras ({groups}); triangulate the frames of each "
                         f"camera separately, or give one --camera for all")
    ac = approx.cameras[next(iter(used))]
    return ac.camera, ac.distortion_tuple()


def _camera_source(approx) -> str:
    """How the images' EXIF gave the block's one camera (checked by :mod:`~fotogeo.tools.triangulate.exif_focal`)."""
    return next(iter(approx.cameras.values())).source if approx.cameras else ""


def _require_gps(names, approx) -> None:
    """Refuse frames whose files carry no GPS position, naming them and what to give instead."""
    _refuse_without_gps([n for n in names if approx.shots.get(n) is None or approx.shots[n].position is None],
                        len(names))


def _refuse_without_gps(missing, n_frames: int) -> None:
    """The one error for frames without a start of their own: named (or "none of the N"), with every way to give one."""
    if missing:
        more = f" and {len(missing) - 10} more" if len(missing) > 10 else ""
        which = (f"none of the {n_frames} frames carries a" if len(missing) == n_frames > 1 else
                 f"frame(s) {', '.join(missing[:10])}{more} carry no")
        raise InputError(f"{which} GPS position in the EXIF/XMP; give their positions (--geoinfo, or --eo with an "
                         f"approximate exterior orientation), ground control to resect them (--gcps), or a reference "
                         f"orthophoto with its DEM to register them (--reference, --dem)")


def _start_from_images(start: BlockStart, approx, map_crs) -> None:
    """Orientations from the images' GPS and attitude; frames with unknown attitude start level, κ along
    the flight direction (module docstring)."""
    from .start import flight_kappa
    _require_gps(start.names, approx)
    if approx.crs is not None and map_crs is not None and not approx.crs.equals(map_crs):
        raise InputError(f"the images' positions are in {approx.crs.to_string()} but the map CRS is "
                         f"{map_crs.to_string()}; give --crs")
    shots = [approx.shots[n] for n in start.names]
    order = np.argsort([n for n in start.names], kind="stable")
    centres = np.array([s.position for s in shots])
    kappa = np.empty(len(shots))
    kappa[order] = flight_kappa(centres[order])
    refs = {s.height_reference for s in shots}
    if len(refs) > 1:
        raise InputError(f"the images' GPS heights mix references ({', '.join(sorted(map(str, refs)))}); give --eo "
                         f"with heights in one reference")
    ref = refs.pop() or "reference not stated by the camera"
    start.notes.append(f"GPS heights: {ref}")
    start.heights = approx.heights or ref
    for n, s, k in zip(start.names, shots, kappa):
        angles = s.angles if s.angles is not None else (0.0, 0.0, float(k))
        start.level[n] = s.angles is None
        start.eos[n] = ExteriorOrientation(*s.position, *angles)
        sh = s.sigma_h if s.sigma_h else GNSS_SIGMA[0]
        sv = s.sigma_v if s.sigma_v else GNSS_SIGMA[1]
        start.sigmas[n] = (sh, sv, ATTITUDE_SIGMA if s.angles is not None else None)
        start.tagged[n] = bool(s.sigma_h)
    start.source += "; orientation from the images' GPS" + ("" if all(not v for v in start.level.values()) else
                                                              " (attitude unknown: level start, κ from the images)")


def _from_orientation_file(eo, crs, reference, dem, camera, frames=(), sfm_frame="auto"):
    """The ApproximateBlock of an SfM/orthority ``--eo`` file (:mod:`fotogeo.io.orientation_file`; the frames' own
    GPS decides an OpenSfM file's local frame and checks every file), or None."""
    from ...io.orientation_file import is_block_file, read_orientation_file
    if not is_block_file(eo):
        return None  # fotogeo's own EO lines: read by inputs.orientations
    given = parse_crs(crs, "--crs") if crs and str(crs).lower() != "auto" else None
    return read_orientation_file(eo, crs=given or _first_projected(reference, dem), camera=camera, sfm_frame=sfm_frame,
                                 images=frames)


def _start_from_file(frames, names, camera, approx, crs, gcps, reference, dem, source) -> BlockStart:
    """The start from an SfM/orthority orientation file: its cameras (unless --camera), its poses, its CRS."""
    from .inputs import frame_names, read_camera
    map_crs, rule = map_crs_rule(crs, gcps, reference, dem, approx.crs)
    map_crs = map_crs or approx.crs
    if not approx.crs.equals(map_crs):
        raise InputError(f"--eo {source!r} is in {approx.crs.to_string()} but the map CRS is {map_crs.to_string()}; "
                         f"give --crs {approx.crs.to_string()}")
    lacking = [n for n in names if n not in approx.shots or approx.shots[n].exterior is None]
    if lacking:
        raise InputError(f"--eo {source!r} has no pose for frame(s) {', '.join(lacking[:10])}; give a file that "
                         f"holds every frame (by file name)")
    sub = {n: approx.shots[n] for n in names}
    from ...io.orientation_file import cameras_from_camera_file
    own = camera is None or cameras_from_camera_file(source)  # orthority's cameras come from --camera already
    cam, dist = _single_camera(type(approx)(approx.cameras, sub)) if own else read_camera(camera)
    frame_names(frames, cam)
    start = BlockStart(cam, dist, list(names), {n: sub[n].exterior for n in names}, map_crs,
                       rule or f"the CRS of --eo {source!r}", f"--eo {source}", notes=list(approx.notes),
                       frame_reading=approx.frame_reading)
    return start
