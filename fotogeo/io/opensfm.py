"""OpenSfM / OpenDroneMap ``reconstruction.json`` (+ ODM ``cameras.json``) -> :class:`ApproximateBlock`.

The format (OpenSfM ``doc/source/geometry.rst`` and ``opensfm/io.py``): a JSON list of
reconstructions, each with ``cameras`` ``{id: {projection_type, width, height, focal | focal_x,
focal_y, c_x, c_y, k1, k2, k3, p1, p2}}``, ``shots`` ``{image file: {rotation, translation, camera,
gps_position, gps_dop, ...}}`` and ``reference_lla`` ``{latitude, longitude, altitude}`` (or a
``reference_lla.json`` beside the file). Conventions, and what fotogeo makes of them:

* **Pose**: ``rotation`` is an axis-angle vector of the world -> camera rotation ``R``,
  ``x_cam = R·X + t``, the centre ``C = −Rᵀ·t``; camera axes x right, y down, z forward (OpenCV),
  so fotogeo's PATB rotation in the local frame is ``Rᵀ·diag(1, −1, −1)``.
* **Camera**: normalised image coordinates put (0, 0) at the image centre, the larger image side
  is 1 and the centre of the top-left pixel is ``(−(w−1)/2, −(h−1)/2)/max(w, h)``; so, in pixels
  (corner convention), ``fx = focal_x·max(w, h)``, ``ppx = w/2 + c_x·max(w, h)`` (``y`` alike).
  The distortion of ``perspective`` (k1, k2), ``simple_radial``, ``radial`` and ``brown`` (k1, k2,
  k3, p1, p2) acts on ``(x/z, y/z)`` before the focal length with OpenCV's tangential terms
  (``2p1·xy + p2(r² + 2x²)``; OpenSfM's ``DistoBrown``), which is fotogeo's model
  (:mod:`fotogeo.orientation.bundle_jacobian`): the coefficients are taken as they are. Fisheye,
  spherical and dual cameras are refused.
* **World frame**: OpenSfM's local frame is topocentric (east, north, up at ``reference_lla`` on
  WGS 84; ``opensfm/geo.py``). ODM reads the same local coordinates as offsets parallel to the UTM
  grid from UTM(``reference_lla``) (GUIDE.md §7). Both readings are implemented (``frame=``):
  ``"topocentric"`` (local -> ECEF -> lon/lat/h -> map CRS; the angles turned by the frame change
  between the reference and the camera and by the map's grid convergence, :func:`fotogeo.geometry.local_frames.grid_angle`) and
  ``"grid"`` (UTM offsets in ODM's zone, :func:`fotogeo.io.sfm_frame.odm_grid`; angles turned only when
  the map CRS is not that zone). ``"auto"`` decides from evidence (:mod:`fotogeo.io.sfm_frame`): the
  camera centres against the images' own GPS (given by the caller), OpenSfM's ``exif/<image>.exif``
  beside the reconstruction or the shots' ``gps_position`` (topocentric in OpenSfM's and ODM's files
  alike), else ODM's layout. When nothing decides and the readings differ here, the file is refused
  naming ``sfm_frame``; the reading and why are the block's ``frame_reading``.
* **Heights**: topocentric ``Z = altitude + z`` as OpenSfM stores them, grid ``Z = z`` (``export_geocoords``
  adds the reference's altitude; ODM's reference is at 0) — the GPS altitude, above the ellipsoid or the geoid
  as the camera wrote it: ``height_reference`` is left unknown.

:func:`write_opensfm` writes a block in the real format (tests, round trips).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import InputError, one_line
from ..geometry.approx_block import ApproxCamera, ApproximateBlock, ApproxShot
from ..geometry.local_frames import LocalFrame
from ..geometry.camera import FrameCamera, angles_patb, rotation_patb
from .block import frame_key
from .text import read_text_file

_D = np.diag([1.0, -1.0, -1.0])
#: OpenSfM projection types read (all map to fotogeo's Brown model)
PROJECTIONS = ("perspective", "simple_radial", "radial", "brown")
FRAMES = ("auto", "topocentric", "grid")
_FIX = "give OpenSfM's or ODM's opensfm/reconstruction.json"


# -- shared with the COLMAP reader -----------------------------------------------------------------
def load_json(path, what: str, fix: str):
    """The parsed JSON of ``path``; one-line :class:`InputError` naming ``what``, the file and ``fix``."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{what} {str(p)!r} {'is a folder' if p.is_dir() else 'does not exist'}; {fix}")
    text = read_text_file(p, what, hint=fix)
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(one_line(f"{what} {str(p)!r} is not valid JSON ({exc.msg}, line {exc.lineno} column "
                                  f"{exc.colno}); {fix}")) from None


