"""orthority's camera files -> :class:`ApproximateBlock`, and back (format only: orthority's
documentation, ``docs/file_formats/{oty_int,oty_ext,csv}.rst`` and ``docs/background/``; orthority
is AGPL and none of its code is used here).

* **Interior parameters** (YAML, :func:`read_orthority_interior`): camera id -> ``type``
  (``pinhole``, ``brown``; ``opencv`` when only its first five coefficients are used; ``fisheye``
  is refused), ``im_size [w, h]``, ``focal_len`` (one value or ``[fx, fy]``), optional
  ``sensor_size [w, h]`` in the unit of ``focal_len`` (without it ``focal_len`` is normalised by
  ``max(w, h)``), ``cx, cy`` (principal point offsets from the image centre in units of
  ``max(w, h)``: ``ppx = w/2 + cx·max(w, h)`` in the corner convention, as
  :func:`fotogeo.io.camera.read_interior_orientation`) and ``k1, k2, p1, p2, k3`` (OpenCV's Brown
  model, fotogeo's). Parsed with :mod:`fotogeo.io.camera`'s YAML subset.
* **Exterior parameters, GeoJSON** (``*.geojson``, orthority's native format): a
  ``FeatureCollection`` with a ``world_crs`` member; per ``Point`` feature the properties
  ``filename``, ``camera`` (may be null), ``xyz`` (world CRS) and ``opk`` (radians); the geometry
  (lon, lat) is not read.
* **Exterior parameters, CSV**: a header naming ``filename, x, y, z, omega, phi, kappa`` and an
  optional ``camera`` (other columns ignored), or no header and the legacy order ``filename x y z
  omega phi kappa`` (fotogeo's ``exterior_orientation.txt``); comma, tab, semicolon, colon or space
  delimited; angles in degrees unless ``radians``; the CRS from a ``.prj`` file beside it unless
  given. Positions as ``latitude, longitude, altitude`` and angles as ``roll, pitch, yaw`` are
  refused by name.

orthority's (ω, φ, κ) rotate camera to world axes with the camera axes in the PATB convention
(x right, y up, z back; ``docs/background/coordinates.rst``): fotogeo's convention
(:mod:`fotogeo.geometry.camera`), so the angles are taken as they are (orthority reads the NGI
camera YAML and exterior orientation unchanged, GUIDE.md §7).
"""
from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np

from ..errors import InputError, one_line
from ..geometry.approx_block import ApproxCamera, ApproximateBlock, ApproxShot
from ..geometry.camera import FrameCamera
from .block import frame_key
from .camera import _number, _pair
from .yaml_file import read_yaml_mapping
from .opensfm import load_json, pixel_camera
from .text import read_text_file

_BROWN = ("k1", "k2", "p1", "p2", "k3")
_OPENCV_EXTRA = ("k4", "k5", "k6", "s1", "s2", "s3", "s4", "tx", "ty")
_CSV_FIELDS = ("filename", "x", "y", "z", "omega", "phi", "kappa")


# -- interior -------------------------------------------------------------------------------------
def _focal(d: dict) -> tuple[float, float]:
    f = d.get("focal_len")
    fx, fy = (_pair(d, "focal_len", float) if isinstance(f, list) else (_number(d, "focal_len"),) * 2)
    if fx <= 0 or fy <= 0:
        raise ValueError(f"focal_len must be positive; got {f}")
    return fx, fy


def orthority_camera(d, source: str = "") -> ApproxCamera:
    """One camera's dict of an orthority interior file -> :class:`ApproxCamera`; ValueError says why not."""
    if not isinstance(d, dict):
        raise ValueError("a camera must be a block of indented 'key: value' lines")
    kind = d.get("type", "pinhole")
    if kind not in ("pinhole", "brown", "opencv"):
        raise ValueError(f"type {str(kind)[:30]!r} cannot be converted to fotogeo's Brown model (pinhole, brown, or "
                         f"opencv with k1, k2, p1, p2, k3 only)")
    extra = [k for k in _OPENCV_EXTRA if _number(d, k, default=0.0)]
    if extra:
        raise ValueError(f"coefficients {', '.join(extra)} are beyond fotogeo's Brown model (k1, k2, p1, p2, k3)")
    dist = {k: _number(d, k, default=0.0) for k in _BROWN}
    if kind == "pinhole" and any(dist.values()):
        raise ValueError("distortion coefficients need type: brown")
    w, h = _pair(d, "im_size", int)
    fx, fy = _focal(d)
    m = max(w, h)
    pp = (w / 2.0 + _number(d, "cx", default=0.0) * m, h / 2.0 + _number(d, "cy", default=0.0) * m)
    source = source or f"orthority {kind} camera"
    if "sensor_size" not in d:
        return pixel_camera(w, h, fx * m, fy * m, *pp, dist, source)
    sw, sh = _pair(d, "sensor_size", float)
    return ApproxCamera(FrameCamera(fx, (sw, sh * fx / fy) if fx != fy else (sw, sh), (w, h), pp), dist, source)


