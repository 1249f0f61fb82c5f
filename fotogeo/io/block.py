"""Files of an aerial-triangulation block: image observations, ODM ground control, orientations.

* **Image observations** (``read_image_observations``): a table (CSV or any vector layer,
  :func:`fotogeo.io.tables.read_table`) with one row per measurement of a point in a frame:
  fields ``frame`` (the frame's file name or stem), ``point`` (any id), ``col``, ``row``
  (pixels, GDAL corner convention) and an optional ``sigma`` (px).
* **Ground control in ODM/OpenSfM's** ``gcp_list.txt`` (``read_gcp_list``): the first line is
  the CRS (``EPSG:32635``, ``WGS84 UTM 35N``, a PROJ string), then one line per measurement
  ``geo_x geo_y geo_z im_x im_y image_name [gcp_name]``. OpenSfM's pixel coordinates put the
  centre of the top-left pixel at (0, 0) (its normalisation adds 0.5), so fotogeo adds 0.5 to
  reach the corner convention; lines without a name are named by their ground coordinates.
* **Exterior orientation** out (``write_exterior_orientation``): ``name X Y Z omega phi kappa``
  lines, the format :func:`fotogeo.io.camera.read_exterior_orientation` reads (metres, PATB
  degrees).
* **Interior orientation** out (``write_interior_orientation``): orthority's YAML — ``type:
  pinhole`` without distortion (what :func:`fotogeo.io.camera.read_interior_orientation` reads),
  ``type: brown`` with ``k1, k2, p1, p2, k3`` otherwise (orthority's Brown model is OpenCV's, the
  same as fotogeo's bundle adjustment); the principal point as ``cx, cy``, offsets from the image
  centre in units of ``max(w, h)`` pixels.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, one_line
from ..pixels import from_centre
from .tables import numeric_columns, read_table, require_columns


def frame_key(name) -> str:
    """The name a frame is known by: its file name without folder and extension."""
    return Path(str(name)).stem


@dataclass(frozen=True)
class ImageObservations:
    frame: np.ndarray  # (n,) frame keys (str)
    point: np.ndarray  # (n,) point ids (str)
    pixel: np.ndarray  # (n, 2) corner convention
    sigma: np.ndarray | None  # (n,) px


def read_image_observations(path) -> ImageObservations:
    """Read a table of image observations (module docstring)."""
    what = f"image observations {str(path)!r}"
    t = read_table(path, what)
    hint = "one row per measurement: frame, point, col, row (corner convention), optional sigma"
    fcol, pcol = require_columns(t, ("frame", "point"), what, hint)
    px = numeric_columns(t, ("col", "row"), what, hint, finite=True, id_field="point")
    sigma = None
    if "sigma" in {str(c).lower() for c in t.columns}:
        sigma = numeric_columns(t, ("sigma",), what, hint, finite=True, id_field="point")[:, 0]
        if not (sigma > 0).all():
            raise InputError(f"{what}: sigma must be positive (px)")
    frames = np.array([frame_key(v) for v in t[fcol]], dtype=object)
    points = t[pcol].astype(str).to_numpy(dtype=object)
    return ImageObservations(frames, points, px, sigma)


@dataclass(frozen=True)
class GcpList:
    crs: str
    name: np.ndarray  # (n,) point names
    ground: np.ndarray  # (n, 3)
    pixel: np.ndarray  # (n, 2) corner convention
    frame: np.ndarray  # (n,) frame keys


def read_gcp_list(path) -> GcpList:
    """Read an ODM/OpenSfM ``gcp_list.txt`` (module docstring)."""
    p = Path(path)
    try:
        lines = [ln.split("#", 1)[0].strip() for ln in p.read_text(encoding="utf-8-sig").splitlines()]
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(one_line(f"cannot read GCP list {str(p)!r} as text: {exc}")) from None
    numbered = [(i + 1, ln) for i, ln in enumerate(lines) if ln]
    if len(numbered) < 2:
        raise InputError(f"GCP list {str(p)!r}: expected a CRS line and measurement lines "
                         f"'geo_x geo_y geo_z im_x im_y image_name [gcp_name]'")
    crs = numbered[0][1]
    names, ground, pixel, frames = [], [], [], []
    for lineno, ln in numbered[1:]:
        parts = ln.split()
        try:
            if len(parts) < 6:
                raise ValueError("too few values")
            g, im = [float(v) for v in parts[:3]], [float(v) for v in parts[3:5]]
        except ValueError:
            raise InputError(one_line(f"GCP list {str(p)!r}, line {lineno}: expected 'geo_x geo_y geo_z im_x im_y "
                                      f"image_name [gcp_name]'; got {ln!r}")) from None
        if not (np.isfinite(g).all() and np.isfinite(im).all()):
            raise InputError(f"GCP list {str(p)!r}, line {lineno}: coordinates must be finite numbers")
        names.append(parts[6] if len(parts) > 6 else f"{g[0]:.3f}_{g[1]:.3f}_{g[2]:.3f}")
        ground.append(g)
        pixel.append(im)
        frames.append(frame_key(parts[5]))
    return GcpList(crs, np.array(names, dtype=object), np.array(ground), from_centre(np.array(pixel)),
                   np.array(frames, dtype=object))


def write_exterior_orientation(path, names, eos, header: str = "") -> None:
    """``name X Y Z omega phi kappa`` lines (module docstring); ``header`` becomes ``#`` comments."""
    out = [f"# {h}" for h in header.splitlines()] if header else []
    out += [f"{n} {e.X:.4f} {e.Y:.4f} {e.Z:.4f} {e.omega:.8f} {e.phi:.8f} {e.kappa:.8f}" for n, e in zip(names, eos)]
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8")


def write_interior_orientation(path, name: str, camera, distortion: dict | None = None) -> None:
    """One camera in orthority's YAML (module docstring)."""
    w, h = camera.image_size
    m = max(w, h)
    d = {k: float(v) for k, v in (distortion or {}).items()}
    brown = any(v != 0.0 for v in d.values())
    lines = [f"{name}:", f"    type: {'brown' if brown else 'pinhole'}", f"    im_size: [{int(w)}, {int(h)}]",
             f"    focal_len: {camera.focal_length!r}",
             f"    sensor_size: [{camera.sensor_size[0]!r}, {camera.sensor_size[1]!r}]",
             f"    cx: {(camera.principal_point[0] - w / 2.0) / m!r}", f"    cy: {(camera.principal_point[1] - h / 2.0) / m!r}"]
    if brown:
        lines += [f"    {k}: {d.get(k, 0.0)!r}" for k in ("k1", "k2", "p1", "p2", "k3")]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
