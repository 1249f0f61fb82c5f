"""COLMAP models (``cameras``/``images`` as ``.txt`` or ``.bin``) -> :class:`ApproximateBlock`, and back.

The format (COLMAP ``doc/format.rst``, ``doc/cameras.rst``, ``src/colmap/sensor/models.h``):

* ``cameras.txt``: ``CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]`` per line. Read: ``SIMPLE_PINHOLE``
  (f, cx, cy), ``PINHOLE`` (fx, fy, cx, cy), ``SIMPLE_RADIAL`` (f, cx, cy, k), ``RADIAL`` (f, cx, cy,
  k1, k2), ``OPENCV`` (fx, fy, cx, cy, k1, k2, p1, p2) and ``FULL_OPENCV`` (… k3, k4, k5, k6; only
  with k4 = k5 = k6 = 0, its rational radial term being otherwise beyond fotogeo's Brown model). The
  distortion acts on ``(x/z, y/z)`` with OpenCV's terms, fotogeo's model
  (:mod:`fotogeo.orientation.bundle_jacobian`): the coefficients are taken as they are. Fisheye and
  other models are refused by name. COLMAP's image coordinates put the top-left corner at (0, 0)
  and the centre of the top-left pixel at (0.5, 0.5): GDAL's corner convention, so ``cx, cy`` are
  fotogeo's ``ppx, ppy`` unchanged.
* ``images.txt``: two lines per image, ``IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME`` and the
  (possibly empty) ``POINTS2D`` line. The Hamilton quaternion and ``T`` map world to camera,
  ``x_cam = R·X + T``, the centre ``C = −Rᵀ·T``; camera axes x right, y down, z forward, so fotogeo's
  PATB rotation is ``Rᵀ·diag(1, −1, −1)``.
* Binary models (``scripts/python/read_write_model.py``): ``cameras.bin`` is a uint64 count, then per
  camera int32 id, int32 model id, uint64 width, height and float64 parameters; ``images.bin`` a uint64
  count, then per image int32 id, float64 QW QX QY QZ TX TY TZ, int32 camera id, the NUL-terminated
  name, a uint64 count of 2-D points and 24 bytes per point (x, y, point id; skipped). Little-endian.
* COLMAP's world frame is arbitrary unless the model was geo-registered (``colmap model_aligner``).
  Aligned to positions in a projected CRS, the reader needs that CRS, and the model's X, Y, Z axes
  are taken as its easting, northing and up; aligned into ECEF (``--alignment_type ecef``: every
  centre within :data:`ECEF_BAND` of the Earth's centre and outside the CRS's area of use), the
  positions go through lon/lat/h into the CRS and the rotations turn from ECEF axes to the local
  east-north-up axes at each camera and by the grid convergence (:mod:`fotogeo.geometry.local_frames`).
  Centres outside the CRS's area of use otherwise (a model left in COLMAP's own frame) are aligned to the images'
  own GPS as ``model_aligner`` does when at least three of the images given carry it (:mod:`fotogeo.io.colmap_align`),
  else refused.
  ``points3D`` is not read.

:func:`write_colmap` writes a block as a text model (tests, round trips).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError, one_line
from ..geometry.approx_block import ApproximateBlock, ApproxShot
from .block import frame_key
from .opensfm import patb_from_world_to_camera, pixel_camera, world_to_camera_from_patb
from .text import read_text_file

#: COLMAP camera models read, with their parameter names
MODELS = {"SIMPLE_PINHOLE": ("f", "cx", "cy"), "PINHOLE": ("fx", "fy", "cx", "cy"),
          "SIMPLE_RADIAL": ("f", "cx", "cy", "k1"), "RADIAL": ("f", "cx", "cy", "k1", "k2"),
          "OPENCV": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"),
          "FULL_OPENCV": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")}
#: COLMAP's camera model ids (binary models), ``src/colmap/sensor/models.h``
MODEL_IDS = {0: "SIMPLE_PINHOLE", 1: "PINHOLE", 2: "SIMPLE_RADIAL", 3: "RADIAL", 4: "OPENCV", 5: "OPENCV_FISHEYE",
             6: "FULL_OPENCV", 7: "FOV", 8: "SIMPLE_RADIAL_FISHEYE", 9: "RADIAL_FISHEYE", 10: "THIN_PRISM_FISHEYE",
             11: "RAD_TAN_THIN_PRISM_FISHEYE"}
_N_PARAMS = {0: 3, 1: 4, 2: 4, 3: 5, 4: 8, 5: 8, 6: 12, 7: 5, 8: 4, 9: 5, 10: 12, 11: 16}
#: distances (m) from the Earth's centre of centres aligned into ECEF (the ellipsoid −1 km to +12 km)
ECEF_BAND = (6_355_000.0, 6_390_000.0)
NO_CRS = ("COLMAP coordinates have no CRS; give the CRS the model was aligned to (e.g. with colmap "
          "model_aligner)")


def _lines(path: Path, what: str):
    """``(line number, text)`` of ``path`` without comment lines (blank lines kept: an image's
    points line may be empty)."""
    text = read_text_file(path, what, hint="give the folder of a COLMAP text model")
    return [(i, ln.strip()) for i, ln in enumerate(text.splitlines(), 1) if not ln.lstrip().startswith("#")]


def _camera(parts: list, where: str):
    model = parts[1].upper()
    if model not in MODELS:
        raise ValueError(f"camera model {parts[1][:30]!r} cannot be converted to fotogeo's Brown model (only "
                         f"{', '.join(MODELS)}); re-run COLMAP with --ImageReader.camera_model OPENCV")
    names = MODELS[model]
    if len(parts) != 4 + len(names):
        raise ValueError(f"{model} needs {len(names)} parameters ({' '.join(names)}); got {len(parts) - 4}")
    w, h = int(parts[2]), int(parts[3])
    p = dict(zip(names, (float(v) for v in parts[4:])))
    if w <= 0 or h <= 0 or not np.isfinite(list(p.values())).all():
        raise ValueError("width, height must be positive and the parameters finite")
    if any(p.get(k, 0.0) for k in ("k4", "k5", "k6")):
        raise ValueError("FULL_OPENCV with k4, k5, k6 (a rational radial term) cannot be converted to fotogeo's "
                         "Brown model; re-run COLMAP with OPENCV")
    fx, fy = p.get("fx", p.get("f")), p.get("fy", p.get("f"))
    return pixel_camera(w, h, fx, fy, p["cx"], p["cy"], p, f"COLMAP {model} of {where}")


def read_colmap_cameras(path) -> dict:
    """``cameras.txt`` -> ``{camera id (str): ApproxCamera}`` (module docstring)."""
    path = Path(path)
    where = f"COLMAP cameras {str(path)!r}"
    cams = {}
    for lineno, ln in _lines(path, "COLMAP cameras file"):
        parts = ln.split()
        if not parts:
            continue
        try:
            if len(parts) < 4:
                raise ValueError("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]")
            cams[parts[0]] = _camera(parts, repr(str(path)))
        except ValueError as exc:
            raise InputError(one_line(f"{where}, line {lineno}: {exc}")) from None
    if not cams:
        raise InputError(f"{where} defines no camera; give a COLMAP text model (colmap model_converter "
                         f"--output_type TXT)")
    return cams


def _image(parts: list):
    """``(name, camera id, C, R_wc)`` of an ``images.txt`` image line."""
    q = np.array([float(v) for v in parts[1:5]])
    t = np.array([float(v) for v in parts[5:8]])
    n = np.linalg.norm(q)
    if not (np.isfinite(q).all() and np.isfinite(t).all()) or abs(n - 1.0) > 1e-3:
        raise ValueError(f"the quaternion QW QX QY QZ must be a finite unit quaternion; got {q.tolist()}")
    from scipy.spatial.transform import Rotation
    R = Rotation.from_quat(np.r_[q[1:], q[0]] / n).as_matrix()  # scipy takes (x, y, z, w)
    return parts[9].strip(), parts[8], -R.T @ t, R


def _is_points_line(text: str) -> bool:
    """An ``images.txt`` POINTS2D line: empty, or ``X Y POINT3D_ID`` triplets of numbers."""
    toks = text.split()
    try:
        [float(v) for v in toks]
    except ValueError:
        return False
    return len(toks) % 3 == 0


def read_colmap_images(path) -> list:
    """``images.txt`` -> ``[(name, camera id, C (3,), R_wc (3, 3))]`` (module docstring)."""
    path = Path(path)
    where = f"COLMAP images {str(path)!r}"
    out, expect_image = [], True
    for lineno, ln in _lines(path, "COLMAP images file"):
        parts = ln.split(maxsplit=9)
        if expect_image and not parts:
            continue
        if not expect_image and _is_points_line(ln):
            expect_image = True  # the image's POINTS2D line, possibly empty
            continue
        try:
            if len(parts) < 10:
                raise ValueError("expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME")
            out.append(_image(parts))
        except ValueError as exc:
            raise InputError(one_line(f"{where}, line {lineno}: {exc}")) from None
        expect_image = False
    if not out:
        raise InputError(f"{where} holds no image; COLMAP registered no image (re-run the mapper)")
    return out


def _model_file(folder: Path, name: str) -> Path:
    """``folder/name.txt``, else ``folder/name.bin``; refused naming both when neither is there."""
    for ext in (".txt", ".bin"):
        if (folder / (name + ext)).is_file():
            return folder / (name + ext)
    raise InputError(f"COLMAP model {str(folder)!r} has no {name}.txt or {name}.bin; give the folder of a COLMAP "
                     f"model (cameras, images){_models_below(folder)}")


def _models_below(folder: Path) -> str:
    """The hint naming the COLMAP models (``sparse/0``, ``0``) or OpenSfM files found a level or two below
    ``folder``, for the refusal of a folder that holds no model itself."""
    found = []
    for pattern in ("*/cameras.*", "*/*/cameras.*", "reconstruction.json", "opensfm/reconstruction.json"):
        found += [p for p in sorted(folder.glob(pattern)) if p.suffix in (".txt", ".bin", ".json")]
    if not found:
        return ""
    shown = sorted({str(p.parent if p.suffix != ".json" else p) for p in found})[:3]
    return f", e.g. {' or '.join(repr(s) for s in shown)} (found below it)"


def _unpack(data: bytes, at: int, fmt: str, where: str):
    import struct
    try:
        return struct.unpack_from("<" + fmt, data, at), at + struct.calcsize("<" + fmt)
    except struct.error:
        raise InputError(f"{where} ends early (byte {at}); the binary model is cut short — export it again (colmap "
                         f"model_converter --output_type BIN or TXT)") from None


def read_colmap_cameras_bin(path) -> dict:
    """``cameras.bin`` -> ``{camera id (str): ApproxCamera}`` (module docstring)."""
    path = Path(path)
    where = f"COLMAP cameras {str(path)!r}"
    data = path.read_bytes()
    (n,), at = _unpack(data, 0, "Q", where)
    cams = {}
    for _ in range(n):
        (cid, mid, w, h), at = _unpack(data, at, "iiQQ", where)
        if mid not in _N_PARAMS:
            raise InputError(f"{where}: camera {cid} has the unknown model id {mid}; give a COLMAP model")
        params, at = _unpack(data, at, f"{_N_PARAMS[mid]}d", where)
        try:
            cams[str(cid)] = _camera([str(cid), MODEL_IDS[mid], str(w), str(h), *map(repr, params)], repr(str(path)))
        except ValueError as exc:
            raise InputError(one_line(f"{where}, camera {cid}: {exc}")) from None
    if not cams:
        raise InputError(f"{where} defines no camera")
    return cams


def read_colmap_images_bin(path) -> list:
    """``images.bin`` -> ``[(name, camera id, C (3,), R_wc (3, 3))]`` (module docstring)."""
    path = Path(path)
    where = f"COLMAP images {str(path)!r}"
    data = path.read_bytes()
    (n,), at = _unpack(data, 0, "Q", where)
    out = []
    for _ in range(n):
        (iid, *pose, cid), at = _unpack(data, at, "i7di", where)
        end = data.find(b"\x00", at)
        if end < 0:
            raise InputError(f"{where}: image {iid} has no NUL-terminated name; the file is damaged")
        name, at = data[at:end].decode("utf-8", "replace"), end + 1
        (npts,), at = _unpack(data, at, "Q", where)
        at += 24 * npts
        try:
            out.append(_image([str(iid), *map(repr, pose), str(cid), name]))
        except ValueError as exc:
            raise InputError(one_line(f"{where}, image {iid}: {exc}")) from None
    if not out:
        raise InputError(f"{where} holds no image; COLMAP registered no image (re-run the mapper)")
    return out


def read_colmap(model_dir, crs=None, *, height_reference: str | None = None, gps=None) -> ApproximateBlock:
    """Read a COLMAP model (text or binary) geo-registered in ``crs`` (required; a projected CRS) or into ECEF
    (then expressed in ``crs``) into an :class:`ApproximateBlock` (module docstring); shots are keyed by the image's
    stem, cameras by COLMAP's ``CAMERA_ID``. ``height_reference`` (``"ellipsoid"``/``"geoid"``) states what Z is
    above when known (it is whatever the alignment positions were; ellipsoidal for ECEF). ``gps``: the images' own
    GPS ``{frame key: GpsFix}``, which aligns a model left in COLMAP's own frame (:mod:`fotogeo.io.colmap_align`)."""
    from ..crs import parse_crs, require_projected
    folder = Path(model_dir)
    if not folder.is_dir():
        raise InputError(f"COLMAP model {str(folder)!r} is not a folder; give the folder holding cameras.txt "
                         f"and images.txt")
    if crs is None:
        raise InputError(f"COLMAP model {str(folder)!r}: {NO_CRS}")
    map_crs = require_projected(parse_crs(crs, "COLMAP model CRS"), "COLMAP model CRS")
    cf, imf = _model_file(folder, "cameras"), _model_file(folder, "images")
    cams = read_colmap_cameras(cf) if cf.suffix == ".txt" else read_colmap_cameras_bin(cf)
    images = read_colmap_images(imf) if imf.suffix == ".txt" else read_colmap_images_bin(imf)
    images, frame, aligned, ref = _in_map(images, map_crs, f"COLMAP model {str(folder)!r}", gps)
    height_reference = ref if frame in ("ecef", "gps") else height_reference
    shots = {}
    for name, cid, C, R in images:
        key = frame_key(name)
        if cid not in cams:
            raise InputError(f"COLMAP model {str(folder)!r}: image {name!r} uses camera {cid}, which cameras.txt "
                             f"does not define")
        if key in shots:
            raise InputError(f"COLMAP model {str(folder)!r}: two images have the stem {key!r}; fotogeo keys frames "
                             f"by file stem: rename them")
        shots[key] = ApproxShot(key, cid, tuple(C), patb_from_world_to_camera(R),
                                height_reference=height_reference, source="COLMAP model", project_name=name)
    used = {s.camera_id for s in shots.values()}
    notes = (f"read from COLMAP model {str(folder)!r}",
             f"model coordinates taken as {map_crs.name} (X easting, Y northing, Z up)" if frame == "map" else
             f"model coordinates are ECEF (colmap model_aligner --alignment_type ecef), expressed in {map_crs.name}"
             if frame == "ecef" else f"model aligned into {map_crs.name}: {aligned}",
             "heights: " + (f"above the {height_reference}" if height_reference else
                            "in the vertical reference of the alignment positions (not stated)"))
    return ApproximateBlock({c: cams[c] for c in cams if c in used}, shots, map_crs, notes, frame_reading=aligned)