def read_orthority_interior(path) -> dict:
    """An orthority interior-parameter YAML -> ``{camera id: ApproxCamera}`` (module docstring)."""
    path = Path(path)
    text = read_text_file(path, "orthority interior parameters", hint="give the YAML file")
    data, lines = read_yaml_mapping(text, f"orthority interior parameters {str(path)!r}, ")
    cams = {}
    for cid, d in data.items():
        try:
            cams[cid] = orthority_camera(d, f"orthority camera {cid!r} of {str(path)!r}")
        except (ValueError, TypeError, OverflowError, ZeroDivisionError, InputError) as exc:
            raise InputError(one_line(f"orthority interior parameters {str(path)!r}, line {lines[cid]}: camera "
                                      f"{cid!r}: {exc}")) from None
    if not cams:
        raise InputError(f"orthority interior parameters {str(path)!r} define no camera; give 'id:' blocks with "
                         f"type, im_size, focal_len")
    return cams


def write_orthority_interior(path, cameras: dict) -> None:
    """``{id: ApproxCamera}`` as an orthority interior YAML (``brown`` with distortion, else ``pinhole``)."""
    out = []
    for cid, cam in cameras.items():
        c = cam.camera
        w, h = c.image_size
        m = max(w, h)
        brown = any(cam.distortion_tuple())
        out += [f"{cid}:", f"    type: {'brown' if brown else 'pinhole'}", f"    im_size: [{int(w)}, {int(h)}]",
                f"    focal_len: {c.focal_length!r}", f"    sensor_size: [{c.sensor_size[0]!r}, {c.sensor_size[1]!r}]",
                f"    cx: {(c.principal_point[0] - w / 2.0) / m!r}", f"    cy: {(c.principal_point[1] - h / 2.0) / m!r}"]
        out += [f"    {k}: {float(cam.distortion.get(k, 0.0))!r}" for k in _BROWN] if brown else []
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8")


# -- exterior -------------------------------------------------------------------------------------
def _rows_geojson(path: Path) -> tuple[list, object]:
    """``[(filename, camera | None, xyz, opk in degrees)]`` and the ``world_crs`` of a GeoJSON file."""
    fix = "give orthority's exterior parameters (a FeatureCollection with world_crs and filename, camera, xyz, opk)"
    data = load_json(path, "orthority exterior parameters", fix)
    refuse_odm_shots(path, data)
    feats = data.get("features") if isinstance(data, dict) else None
    if not isinstance(feats, list):
        raise InputError(f"orthority exterior parameters {str(path)!r} is not a GeoJSON FeatureCollection; {fix}")
    rows = []
    for i, f in enumerate(feats):
        p = f.get("properties") if isinstance(f, dict) else None
        try:
            if not isinstance(p, dict):
                raise ValueError("no properties")
            xyz, opk = (np.asarray(p.get(k), float).reshape(3) for k in ("xyz", "opk"))
            if not (np.isfinite(xyz).all() and np.isfinite(opk).all()):
                raise ValueError("xyz and opk must be finite")
            rows.append((str(p["filename"]), p.get("camera"), xyz, np.degrees(opk)))
        except (ValueError, TypeError, KeyError) as exc:
            raise InputError(one_line(f"orthority exterior parameters {str(path)!r}, feature {i}: {exc}; each needs "
                                      f"filename, xyz [x, y, z] and opk [omega, phi, kappa] in radians")) from None
    return rows, data.get("world_crs")