def pixel_camera(w: int, h: int, fx: float, fy: float, ppx: float, ppy: float, distortion: dict,
                 source: str) -> ApproxCamera:
    """An :class:`ApproxCamera` from focal lengths and principal point in pixels (corner convention):
    ``focal_length = fx``, ``sensor_size = (w, h·fx/fy)`` so that ``camera.fx, camera.fy = fx, fy``."""
    if not (fx > 0 and fy > 0 and math.isfinite(fx) and math.isfinite(fy)):
        raise ValueError(f"focal lengths must be positive; got fx={fx}, fy={fy} px")
    if not (math.isfinite(ppx) and math.isfinite(ppy)):
        raise ValueError(f"principal point must be finite; got ({ppx}, {ppy})")
    sensor = (float(w), float(h)) if fx == fy else (float(w), h * fx / fy)
    return ApproxCamera(FrameCamera(float(fx), sensor, (int(w), int(h)), (float(ppx), float(ppy))),
                        {k: float(distortion.get(k, 0.0)) for k in ("k1", "k2", "k3", "p1", "p2")}, source)


def patb_from_world_to_camera(R_wc) -> tuple:
    """PATB ``(ω, φ, κ)`` degrees of a world -> OpenCV-camera rotation ``R_wc`` (``x_cam = R_wc·X + t``)."""
    return angles_patb(np.asarray(R_wc, float).T @ _D)


def world_to_camera_from_patb(angles) -> np.ndarray:
    """Inverse of :func:`patb_from_world_to_camera`: ``R_wc = (R_patb·D)ᵀ``."""
    return (rotation_patb(*angles) @ _D).T


# -- reading --------------------------------------------------------------------------------------
def _vector(d: dict, key: str, n: int = 3) -> np.ndarray:
    v = d.get(key)
    if not isinstance(v, list) or len(v) != n or not all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                                           for a in v) or not np.isfinite(v).all():
        raise ValueError(f"{key} must be {n} finite numbers; got {str(v)[:60]!r}")
    return np.asarray(v, float)


def _number(d: dict, key: str, default=None) -> float:
    v = d.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{key} must be a finite number; got {str(v)[:40]!r}")
    return float(v)


def camera_from_opensfm(d: dict, source: str = "") -> ApproxCamera:
    """One OpenSfM camera dict -> :class:`ApproxCamera` (module docstring); ValueError says what is wrong.

    >>> c = camera_from_opensfm({"projection_type": "brown", "width": 4000, "height": 3000, "focal_x": 0.8,
    ...                          "focal_y": 0.8, "c_x": 0.01, "c_y": -0.02, "k1": -0.1})
    >>> c.camera.fx, c.camera.principal_point, c.distortion["k1"]
    (3200.0, (2040.0, 1420.0), -0.1)
    """
    if not isinstance(d, dict):
        raise ValueError("a camera must be a JSON object")
    pt = d.get("projection_type", "perspective")
    if pt not in PROJECTIONS:
        raise ValueError(f"projection_type {str(pt)[:40]!r} cannot be converted to fotogeo's Brown model (only "
                         f"{', '.join(PROJECTIONS)}); re-run with a brown camera (ODM --camera-lens brown, OpenSfM "
                         f"camera_projection_type: BROWN)")
    w, h = int(_number(d, "width")), int(_number(d, "height"))
    if w <= 0 or h <= 0:
        raise ValueError(f"width and height must be positive; got {w} x {h}")
    m = max(w, h)
    if pt == "perspective":
        fx = fy = _number(d, "focal")
    else:
        fx = _number(d, "focal_x", d.get("focal"))
        fy = _number(d, "focal_y", fx)
    terms = {"perspective": ("k1", "k2"), "simple_radial": ("k1",), "radial": ("k1", "k2"),
             "brown": ("k1", "k2", "k3", "p1", "p2")}[pt]
    dist = {k: _number(d, k, 0.0) for k in terms}
    cx, cy = (0.0, 0.0) if pt == "perspective" else (_number(d, "c_x", 0.0), _number(d, "c_y", 0.0))
    return pixel_camera(w, h, fx * m, fy * m, w / 2.0 + cx * m, h / 2.0 + cy * m, dist, source or f"OpenSfM {pt}")