def _in_map(images: list, map_crs, where: str, gps=None) -> tuple:
    """``(images with centres and rotations in map_crs, "map" | "ecef" | "gps", sentence, height reference)``
    (module docstring: ECEF detected — ellipsoidal heights; coordinates outside the CRS's area of use aligned to the
    images' ``gps`` — their altitudes' common reference, None when unknown — or refused)."""
    from ..crs import outside_area_of_use
    C = np.array([c for _, _, c, _ in images], float)
    if not outside_area_of_use(map_crs, C[:, :2], 1.0).any():  # widened by 1°: a block may overhang a zone
        return images, "map", "", None
    r = np.linalg.norm(C, axis=1)
    if not np.all((r > ECEF_BAND[0]) & (r < ECEF_BAND[1])):
        from .colmap_align import MIN_IMAGES, align_to_gps
        aligned = align_to_gps(images, gps, map_crs, where) if gps else None
        if aligned is not None:
            return aligned[0], "gps", *aligned[1:]
        e = np.median(C, axis=0)
        raise InputError(f"{where}: its camera centres (around {e[0]:.6g}, {e[1]:.6g}, {e[2]:.6g}) are not in "
                         f"{map_crs.name} (outside its area of use) nor in ECEF; the model is in COLMAP's own frame or "
                         f"another CRS: geo-register it (colmap model_aligner) and give the CRS of its positions "
                         f"(--crs), or give at least {MIN_IMAGES} of its images carrying GPS (EXIF) to align it")
    from ..geometry.local_frames import ecef_to_map
    xyz, M = ecef_to_map(C, map_crs)
    out = [(n, cid, p, R @ m.T) for (n, cid, _, R), p, m in zip(images, xyz, M)]
    return out, "ecef", "", "ellipsoid"


