"""Camera files: orthority-style interior orientation YAML, ``name X Y Z omega phi kappa``
exterior orientation text, and the NGI frames built from both.

:func:`read_interior_orientation` parses the small YAML subset itself (no PyYAML needed);
the principal point convention is explained there.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from ..geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame


def _parse_value(text: str):
    text = text.strip()
    if text.startswith("[") and text.endswith("]"):
        return [_parse_value(t) for t in text[1:-1].split(",") if t.strip()]
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return text.strip("'\"")


def _parse_simple_yaml(text: str) -> dict:
    """Parse the two-level ``key: value`` YAML subset of orthority interior-orientation files."""
    out: dict = {}
    stack = [(-1, out)]
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].rstrip()
        if not line.strip():
            continue
        indent = len(line) - len(line.lstrip())
        key, sep, value = line.strip().partition(":")
        if not sep:
            raise InputError(f"line {lineno}: expected 'key: value', got {raw!r}")
        while indent <= stack[-1][0]:
            stack.pop()
        parent = stack[-1][1]
        if value.strip():
            parent[key.strip()] = _parse_value(value)
        else:
            parent[key.strip()] = child = {}
            stack.append((indent, child))
    return out


def read_interior_orientation(path) -> dict[str, FrameCamera]:
    """Read an orthority-style interior orientation YAML: camera id -> :class:`FrameCamera`.

    Per camera: ``type: pinhole``, ``im_size: [w, h]``, ``focal_len``, ``sensor_size: [w, h]``
    and optional ``cx``, ``cy``: the principal point offset from the image centre in units of
    ``max(w, h)`` pixels (orthority's normalised convention), so
    ``ppx = w/2 + cx·max(w, h)``, ``ppy = h/2 + cy·max(w, h)`` (corner convention).
    """
    path = Path(path)
    try:
        data = _parse_simple_yaml(path.read_text())
    except OSError as exc:
        raise InputError(f"cannot read interior orientation {path}: {exc}") from None
    cams = {}
    for cid, d in data.items():
        if not isinstance(d, dict) or d.get("type", "pinhole") != "pinhole":
            raise InputError(f"{path}: camera {cid!r} is not a 'pinhole' camera; only pinhole is supported")
        try:
            w, h = (int(v) for v in d["im_size"])
            sw, sh = (float(v) for v in d["sensor_size"])
            f = float(d["focal_len"])
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: camera {cid!r} needs im_size [w, h], sensor_size [w, h] and "
                             "focal_len") from None
        m = max(w, h)
        pp = (w / 2.0 + float(d.get("cx", 0.0)) * m, h / 2.0 + float(d.get("cy", 0.0)) * m)
        cams[cid] = FrameCamera(f, (sw, sh), (w, h), pp)
    return cams


def read_exterior_orientation(path) -> dict[str, ExteriorOrientation]:
    """Read ``name X Y Z omega phi kappa`` lines (metres, degrees; ``#`` comments allowed)."""
    path = Path(path)
    out = {}
    for lineno, raw in enumerate(path.read_text().splitlines(), 1):
        line = raw.split("#", 1)[0].split()
        if not line:
            continue
        if len(line) != 7:
            raise InputError(f"{path}, line {lineno}: expected 'name X Y Z omega phi kappa'; got {raw!r}")
        try:
            out[line[0]] = ExteriorOrientation(*(float(v) for v in line[1:]))
        except ValueError:
            raise InputError(f"{path}, line {lineno}: non-numeric orientation value in {raw!r}") from None
    return out


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