def _reference(rec: dict, path: Path):
    lla = rec.get("reference_lla")
    where = f"OpenSfM reconstruction {str(path)!r}"
    if lla is None:
        from .sfm_frame import opensfm_folder
        folder, undistorted = opensfm_folder(path)  # undistorted/: OpenSfM's folder above holds it
        side = folder / "reference_lla.json"
        if not side.is_file():
            raise InputError(f"{where} has no reference_lla and there is no reference_lla.json "
                             f"{'in the OpenSfM folder above it' if undistorted else 'beside it'}; the "
                             f"reconstruction is not georeferenced (run OpenSfM/ODM with GPS or GCPs)")
        lla, where = load_json(side, "OpenSfM reference", "give OpenSfM's reference_lla.json"), repr(str(side))
    try:
        return tuple(_number(lla, k) for k in ("latitude", "longitude", "altitude"))
    except (ValueError, AttributeError) as exc:
        raise InputError(one_line(f"{where}: reference_lla: {exc}; it needs latitude, longitude, altitude")) from None


def read_opensfm(reconstruction_json, cameras_json=None, crs=None, *, frame: str = "auto",
                 reconstruction: int | None = None, gps=None, names=()) -> ApproximateBlock:
    """Read an OpenSfM/ODM reconstruction into an :class:`ApproximateBlock` (module docstring).

    ``cameras_json``: ODM's ``cameras.json`` (camera dicts by id), which overrides or provides the
    cameras; ``crs``: the map CRS (projected), by default the UTM zone of ``reference_lla``;
    ``frame``: ``"auto"``, ``"topocentric"`` or ``"grid"`` (the tools' ``sfm_frame``); ``gps``: the
    images' own GPS ``{frame key: GpsFix}`` (:func:`fotogeo.io.sfm_frame.images_gps`), evidence for
    ``"auto"``; ``reconstruction``: which one of the list, by default the one holding most of the images
    ``names`` (frame keys), else the largest (:func:`_pick`). Shots are keyed by the image's stem. The reading and
    why are the block's ``frame_reading`` (and a note).
    """
    from ..crs import parse_crs, require_projected, utm_crs_for
    path = Path(reconstruction_json)
    where = f"OpenSfM reconstruction {str(path)!r}"
    if frame not in FRAMES:
        raise InputError(f"sfm_frame {frame!r} is not one of {', '.join(FRAMES)}", option="sfm_frame")
    data = load_json(path, "OpenSfM reconstruction", _FIX)
    if isinstance(data, dict):
        data = [data]
    if not isinstance(data, list) or not all(isinstance(r, dict) for r in data):
        raise InputError(f"{where} is not a list of reconstructions (objects with cameras and shots); {_FIX}")
    reconstruction, picked = _pick(data, reconstruction, names, where)
    rec = data[reconstruction]
    shots = rec.get("shots")
    if not isinstance(shots, dict) or not shots:
        raise InputError(f"{where}: reconstruction {reconstruction} has no shots (OpenSfM could not orient the images); "
                         f"re-run OpenSfM/ODM or give another reconstruction")
    cams = rec.get("cameras") or {}
    if not isinstance(cams, dict):
        raise InputError(f"{where}: cameras must be an object of camera dicts by id; {_FIX}")
    cams = dict(cams)
    notes = [f"read from {str(path)!r}" + (f" ({picked})" if picked else "")]
    if cameras_json is not None:
        extra = load_json(cameras_json, "ODM cameras file", "give ODM's cameras.json (camera dicts by id)")
        if not isinstance(extra, dict):
            raise InputError(f"ODM cameras file {str(cameras_json)!r} is not an object of camera dicts by id")
        cams.update(extra)
        notes.append(f"cameras from {str(cameras_json)!r} override the reconstruction's")
    ref = _reference(rec, path)
    map_crs = (require_projected(parse_crs(crs, "map CRS"), "map CRS", (ref[1], ref[0])) if crs is not None
               else utm_crs_for(ref[1], ref[0]))
    if crs is None:
        notes.append(f"map CRS EPSG:{map_crs.to_epsg()}: the UTM zone of reference_lla")
    parsed = _shots(path, shots, cams)
    from .sfm_frame import choose_reading, odm_grid
    grid, zone, odm = odm_grid(path, ref)
    kind, why = choose_reading(frame, shots, dict(zip(parsed[0], parsed[2])), path, ref, map_crs, gps, where, grid,
                               odm)
    if kind == "grid" and odm:
        why += f"; {zone}"
    notes += [why, "heights: " + ("local z" if kind == "grid" else "reference_lla altitude + local z") +
              ", in the vertical reference of the GPS altitudes (OpenSfM does not record it)"]
    return _block(parsed, LocalFrame(kind, ref, map_crs, *grid), map_crs, notes, why)