def _colmap_ids(block: ApproximateBlock) -> dict:
    """COLMAP's integer CAMERA_IDs for the block's camera ids (kept when they are positive integers)."""
    ids = list(block.cameras)
    if all(str(i).isdigit() and int(i) > 0 for i in ids) and len({int(i) for i in ids}) == len(ids):
        return {i: int(i) for i in ids}
    return {i: k for k, i in enumerate(ids, 1)}


def _camera_line(cid: int, cam) -> str:
    c, d = cam.camera, cam.distortion_tuple()  # (k1, k2, k3, p1, p2)
    w, h = c.image_size
    (ppx, ppy), (k1, k2, k3, p1, p2) = c.principal_point, d
    if not any(d):
        return f"{cid} PINHOLE {w} {h} {c.fx!r} {c.fy!r} {ppx!r} {ppy!r}"
    if k3 == 0.0:
        return f"{cid} OPENCV {w} {h} {c.fx!r} {c.fy!r} {ppx!r} {ppy!r} {k1!r} {k2!r} {p1!r} {p2!r}"
    return f"{cid} FULL_OPENCV {w} {h} {c.fx!r} {c.fy!r} {ppx!r} {ppy!r} {k1!r} {k2!r} {p1!r} {p2!r} {k3!r} 0 0 0"


