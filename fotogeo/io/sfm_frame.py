"""Which reading of an SfM local frame the evidence supports, and whether an SfM file agrees with the images' GPS.

An OpenSfM ``reconstruction.json`` holds local coordinates that OpenSfM reads as a topocentric frame and
ODM as offsets parallel to the UTM grid from UTM(``reference_lla``) (GUIDE.md §7): ODM runs OpenSfM's
``export_geocoords`` (positions ``A·x + b``, rotations ``R·A⁻¹``, A the linear map topocentric -> UTM at the
reference) and keeps the topocentric file as ``reconstruction.topocentric.json``; it imposes ``reference_lla`` at
its UTM offset (``odm_georeferencing/coords.txt``: the zone of its first photo and ``floor`` of the photos' mean
UTM). The two readings agree at the reference and part with the distance from it: by the meridian convergence γ
(≈ Δλ·sin φ, largest at high latitude far from the zone's central meridian) and the grid's scale.
``export_geocoords`` leaves each shot's ``gps_position`` as OpenSfM wrote it, topocentric, so it says nothing about
the poses' frame: the reading is decided by the **camera centres** against an absolute GPS of the same images, in
this order:

1. the images' own EXIF GPS, with the σ of their accuracy tags (DJI RTK, senseFly) or :data:`DEFAULT_SIGMA_H`
   (a consumer receiver);
2. OpenSfM's ``exif/<image>.exif`` beside the reconstruction, with its ``dop`` as σ (ODM writes the RTK σ there);
3. the shots' ``gps_position`` read as topocentric, with their ``gps_dop`` as σ.

With horizontal residuals ``r_i`` and σ ``s_i`` of each reading, ``χ² = Σ |r_i|²/s_i²``: a reading is
chosen when it fits (``χ²/(2n) ≤`` :data:`~fotogeo.geometry.similarity3d.CHI2_DOF_MAX` = 9, RMS within 3σ)
and the other fits worse by ``Δχ² ≥ 25`` (a 5σ separation). Without such evidence, the layout decides: the file
named ``reconstruction.topocentric.json`` is topocentric; one beside it, or ODM's flag ``exported_geocoords.txt``
(ODM 2.4.7 to 2.6.3 rewrote ``reconstruction.json`` in place, keeping no topocentric copy), marks ODM's grid file;
OpenSfM's folder (``exif/``) with none of these nor ODM's reference or ``coords.txt`` is OpenSfM's own,
topocentric. ``undistorted/reconstruction.json`` (OpenSfM's ``undistort``, which ODM runs after
``export_geocoords``) is read in OpenSfM's folder above it (:func:`opensfm_folder`: its ``exif/``, ODM's files one
level further up) and in the frame of the file there whose poses it holds (``undistort`` copies them), never from
its place alone: moved out of that folder, or beside a file of other poses, it has no layout. When the two
readings place every camera within
:data:`SAME_M` (horizontally) and :data:`SAME_DEG` of each other the choice is immaterial (topocentric is taken
and said). Otherwise the file is refused, naming the option ``sfm_frame``. Heights are not compared (the GPS
altitude's reference is often unknown).

Which image's GPS is a shot's (:func:`images_gps`, :func:`gps_for`): every image given claims its own name, with
GPS or without, and the same file name in two folders is one image when their GPS is the same, else matched by the
path the project names or refused by name — an image never lends its GPS to another's shot.

:func:`check_gps` is the same test for any SfM block (COLMAP, orthority, OpenSfM after its reading): the
block's centres must agree with the images' own GPS within 3σ horizontally (RMS), else it is refused by name.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry.similarity3d import CHI2_DOF_MAX
from .gps_keys import DEFAULT_SIGMA_H, GpsFix, ImagesGps, gps_for, images_gps, project_key  # noqa: F401 (their home)

#: σ (m) of a GPS position without ``dop``/``gps_dop`` (OpenSfM's default dop)
OPENSFM_DOP = 15.0
#: σ (m) to which the same GPS written twice (EXIF rationals, OpenSfM's exif JSON) agrees with itself
TAG_SIGMA = 0.05
#: readings closer than these everywhere are the same for every purpose
SAME_M, SAME_DEG = 0.005, 2e-4
#: ODM's flag beside the reconstruction.json that its versions 2.4.7 to 2.6.3 rewrote along the grid in place
ODM_FLAG = "exported_geocoords.txt"
#: poses (radians, metres) that agree within this are copies of each other (OpenSfM's undistort copies them)
POSE_TOL = 1e-6
READINGS = ("topocentric", "grid")
_WHAT = {"topocentric": "OpenSfM's topocentric frame", "grid": "ODM's offsets along the UTM grid"}


def map_xy(crs, lon, lat) -> np.ndarray:
    """``(N, 2)`` map coordinates in ``crs`` of WGS 84 ``lon``, ``lat`` (degrees)."""
    from ..crs import transform_points
    return transform_points("EPSG:4326", crs, np.column_stack([np.asarray(lon, float), np.asarray(lat, float)]))


def _chi2(res, sigma) -> float:
    return float(np.sum(np.sum(res ** 2, axis=1) / sigma ** 2))


def _rms(res) -> float:
    return float(np.sqrt(np.mean(np.sum(res ** 2, axis=1))))


def separation(ref, crs, centres, grid=None) -> tuple[float, float]:
    """``(metres, degrees)``: the largest horizontal distance and turn between the two readings of ``centres``
    (local); ``grid``: ``(UTM CRS, origin)`` of the grid reading (:func:`odm_grid`; default: the zone of ``ref`` at
    it). Heights are left out: the grid reading takes z as the altitude (ODM imposes a reference altitude 0), the
    topocentric one adds the reference's altitude."""
    from ..geometry.local_frames import LocalFrame
    (pa, ma), (pb, mb) = (LocalFrame(k, ref, crs, *(grid or ())).to_map(centres) for k in READINGS)
    turn = np.einsum("nij,nkj->nik", ma, mb)
    ang = np.degrees(np.arccos(np.clip((np.trace(turn, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)))
    return float(np.max(np.linalg.norm(pa[:, :2] - pb[:, :2], axis=1))), float(np.max(ang))


def decide(local: dict, gps: dict, ref, crs, source: str, grid=None):
    """``(reading, sentence)`` from ``local`` ``{name: local xyz}`` against ``gps`` ``{name: (lon, lat, σ)}``
    (module docstring), or ``(None, sentence)`` when they cannot tell or contradict both readings."""
    from ..geometry.local_frames import LocalFrame
    gps = gps_for(gps, local)
    names = sorted(set(local) & set(gps))
    if not names:
        return None, f"none of the images with {source} is a shot of the reconstruction"
    xyz = np.array([local[n] for n in names], float)
    ev = np.array([gps[n] for n in names], float)
    want, sigma = map_xy(crs, ev[:, 0], ev[:, 1]), ev[:, 2]
    res = {k: LocalFrame(k, ref, crs, *(grid or ())).to_map(xyz)[0][:, :2] - want for k in READINGS}
    chi = {k: _chi2(r, sigma) for k, r in res.items()}
    best = min(chi, key=chi.get)
    other = READINGS[1 - READINGS.index(best)]
    said = (f"{source} ({len(names)} image(s), σ {np.median(sigma):.3g} m): {_rms(res[best]):.3f} m RMS "
            f"horizontally as {best}, {_rms(res[other]):.3f} m as {other}")
    if chi[best] / (2 * len(names)) > CHI2_DOF_MAX:
        return None, f"neither reading fits the {said}"
    if chi[other] - chi[best] < 25.0:
        return None, f"the {said}: too close to tell"
    return best, f"read as {best}: {_WHAT[best]} fits the {said}"


def check_gps(block, gps: dict, what: str, option: str | None = None) -> str:
    """The sentence saying how ``block``'s centres agree with the images' own ``gps`` ({name: GpsFix}); an
    :class:`InputError` naming ``what`` and the frames furthest off when the horizontal RMS exceeds 3σ, and the
    options to check: the CRS the file is read in (``crs``) and ``option`` (an SfM file's local frame)."""
    named = {s.project_name or k: k for k, s in block.shots.items()}  # the project's own name: its folder tells
    gps = {named[n]: g for n, g in gps_for(gps, named).items()}
    names = sorted(n for n in gps if block.shots[n].position is not None)
    if not names or block.crs is None:
        return ""
    pos = np.array([block.shots[n].position[:2] for n in names], float)
    want = map_xy(block.crs, [gps[n].lon for n in names], [gps[n].lat for n in names])
    sigma = np.array([max(gps[n].sigma_h, TAG_SIGMA) for n in names])
    off = np.linalg.norm(pos - want, axis=1)
    rms, s = _rms(pos - want), float(np.sqrt(np.mean(sigma ** 2)))
    if rms > 3.0 * s:
        worst = [f"{names[i]} {off[i]:.2f} m" for i in np.argsort(-off)[:3]]
        raise InputError(f"{what}: its camera centres are {rms:.2f} m RMS (horizontally) from the images' own GPS, "
                         f"more than 3 x their sigma {s:.3g} m ({', '.join(worst)}); the file was made in another "
                         f"frame or CRS than it is read in, or for other images — " + (
                             f"check the frame it is read in ({option})" if option else
                             "check the CRS it is read in (crs)"), option=option or "crs")
    return (f"camera centres {rms:.3f} m RMS horizontally from the images' own GPS of {len(names)} image(s) "
            f"(σ {s:.3g} m)")


def refusal(where: str, why: str, sep: tuple, gps_given: bool) -> InputError:
    """The refusal of an undecided reading (module docstring), naming ``sfm_frame``; the fix after " — ", where
    :func:`fotogeo.errors.one_line` keeps it however long the evidence before it is. ``gps_given``: images with GPS
    were given and could not decide, which calls for images with a GPS precise enough, not for the same images."""
    m, deg = sep
    images = ("images with a GPS precise enough to tell them apart (RTK)" if gps_given else
              "the images with GPS (their EXIF GPS decides)")
    return InputError(f"{where}: its local coordinates may be OpenSfM's topocentric frame or ODM's offsets along the "
                      f"UTM grid, which place the cameras up to {m:.2f} m and {deg:.2f}° apart here, and {why} — "
                      f"give {images}, or say which with sfm_frame topocentric (OpenSfM) or grid (ODM)",
                      option="sfm_frame")


def immaterial(sep: tuple) -> bool:
    return sep[0] <= SAME_M and sep[1] <= SAME_DEG and all(map(math.isfinite, sep))


def odm_grid(path: Path, ref) -> tuple:
    """``((UTM CRS, origin or None), sentence, odm)`` of the grid reading: ODM's zone and offset from
    ``odm_georeferencing/coords.txt`` beside the ``opensfm`` folder (``export_geocoords`` subtracts that offset);
    else, for a reference at altitude 0 (ODM imposes it at its offset), the zone — the reference's or a neighbour —
    where it falls on whole metres; ``odm`` True for these two (ODM's offset is known); else the reference's zone and
    UTM position, an empty sentence and ``odm`` False."""
    from pyproj import CRS, Transformer
    from pyproj.exceptions import CRSError

    from ..crs import utm_crs_for
    from .block import odm_crs
    own = utm_crs_for(ref[1], ref[0])
    coords = opensfm_folder(path)[0].parent / "odm_georeferencing" / "coords.txt"
    if coords.is_file():
        try:
            lines = coords.read_text(encoding="utf-8").splitlines()
            crs, off = CRS.from_user_input(odm_crs(lines[0])), np.array([float(v) for v in lines[1].split()[:2]])
            if crs.is_projected and np.isfinite(off).all():
                return (crs, off), (f"the grid of {crs.name} from ODM's offset {off[0]:.0f} {off[1]:.0f} in "
                                    f"{str(coords)!r}"), True
        except (OSError, UnicodeDecodeError, IndexError, ValueError, CRSError):
            pass
    if ref[2] == 0.0:
        zone, south = own.utm_zone[:-1], own.utm_zone.endswith("S")
        for z in (int(zone), int(zone) % 60 + 1, (int(zone) - 2) % 60 + 1):
            crs = CRS.from_epsg((32700 if south else 32600) + z)
            xy = np.array(Transformer.from_crs(4326, crs, always_xy=True).transform(ref[1], ref[0]))
            if np.all(np.abs(xy - np.round(xy)) < 2e-3):
                return (crs, None), (f"the grid of {crs.name}, where reference_lla falls on whole metres (ODM "
                                     f"imposes it at its UTM offset)"), True
    return (own, None), "", False


def _exif_gps(folder: Path, names) -> dict:
    """``{frame key: (lon, lat, σ)}`` from OpenSfM's ``exif/<image>.exif`` files (σ their ``dop``), where readable."""
    from .block import frame_key
    out = {}
    for name in names:
        try:
            g = json.loads((folder / "exif" / f"{name}.exif").read_text(encoding="utf-8"))["gps"]
            dop = float(g.get("dop") or OPENSFM_DOP)
            out[frame_key(name)] = (float(g["longitude"]), float(g["latitude"]), dop if dop > 0 else OPENSFM_DOP)
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            continue
    return out


def _gps_positions(shots: dict, ref, crs) -> dict:
    """``{frame key: (lon, lat, σ)}`` of the shots' ``gps_position`` read as topocentric (σ their ``gps_dop``)."""
    from ..geometry.local_frames import LocalFrame
    from .block import frame_key
    keys, xyz, dop = [], [], []
    for n, s in shots.items():
        v = s.get("gps_position") if isinstance(s, dict) else None
        if isinstance(v, list) and len(v) == 3 and all(isinstance(a, (int, float)) for a in v) and np.isfinite(v).all():
            d = s.get("gps_dop")
            keys.append(frame_key(n))
            xyz.append(v)
            dop.append(float(d) if isinstance(d, (int, float)) and d > 0 else OPENSFM_DOP)
    if not keys:
        return {}
    llh = LocalFrame("topocentric", ref, crs).to_lonlath(np.array(xyz, float))
    return {k: (g[0], g[1], d) for k, g, d in zip(keys, llh, dop)}


def opensfm_folder(path) -> tuple:
    """``(folder, undistorted)``: the OpenSfM data set ``path`` belongs to — the folder above for a file in
    ``undistorted/`` (OpenSfM's ``undistort`` writes ``undistorted/reconstruction.json`` there, beside the images it
    resamples, with the shots' poses copied), else the file's own folder."""
    p = Path(path)
    return (p.parent.parent, True) if p.parent.name == "undistorted" else (p.parent, False)


def _layout(path: Path, odm: bool, shots=None):
    """``(reading, sentence, marker)`` from the file layout, or None; ``odm``: ODM's reference or coords.txt was
    found; ``shots``: the file's own shots (an undistorted file is read as the file above holding its poses)."""
    p = Path(path)
    folder, undistorted = opensfm_folder(p)
    if undistorted:
        return _undistorted_layout(folder, odm, shots or {})
    if p.name.lower() == "reconstruction.topocentric.json":
        return ("topocentric", "read as topocentric: the file is ODM's copy of OpenSfM's topocentric reconstruction",
                "")
    if (p.parent / "reconstruction.topocentric.json").is_file():
        return "grid", ("read as grid: reconstruction.topocentric.json beside it marks ODM's reconstruction.json, "
                        "which export_geocoords wrote along the UTM grid"), "reconstruction.topocentric.json"
    if (p.parent / ODM_FLAG).is_file():
        return "grid", (f"read as grid: {ODM_FLAG} beside it marks the reconstruction.json that ODM (2.4.7 to 2.6.3) "
                        f"rewrote along the UTM grid with export_geocoords"), ODM_FLAG
    if not odm and (p.parent / "exif").is_dir():
        return "topocentric", ("read as topocentric: OpenSfM's folder (exif/ beside it) without "
                               "reconstruction.topocentric.json, ODM's reference or coords.txt — ODM moves OpenSfM's "
                               "topocentric file there when it writes its own along the grid"), ""
    return None


def _unknown_offset(layout, path: Path, where: str, told: bool = False) -> None:
    """Refuse an ODM layout marking a file along the UTM grid (``layout``: :func:`_layout`'s) whose grid offset is
    not known (no ``coords.txt``; :func:`odm_grid`): reference_lla is not ODM's offset there, so the grid reading,
    found or told (``told``: ``sfm_frame grid``), would place the cameras wrong in silence."""
    if layout is None or layout[0] != "grid":
        return
    undistorted = opensfm_folder(path)[1]
    fix = ("copy coords.txt with the project or give the images with RTK GPS" if undistorted or layout[2] == ODM_FLAG
           else "copy coords.txt with the project, give the images with RTK GPS, or read "
                "reconstruction.topocentric.json instead")
    raise InputError(f"{where}: {'sfm_frame grid was told, but ' if told else ''}{layout[2]} "
                     f"{'in the folder above' if undistorted else 'beside it'} marks ODM's file along the UTM grid, "
                     f"but its offset is not known (reference_lla is not ODM's offset and no "
                     f"odm_georeferencing/coords.txt is beside the opensfm folder); {fix}", option="sfm_frame")


def _undistorted_layout(folder: Path, odm: bool, shots: dict):
    """The layout of the OpenSfM file in ``folder`` whose poses ``shots`` hold (undistort copies them), or None
    when no file there holds them (a folder copied elsewhere, or undistorted from another run)."""
    for name in ("reconstruction.json", "reconstruction.topocentric.json"):
        f = folder / name
        if not (f.is_file() and _same_poses(f, shots)):
            continue
        got = _layout(f, odm)
        if got is not None:
            why = got[1].split(": ", 1)[1]
            return got[0], (f"read as {got[0]}: undistorted/ holds the poses of the OpenSfM folder's {name} (OpenSfM's "
                            f"undistort copies them), and {why}"), got[2]
    return None


def _same_poses(path: Path, shots: dict) -> bool:
    """Whether every shot of ``shots`` that the reconstruction file ``path`` holds has the same pose there
    (within :data:`POSE_TOL`), and at least one does."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    theirs = {}
    for rec in data if isinstance(data, list) else ():
        theirs.update(rec["shots"] if isinstance(rec, dict) and isinstance(rec.get("shots"), dict) else {})
    common = [n for n in shots if n in theirs]
    try:
        a, b = (np.array([[*s[n]["rotation"], *s[n]["translation"]] for n in common], float) for s in (shots, theirs))
    except (KeyError, TypeError, ValueError):
        return False
    return bool(common) and a.shape == b.shape and bool(np.all(np.abs(a - b) <= POSE_TOL))


def choose_reading(frame: str, shots: dict, centres: dict, path: Path, ref, crs, gps, where: str, grid=None,
                   odm_origin: bool = True) -> tuple:
    """``(reading, sentence)`` of an OpenSfM file's local frame (module docstring): as told, else from the evidence,
    else ODM's layout; an :class:`InputError` naming ``sfm_frame`` when nothing decides and the readings differ.
    ``odm_origin``: whether ODM's grid origin is known (:func:`odm_grid`); an ODM layout without it (a project of
    the ODM versions that kept OpenSfM's reference, copied without ``odm_georeferencing/coords.txt``) is refused."""
    if frame == "grid" and not odm_origin:  # told grid: the offset would come from reference_lla, not ODM's
        _unknown_offset(_layout(path, odm_origin, shots), path, where, told=True)
    if frame != "auto":
        return frame, f"OpenSfM local frame read as {frame} ({_WHAT[frame]}), as told (sfm_frame {frame})"
    steps = []
    if gps:
        ev = gps.mapped(lambda g: (g.lon, g.lat, g.sigma_h)) if isinstance(gps, ImagesGps) else \
            {n: (g.lon, g.lat, g.sigma_h) for n, g in gps.items()}
        steps.append((ev, "camera centres vs the images' own EXIF GPS"))
    folder, undistorted = opensfm_folder(path)
    exif = _exif_gps(folder, list(shots))
    if exif:
        steps.append((exif, "camera centres vs the GPS of the exif/<image>.exif " +
                      ("of the OpenSfM folder above it" if undistorted else "beside it")))
    gp = _gps_positions(shots, ref, crs)
    if gp:
        steps.append((gp, "camera centres vs the shots' gps_position (topocentric, as OpenSfM writes it)"))
    reasons = []
    for evidence, source in steps:
        kind, why = decide(centres, evidence, ref, crs, source, grid)
        if kind is not None:
            return kind, f"OpenSfM local frame {why}"
        reasons.append(why)
    layout = _layout(path, odm_origin, shots)
    if not odm_origin:
        _unknown_offset(layout, path, where)
    if layout is not None:
        return layout[0], f"OpenSfM local frame {layout[1]}" + (f" ({'; '.join(reasons)})" if reasons else "")
    sep = separation(ref, crs, np.array(list(centres.values()), float), grid)
    if immaterial(sep):
        return "topocentric", (f"OpenSfM local frame read as topocentric: the topocentric and grid readings place "
                               f"every camera within {sep[0]:.3f} m and {sep[1]:.5f}° of each other here")
    if not steps:
        reasons.append("no exif/<image>.exif is beside it, its shots carry no gps_position and the images' own GPS "
                       "is not at hand")
    raise refusal(where, "; ".join(reasons), sep, bool(gps))