def _pick(data: list, index, names, where: str) -> tuple:
    """``(index, sentence)`` of the reconstruction read: ``index`` when given, else the one holding most of the
    images ``names``, else the one with most shots; the images in none or split over several are named."""
    keys = [{frame_key(n) for n in r["shots"]} if isinstance(r.get("shots"), dict) else set() for r in data]
    if index is not None:
        if not 0 <= index < len(data):
            raise InputError(f"{where} holds {len(data)} reconstruction(s); reconstruction={index} does not exist")
        return index, f"reconstruction {index} of {len(data)}, as told" if len(data) > 1 else ""
    wanted = set(names or ())
    best = max(range(len(data)), key=lambda i: (len(keys[i] & wanted), len(keys[i])))
    if len(data) == 1:
        return best, ""
    elsewhere = sorted(n for n in wanted - keys[best] if any(n in k for k in keys))
    if elsewhere:
        raise InputError(f"{where}: the images {', '.join(elsewhere[:5])} are oriented in another of its {len(data)} "
                         f"reconstructions than the rest (OpenSfM could not join them into one block); run once per "
                         f"reconstruction, each time with only its images")
    why = "the one holding the images given" if wanted & keys[best] else "the largest"
    return best, f"reconstruction {best} of {len(data)} ({len(keys[best])} shots; the others hold " \
                 f"{', '.join(str(len(k)) for i, k in enumerate(keys) if i != best)}): {why}"


def _shots(path: Path, shots, cams) -> tuple:
    """``(names, camera ids, local centres, PATB rotations camera -> local, cameras)`` of the shots."""
    from scipy.spatial.transform import Rotation
    where = f"OpenSfM reconstruction {str(path)!r}"
    names, cids, centres, rots, cameras = [], [], [], [], {}
    for name, s in shots.items():
        try:
            if not isinstance(s, dict):
                raise ValueError("a shot must be a JSON object")
            R = Rotation.from_rotvec(_vector(s, "rotation")).as_matrix()
            t = _vector(s, "translation")
            cid = str(s.get("camera"))
            if cid not in cams:
                raise ValueError(f"camera {cid!r} is not among the cameras ({', '.join(map(repr, list(cams)[:5]))})")
            if cid not in cameras:
                try:
                    cameras[cid] = camera_from_opensfm(cams[cid], f"OpenSfM camera {cid!r} of {str(path)!r}")
                except ValueError as exc:
                    raise ValueError(f"camera {cid!r}: {exc}") from None
        except ValueError as exc:
            raise InputError(one_line(f"{where}: shot {name!r}: {exc}")) from None
        names.append(frame_key(name))
        cids.append(cid)
        centres.append(-R.T @ t)
        rots.append(R.T @ _D)  # PATB camera -> local
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"{where}: images {', '.join(dup[:5])} differ only by extension or folder; fotogeo keys "
                         f"frames by file stem: rename them")
    return names, cids, centres, rots, cameras