def write_colmap(model_dir, block: ApproximateBlock, *, extension: str = ".jpg") -> None:
    """Write ``block`` as a COLMAP text model in ``model_dir`` (created): ``cameras.txt`` (PINHOLE,
    OPENCV, or FULL_OPENCV when k3 ≠ 0), ``images.txt`` (an empty points line per image; image names
    are the shot names plus ``extension``) and an empty ``points3D.txt``. Shots without position or
    angles are left out; the coordinates are the block's map coordinates."""
    from scipy.spatial.transform import Rotation
    folder = Path(model_dir)
    folder.mkdir(parents=True, exist_ok=True)
    ids = _colmap_ids(block)
    cams = ["# Camera list with one line of data per camera:", "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]"]
    cams += [_camera_line(ids[c], cam) for c, cam in block.cameras.items()]
    imgs = ["# Image list with two lines of data per image:", "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME",
            "#   POINTS2D[] as (X, Y, POINT3D_ID)"]
    for k, s in enumerate((s for s in block.shots.values() if s.exterior is not None), 1):
        R = world_to_camera_from_patb(s.angles)
        x, y, z, w = Rotation.from_matrix(R).as_quat()
        t = -R @ np.asarray(s.position)
        pose = " ".join(repr(float(v)) for v in (w, x, y, z, *t))
        imgs += [f"{k} {pose} {ids[s.camera_id]} {s.name}{extension}", ""]
    (folder / "cameras.txt").write_text("\n".join(cams) + "\n", encoding="utf-8")
    (folder / "images.txt").write_text("\n".join(imgs) + "\n", encoding="utf-8")
    (folder / "points3D.txt").write_text("# 3D point list with one line of data per point:\n", encoding="utf-8")
