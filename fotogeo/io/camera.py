"""Camera files: orthority-style interior orientation YAML, ``name X Y Z omega phi kappa``
exterior orientation text, and the NGI frames built from both.

:func:`read_interior_orientation` reads the YAML through :func:`fotogeo.io.yaml_file.read_yaml_mapping`
(PyYAML's safe loader); the principal point convention is explained there.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

from ..errors import InputError, one_line
from ..geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from .text import read_text_file
from .yaml_file import read_yaml_mapping


def _number(d: dict, key: str, kind=float, default=None):
    """``d[key]`` as a finite ``kind`` (int or float); ValueError names the key."""
    value = d.get(key, default)
    if value is None:
        raise ValueError(f"{key} is missing")
    if isinstance(value, (list, dict, bool)) or not isinstance(value, (int, float)):
        raise ValueError(f"{key} must be a number; got {str(value)[:40]!r}")
    if not math.isfinite(value) or (kind is int and value != int(value)):
        raise ValueError(f"{key} must be a finite {'whole ' if kind is int else ''}number; got {value!r}")
    return kind(value)


def _pair(d: dict, key: str, kind):
    """``d[key]`` as two finite positive numbers ``[w, h]``; ValueError names the key."""
    value = d.get(key)
    if not isinstance(value, list) or len(value) != 2:
        raise ValueError(f"{key} must be [width, height]; got {str(value)[:40]!r}")
    w, h = (_number({key: v}, key, kind) for v in value)
    if w <= 0 or h <= 0:
        raise ValueError(f"{key} must be positive; got [{w}, {h}]")
    return w, h


#: orthority's Brown distortion terms (OpenCV's model, the bundle adjustment's), in file order
BROWN_TERMS = ("k1", "k2", "p1", "p2", "k3")


def _frame_camera(d, types=("pinhole",)) -> FrameCamera:
    """A pinhole :class:`FrameCamera` from one camera's dict; ValueError says which value is wrong."""
    if not isinstance(d, dict):
        raise ValueError(f"a camera must be a block of indented 'key: value' lines; got {str(d)[:40]!r}")
    if d.get("type", "pinhole") not in types:
        raise ValueError(f"type {str(d.get('type'))[:40]!r} is not supported here; only "
                         f"{' or '.join(map(repr, types))} {'is' if len(types) == 1 else 'are'}"
                         + (" (a 'brown' camera with distortion is read by triangulate)" if "brown" not in types else ""))
    w, h = _pair(d, "im_size", int)
    sw, sh = _pair(d, "sensor_size", float)
    f = _number(d, "focal_len")
    if f <= 0:
        raise ValueError(f"focal_len must be positive; got {f}")
    m = max(w, h)
    pp = (w / 2.0 + _number(d, "cx", default=0.0) * m, h / 2.0 + _number(d, "cy", default=0.0) * m)
    return FrameCamera(f, (sw, sh), (w, h), pp)


def read_interior_orientation(path) -> dict[str, FrameCamera]:
    """Read an orthority-style interior orientation YAML: camera id -> :class:`FrameCamera`.

    Per camera: ``type: pinhole``, ``im_size: [w, h]``, ``focal_len``, ``sensor_size: [w, h]``
    and optional ``cx``, ``cy``: the principal point offset from the image centre in units of
    ``max(w, h)`` pixels (orthority's normalised convention), so
    ``ppx = w/2 + cx·max(w, h)``, ``ppy = h/2 + cy·max(w, h)`` (corner convention).
    Any problem is one :class:`InputError` naming the file, the line and the value.
    """
    path = Path(path)
    text = read_text_file(path, "interior orientation file", hint="give the YAML file")
    data, lines = read_yaml_mapping(text, f"interior orientation {str(path)!r}, ")
    cams = {}
    for cid, d in data.items():
        try:
            cams[cid] = _frame_camera(d)
        except (ValueError, TypeError, OverflowError, ZeroDivisionError, InputError) as exc:
            raise InputError(one_line(f"interior orientation {str(path)!r}, line {lines[cid]}: camera {cid!r}: {exc}; "
                                      f"it needs im_size [w, h], sensor_size [w, h] and focal_len "
                                      f"(type pinhole, optional cx, cy)")) from None
    return cams