def _block(parsed, fr: LocalFrame, map_crs, notes, why: str) -> ApproximateBlock:
    names, cids, centres, rots, cameras = parsed
    xyz, M = fr.to_map(np.array(centres))
    out = {n: ApproxShot(n, c, tuple(p), angles_patb(m @ r), source="OpenSfM reconstruction")
           for n, c, p, m, r in zip(names, cids, xyz, M, rots)}
    return ApproximateBlock(cameras, out, map_crs, tuple(notes), frame_reading=why)


# -- writing --------------------------------------------------------------------------------------
def opensfm_camera(cam: ApproxCamera) -> dict:
    """An :class:`ApproxCamera` as an OpenSfM ``brown`` camera dict (inverse of :func:`camera_from_opensfm`)."""
    c = cam.camera
    w, h = c.image_size
    m = float(max(w, h))
    d = {"projection_type": "brown", "width": int(w), "height": int(h), "focal_x": c.fx / m, "focal_y": c.fy / m,
         "c_x": (c.principal_point[0] - w / 2.0) / m, "c_y": (c.principal_point[1] - h / 2.0) / m}
    d.update({k: float(cam.distortion.get(k, 0.0)) for k in ("k1", "k2", "p1", "p2", "k3")})
    return d


def write_opensfm(path, block: ApproximateBlock, reference_lla, *, frame: str = "topocentric",
                  extension: str = ".jpg", exif: bool = True) -> None:
    """Write ``block`` as OpenSfM's ``reconstruction.json`` with the poses in the local ``frame``
    (``"topocentric"``, or ``"grid"``: ODM's after ``export_geocoords``) at ``reference_lla``
    (``{latitude, longitude, altitude}`` or ``(lat, lon, alt)``), ``reference_lla.json`` beside it and, with
    ``exif``, OpenSfM's ``exif/<image>.exif`` with each image's GPS (its projection centre) and ``dop`` (the
    shot's ``sigma_h``, else 5 m); ``gps_position`` is that GPS in the topocentric frame in both cases, as
    OpenSfM writes it and ``export_geocoords`` leaves it. Image keys are the shot names plus ``extension``.
    Z is taken as the GPS altitude."""
    from scipy.spatial.transform import Rotation
    if frame not in FRAMES[1:]:
        raise InputError(f"frame {frame!r} is not one of topocentric, grid")
    if block.crs is None:
        raise InputError("write_opensfm: the block has no CRS; its positions cannot be placed on the Earth")
    lla = reference_lla if isinstance(reference_lla, dict) else dict(zip(("latitude", "longitude", "altitude"),
                                                                          reference_lla))
    ref = tuple(float(lla[k]) for k in ("latitude", "longitude", "altitude"))
    shots = [s for s in block.shots.values() if s.exterior is not None]
    fr = LocalFrame(frame, ref, block.crs)
    local, M = fr.from_map(np.array([s.position for s in shots]))
    llh = fr.to_lonlath(local)
    topo = LocalFrame("topocentric", ref, block.crs).from_lonlath(llh)
    out, folder = {}, Path(path).parent
    for s, c, m, g, t in zip(shots, local, M, llh, topo):
        R = (m.T @ rotation_patb(*s.angles) @ _D).T  # world -> camera in the local frame
        key, dop = s.name + extension, s.sigma_h or 5.0
        out[key] = {"rotation": Rotation.from_matrix(R).as_rotvec().tolist(), "translation": (-R @ c).tolist(),
                    "camera": s.camera_id, "gps_position": t.tolist(), "gps_dop": dop}
        if exif:
            (folder / "exif").mkdir(exist_ok=True)
            (folder / "exif" / f"{key}.exif").write_text(json.dumps(
                {"gps": {"longitude": g[0], "latitude": g[1], "altitude": g[2], "dop": dop}}))
    rec = {"cameras": {cid: opensfm_camera(c) for cid, c in block.cameras.items()}, "shots": out, "points": {},
           "reference_lla": dict(zip(("latitude", "longitude", "altitude"), ref))}
    Path(path).write_text(json.dumps([rec], indent=1), encoding="utf-8")
    (folder / "reference_lla.json").write_text(json.dumps(rec["reference_lla"]), encoding="utf-8")