def refuse_odm_shots(path, data=None) -> None:
    """Refuse ODM's ``odm_report/shots.geojson`` by name: a FeatureCollection whose first feature's properties are
    ``filename, focal, width, height, translation, rotation`` (ODM's ``opendm/shots.py``) and no ``xyz``/``opk``.
    ``translation`` is the camera centre in a UTM zone the file does not state (or in the local frame of an
    unreferenced project) and ``rotation`` an OpenSfM axis-angle vector (world -> camera, camera axes x right,
    y down, z forward), not orthority's PATB ω, φ, κ; the same project's ``opensfm/reconstruction.json`` holds these
    poses with their reference (read by :func:`fotogeo.io.opensfm.read_opensfm`): named by its path when it is
    there, else by where ODM writes it. ``data``: the file's parsed JSON (read here when None)."""
    if data is None:
        data = load_json(path, "orthority exterior parameters", "give orthority's exterior parameters")
    feats = data.get("features") if isinstance(data, dict) else None
    first = feats[0] if isinstance(feats, list) and feats and isinstance(feats[0], dict) else {}
    props = first.get("properties")
    if not isinstance(props, dict) or not {"translation", "rotation"} <= set(props) or {"xyz", "opk"} & set(props):
        return
    project = Path(path).resolve().parent
    rec = (project.parent if project.name == "odm_report" else project) / "opensfm" / "reconstruction.json"
    fix = (f"give the same ODM project's reconstruction instead (--eo {str(rec)!r})" if rec.is_file() else
           "give instead the reconstruction ODM writes in the project's folder (the one holding odm_report): "
           "opensfm/reconstruction.json (--eo)")
    raise InputError(f"{str(path)!r} is ODM's shots.geojson (translation, rotation: OpenSfM's axis-angle poses in a "
                     f"UTM zone the file does not state), not orthority's exterior parameters (xyz, opk); {fix}")


def _sniff(line: str) -> str | None:
    """The CSV delimiter of ``line`` (None: whitespace), looked for outside quoted values."""
    import re
    bare = re.sub(r"\"[^\"]*\"|'[^']*'", "", line)
    for d in ("\t", ",", ";", ":"):
        if d in bare:
            return d
    return None


def _split(line: str, delim) -> list:
    if delim is None:
        return next(csv.reader(io.StringIO(line.strip()), delimiter=" ", skipinitialspace=True))
    return [v.strip() for v in next(csv.reader(io.StringIO(line), delimiter=delim, skipinitialspace=True))]


def _csv_fields(first: list, where: str) -> tuple[list, bool]:
    """The field names and whether the first line is a header (module docstring)."""
    names = [f.strip().lower() for f in first]
    if "filename" not in names:
        return list(_CSV_FIELDS), False
    for bad, fix in ((("latitude", "longitude", "altitude"), "x, y, z in a projected CRS"),
                     (("roll", "pitch", "yaw"), "omega, phi, kappa")):
        if any(b in names for b in bad) and not all(k in names for k in ("x", "y", "z", "omega", "phi", "kappa")):
            raise InputError(f"{where}: positions or angles as {', '.join(bad)} are not supported; give {fix}")
    missing = [k for k in _CSV_FIELDS if k not in names]
    if missing:
        raise InputError(f"{where}: the header lacks {', '.join(missing)}; give filename, x, y, z, omega, phi, kappa "
                         f"[, camera]")
    return names, True


def _rows_csv(path: Path, radians: bool) -> tuple[list, object]:
    """``[(filename, camera | None, xyz, opk in degrees)]`` and the CRS of a ``.prj`` beside the CSV."""
    where = f"orthority exterior parameters {str(path)!r}"
    text = read_text_file(path, "orthority exterior parameters", hint="give the CSV file")
    lines = [(i, ln) for i, ln in enumerate(text.splitlines(), 1) if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"{where} is empty; give lines 'filename x y z omega phi kappa'")
    delim = _sniff(lines[0][1])
    names, header = _csv_fields(_split(lines[0][1], delim), where)
    rows = []
    for lineno, ln in lines[1:] if header else lines:
        vals = dict(zip(names, _split(ln, delim)))
        try:
            xyz = np.array([float(vals[k]) for k in ("x", "y", "z")])
            opk = np.array([float(vals[k]) for k in ("omega", "phi", "kappa")])
            if not (np.isfinite(xyz).all() and np.isfinite(opk).all()):
                raise ValueError
        except (KeyError, ValueError):
            raise InputError(one_line(f"{where}, line {lineno}: expected {', '.join(names)}; got {ln!r}")) from None
        rows.append((vals["filename"], vals.get("camera") or None, xyz, np.degrees(opk) if radians else opk))
    prj = path.with_suffix(".prj")
    return rows, (read_text_file(prj, "CRS file").strip() if prj.is_file() else None)