def read_camera_with_distortion(path) -> tuple[FrameCamera, dict]:
    """The first camera of an interior orientation YAML and its distortion ``{k1, k2, k3, p1, p2}``.

    Besides ``type: pinhole`` (no distortion) it reads orthority's ``type: brown`` with the
    optional terms ``k1, k2, p1, p2, k3`` (OpenCV's Brown (1971) model on the focal-length-
    normalised camera coordinates, the model of :mod:`fotogeo.orientation.bundle_jacobian`),
    which is what ``fotogeo triangulate`` writes after self-calibration, so its ``camera.yaml``
    is a valid ``--camera`` of the next run.
    """
    path = Path(path)
    text = read_text_file(path, "interior orientation file", hint="give the YAML file")
    data, lines = read_yaml_mapping(text, f"interior orientation {str(path)!r}, ")
    if not data:
        raise InputError(f"camera file {str(path)!r} defines no camera")
    cid, d = next(iter(data.items()))
    if isinstance(d, dict) and "projection_type" in d:
        return _opensfm_cameras(path, data, lines)
    try:
        cam = _frame_camera(d, ("pinhole", "brown"))
        dist = {k: _number(d, k, default=0.0) for k in BROWN_TERMS}
        if d.get("type", "pinhole") == "pinhole" and any(dist.values()):
            raise ValueError("distortion terms need type: brown")
    except (ValueError, TypeError, OverflowError, ZeroDivisionError, InputError) as exc:
        raise InputError(one_line(f"interior orientation {str(path)!r}, line {lines[cid]}: camera {cid!r}: {exc}; "
                                  f"it needs im_size [w, h], sensor_size [w, h] and focal_len (type pinhole, or "
                                  f"brown with k1, k2, p1, p2, k3; optional cx, cy)")) from None
    return cam, dist


def _opensfm_cameras(path: Path, data: dict, lines: dict) -> tuple[FrameCamera, dict]:
    """The one camera of ODM's ``cameras.json`` (OpenSfM camera dicts by id, ``projection_type``; read by
    :func:`fotogeo.io.opensfm.camera_from_opensfm`) and its distortion; several cameras are refused by name (which
    image has which is in the reconstruction.json)."""
    from .opensfm import camera_from_opensfm
    if len(data) > 1:
        raise InputError(f"camera file {str(path)!r} is ODM's/OpenSfM's cameras.json with {len(data)} cameras; give "
                         f"it without --camera beside opensfm/reconstruction.json (which names each image's camera) "
                         f"or one camera")
    cid, d = next(iter(data.items()))
    try:
        c = camera_from_opensfm(d, f"OpenSfM camera {cid!r} of {str(path)!r}")
    except (ValueError, TypeError) as exc:
        raise InputError(one_line(f"camera file {str(path)!r} (ODM/OpenSfM cameras.json), line {lines[cid]}: camera "
                                  f"{cid!r}: {exc}")) from None
    return c.camera, {k: float(c.distortion.get(k, 0.0)) for k in BROWN_TERMS}


def read_exterior_orientation(path) -> dict[str, ExteriorOrientation]:
    """Read ``name X Y Z omega phi kappa`` lines (metres, degrees; ``#`` comments at a line's start or after a
    space). A name may hold spaces: quoted as the shell quotes (what :func:`fotogeo.io.block.write_exterior_orientation`
    writes), or bare — the last six values are the numbers and the rest of the line is the name. Lines of seven
    comma- or semicolon-separated fields are read too (they were refused as not 'name X Y Z omega phi kappa')."""
    path = Path(path)
    out = {}
    text = read_text_file(path, "exterior orientation file", hint="give the text file of 'name X Y Z omega phi kappa' lines")
    for lineno, raw in enumerate(text.splitlines(), 1):
        parts = _eo_fields(raw)
        if parts is None:
            continue
        if len(parts) != 7:  # comma or semicolon separated (a spreadsheet's export): the same seven fields
            parts = [p.strip() for p in re.split(r"[,;]", raw.split(" #")[0].strip())]
        if len(parts) != 7:
            raise InputError(one_line(f"{path}, line {lineno}: expected 'name X Y Z omega phi kappa'; got {raw!r}"))
        try:
            out[parts[0]] = ExteriorOrientation(*(float(v) for v in parts[1:]))
        except ValueError:
            raise InputError(one_line(f"{path}, line {lineno}: non-numeric orientation value in {raw!r}")) from None
    return out


#: file extensions an orientation line may keep on an image's name (``IMG_0001.JPG``: Pix4D, Metashape exports)
IMAGE_SUFFIXES = (".tif", ".tiff", ".jpg", ".jpeg", ".png", ".jp2", ".dng")


def exterior_for(table: dict, name: str):
    """The pose of image ``name`` (its file name without extension) in ``table`` (:func:`read_exterior_orientation`):
    the line named ``name``, else the one line named ``name`` plus an image extension (any case); None otherwise.

    >>> exterior_for({"IMG_1.JPG": 1, "IMG_2": 2}, "IMG_1"), exterior_for({"IMG_2": 2}, "IMG_1")
    (1, None)
    """
    if name in table:
        return table[name]
    hits = [v for k, v in table.items() if Path(k).stem == name and Path(k).suffix.lower() in IMAGE_SUFFIXES]
    return hits[0] if len(hits) == 1 else None


def exterior_orientation_crs(path):
    """The CRS a fotogeo-written orientation file states in its header (``# fotogeo …, CRS EPSG:32654``, what
    triangulate writes), or None when it states none (lines from elsewhere: the caller's CRS applies)."""
    import re

    from ..crs import parse_crs
    text = read_text_file(Path(path), "exterior orientation file",
                          hint="give the text file of 'name X Y Z omega phi kappa' lines")
    for raw in text.splitlines():
        if raw.strip() and not raw.lstrip().startswith("#"):
            return None  # the header is above the first orientation line
        found = re.match(r"^\s*#\s*fotogeo\b.*,\s*CRS\s+(\S.*?)\s*$", raw)
        if found:
            return parse_crs(found.group(1), f"the CRS written in {path}")
    return None


def _eo_fields(raw: str):
    """``[name, six values]`` of one line (:func:`read_exterior_orientation`), None for a blank or comment line;
    fewer fields when the line has fewer."""
    import shlex
    text = raw.strip()
    if not text or text.startswith("#"):
        return None
    if text[0] in "'\"":
        try:
            return shlex.split(text, comments=True)
        except ValueError:  # an unclosed quote
            return [text]
    fields = re.split(r"\s#", text, maxsplit=1)[0].split()
    if len(fields) <= 7:
        return fields
    name = re.match(r"^(.*?)\s+" + r"\s+".join([r"\S+"] * 6) + r"\s*$", re.split(r"\s#", text, maxsplit=1)[0])
    return [name.group(1), *fields[-6:]]


def load_ngi_frame(ngi_dir, name: str) -> OrientedFrame:
    """The true geometry of an NGI frame: ``load_ngi_frame(data / "ngi", "3324c_2015_1004_05_0182")``.

    ``name`` may omit the ``_RGB`` suffix and the ``.tif`` extension. Reads
    ``interior_orientation.yaml`` (one camera) and ``exterior_orientation.txt``.
    """
    ngi_dir = Path(ngi_dir)
    cams = read_interior_orientation(ngi_dir / "interior_orientation.yaml")
    if len(cams) != 1:
        raise InputError(f"{ngi_dir}/interior_orientation.yaml: expected one camera, found {len(cams)}")
    eos = read_exterior_orientation(ngi_dir / "exterior_orientation.txt")
    stem = Path(name).name.removesuffix(".tif")
    for key in (stem, stem + "_RGB"):
        if key in eos:
            return OrientedFrame(next(iter(cams.values())), eos[key], key)
    raise InputError(f"frame {name!r} not in {ngi_dir}/exterior_orientation.txt; "
                     f"known frames: {', '.join(eos)}")


def load_camera(camera):
    """A FrameCamera from an object or an interior-orientation YAML file (its only, or first, camera)."""
    if camera is None or hasattr(camera, "focal_length"):
        return camera
    from .camera import read_interior_orientation
    cams = read_interior_orientation(camera)
    if not cams:
        raise InputError(f"camera file {camera!r} defines no camera")
    return next(iter(cams.values()))