def read_orthority(exterior, interior, crs=None, *, radians: bool = False) -> ApproximateBlock:
    """Read orthority exterior parameters (``.geojson``/``.json``, or CSV otherwise) and interior
    parameters (YAML) into an :class:`ApproximateBlock` (module docstring). ``crs`` overrides the
    file's CRS (``world_crs``, ``.prj``) and is required when the file has none; ``radians`` is for
    CSV angles. An image without camera id uses the only camera of ``interior``."""
    from ..crs import parse_crs, require_projected
    path = Path(exterior)
    where = f"orthority exterior parameters {str(path)!r}"
    cams = read_orthority_interior(interior)
    rows, file_crs = _rows_geojson(path) if path.suffix.lower() in (".geojson", ".json") else _rows_csv(path, radians)
    if not rows:
        raise InputError(f"{where} holds no image")
    if crs is None and not file_crs:
        raise InputError(f"{where} states no CRS (no world_crs, no .prj beside it); give the CRS of x, y, z")
    map_crs = require_projected(parse_crs(crs if crs is not None else file_crs, f"CRS of {where}"), f"CRS of {where}")
    shots = {}
    for name, cid, xyz, opk in rows:
        if cid is None and len(cams) != 1:
            raise InputError(f"{where}: image {name!r} names no camera and {str(interior)!r} defines {len(cams)}; "
                             f"give each image's camera id")
        cid = str(cid) if cid is not None else next(iter(cams))
        if cid not in cams:
            raise InputError(f"{where}: image {name!r} uses camera {cid!r}, which {str(interior)!r} does not define "
                             f"(it defines {', '.join(map(repr, list(cams)[:5]))})")
        key = frame_key(name)
        if key in shots:
            raise InputError(f"{where}: image {key!r} appears twice; give each image once")
        shots[key] = ApproxShot(key, cid, tuple(xyz), tuple(float(a) for a in opk), source="orthority exterior parameters")
    used = {s.camera_id for s in shots.values()}
    notes = (f"read from {str(path)!r} and {str(interior)!r}", f"CRS {map_crs.name}" + (" (given)" if crs else ""),
             "orthority's omega, phi, kappa are PATB angles, taken as they are")
    return ApproximateBlock({c: v for c, v in cams.items() if c in used}, shots, map_crs, notes)


def _oriented(block: ApproximateBlock) -> list:
    if block.crs is None:
        raise InputError("the block has no CRS; orthority's exterior parameters need one")
    return [s for s in block.shots.values() if s.exterior is not None]


def write_orthority_geojson(path, block: ApproximateBlock, *, extension: str = ".jpg") -> None:
    """The oriented shots of ``block`` as orthority's GeoJSON exterior parameters (module docstring)."""
    from pyproj import Transformer
    shots = _oriented(block)
    t = Transformer.from_crs(block.crs, 4326, always_xy=True)
    feats = []
    for s in shots:
        lon, lat = t.transform(s.position[0], s.position[1])
        feats.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": [lon, lat, s.position[2]]},
                      "properties": {"filename": s.name + extension, "camera": s.camera_id, "xyz": list(s.position),
                                     "opk": [math.radians(a) for a in s.angles]}})
    crs = block.crs.to_string() if block.crs.to_epsg() else block.crs.to_wkt()
    Path(path).write_text(json.dumps({"type": "FeatureCollection", "world_crs": crs, "features": feats}, indent=1),
                          encoding="utf-8")


def write_orthority_csv(path, block: ApproximateBlock, *, radians: bool = False, extension: str = ".jpg") -> None:
    """The oriented shots of ``block`` as orthority's CSV (header, comma-delimited, degrees unless
    ``radians``) and its CRS as WKT in a ``.prj`` beside it."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow([*_CSV_FIELDS, "camera"])
    for s in _oriented(block):
        a = [math.radians(v) for v in s.angles] if radians else list(s.angles)
        w.writerow([s.name + extension, *(repr(float(v)) for v in (*s.position, *a)), s.camera_id])
    Path(path).write_text(out.getvalue(), encoding="utf-8")
    Path(path).with_suffix(".prj").write_text(block.crs.to_wkt(), encoding="utf-8")
