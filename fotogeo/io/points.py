"""QGIS Georeferencer ``.points`` files: read, write, and convert to/from a GeoPackage layer.

The format, as QGIS writes it (``QgsGCPList::saveGcps``) and reads it (``loadGcps``)::

    #CRS: <WKT or any CRS definition of the map coordinates>     (optional line)
    mapX,mapY,sourceX,sourceY,enable,dX,dY,residual               (header, skipped on read)
    500012.5,6200034.25,100.5,-200.25,1,0.1,-0.2,0.2236

Columns are positional (older files say ``pixelX,pixelY`` and may be tab-separated);
``enable`` is 1 or 0 and missing means 1; ``dX, dY, residual`` are QGIS's residuals.

Source coordinates are in the source raster's *layer* coordinates:

- for an unreferenced raster QGIS uses the pixel grid with y pointing up, so
  ``sourceX = col`` and ``sourceY = -row``, with (0, 0) the top-left corner of the top-left
  pixel — the GDAL corner convention of :mod:`fotogeo.pixels`; the pixel centre of the
  top-left pixel is (0.5, -0.5);
- for a georeferenced raster they are map coordinates of that raster, and
  ``(col, row) = ~transform * (sourceX, sourceY)``.

A fotogeo GCP / tie-point layer is a GeoPackage point layer in the map CRS with fields
``id`` (int), ``col``, ``row`` (source pixel, corner convention), ``z`` (height, NULL when
unknown), ``role`` (``control`` or ``check``) and, when known, ``dx``, ``dy``,
``residual``. ``enable = 1`` ↔ ``role = control``; a disabled point becomes a ``check``
point (excluded from the fit, used to measure it), and any role other than ``control``
is written with ``enable = 0``.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, VectorError, one_line
from ..pixels import as_points
from .text import read_text_file

HEADER = "mapX,mapY,sourceX,sourceY,enable,dX,dY,residual"
CRS_PREFIX = "#CRS:"


@dataclass(frozen=True)
class GeorefPoints:
    """The content of one ``.points`` file (coordinates exactly as written in it)."""

    map_xy: np.ndarray  # (N, 2) float64, map coordinates (in ``crs``)
    source_xy: np.ndarray  # (N, 2) float64, source layer coordinates (see module docstring)
    enabled: np.ndarray  # (N,) bool
    residual: np.ndarray  # (N, 2) float64 dX, dY (NaN when the file has none)
    crs: str | None = None  # the text after "#CRS: ", or None

    def __len__(self) -> int:
        return len(self.map_xy)


def _fmt(v: float) -> str:
    """Shortest text that reads back to the same float64 (like QGIS's qgsDoubleToString)."""
    v = float(v)
    if not math.isfinite(v):
        return "0"
    if v == int(v) and abs(v) < 1e15:
        return str(int(v))
    return repr(v)


#: first fields of a header line: QGIS writes ``mapX,mapY,sourceX,...``, older files ``pixelX,pixelY``
HEADER_STARTS = (("mapx", "mapy", "sourcex", "sourcey"), ("mapx", "mapy", "pixelx", "pixely"))


def _is_header(parts: list[str]) -> bool:
    """True for the header line only: ``mapX,mapY,sourceX,sourceY[,...]`` (any letter case)."""
    return tuple(p.lower() for p in parts[:4]) in HEADER_STARTS


def _parse_line(parts: list[str], where: str, raw: str) -> list[float]:
    """``[mapX, mapY, sourceX, sourceY, enable, dX, dY]`` of one data line (dX, dY NaN when absent)."""
    if not 4 <= len(parts) <= 8:
        raise VectorError(one_line(f"{where}: expected at least 4 values mapX,mapY,sourceX,sourceY and at most 8 "
                                   f"(…,enable,dX,dY,residual), separated by commas; got {raw!r}"))
    names = HEADER.split(",")
    values = []
    for name, text in zip(names, parts[:7]):
        if name == "enable" and text == "":
            values.append(1.0)  # missing enable means enabled
            continue
        try:
            v = float(text)
        except ValueError:
            raise VectorError(one_line(f"{where}: not a number: {name} is {text!r}")) from None
        if not math.isfinite(v):
            raise VectorError(one_line(f"{where}: {name} is {text!r}; every value must be a finite number"))
        if name == "enable" and v not in (0.0, 1.0):
            raise VectorError(one_line(f"{where}: enable must be 1 (control point) or 0 (check point); got {text!r}"))
        values.append(v)
    values += [1.0] if len(values) == 4 else []
    values += [math.nan] * (7 - len(values)) if len(values) < 7 else []
    return values[:7]


def read_points(path) -> GeorefPoints:
    """Read a Georeferencer ``.points`` file; a :class:`VectorError` names the bad line.

    Only the exact header (``mapX,mapY,sourceX,sourceY,...`` or ``mapX,mapY,pixelX,pixelY,...``)
    is skipped; every other line must be a point with finite numbers and ``enable`` 0 or 1, so a
    first point starting with ``nan`` is refused, not mistaken for a header.
    """
    p = Path(path)
    text = read_text_file(p, "points file", hint="give the .points file", error=VectorError)
    crs = None
    rows = []
    data_seen = False
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            if line.upper().startswith(CRS_PREFIX):
                crs = line[len(CRS_PREFIX):].strip() or None
            continue
        parts = [s.strip() for s in (line.split(",") if "," in line else re.split(r"\t+", line))]
        if not data_seen and _is_header(parts):
            data_seen = True  # the header, before any point
            continue
        data_seen = True
        rows.append(_parse_line(parts, f"points file {str(p)!r}, line {n}", raw))
    if not rows:
        raise VectorError(f"points file {str(p)!r} holds no points (expected the header "
                          f"{HEADER!r} followed by one line per point)")
    a = np.array(rows, dtype=np.float64)
    return GeorefPoints(a[:, 0:2].copy(), a[:, 2:4].copy(), a[:, 4] > 0, a[:, 5:7].copy(), crs)


def write_points(path, map_xy, source_xy, enabled=None, residual=None, crs: str | None = None) -> None:
    """Write a Georeferencer ``.points`` file (QGIS ≥ 3.26 layout; 3.22 reads it too).

    ``crs`` (WKT or any CRS definition) becomes the ``#CRS:`` line when given. Writes
    straight to ``path``; :func:`layer_to_points` adds the atomic rename and checks.
    """
    m = as_points(map_xy, name="map_xy")
    s = as_points(source_xy, name="source_xy")
    if len(m) != len(s):
        raise InputError(f"map_xy has {len(m)} points but source_xy has {len(s)}")
    en = np.ones(len(m), bool) if enabled is None else np.asarray(enabled, bool).reshape(-1)
    if len(en) != len(m):
        raise InputError(f"enabled has {len(en)} values for {len(m)} points")
    r = np.zeros((len(m), 2)) if residual is None else as_points(residual, name="residual")
    if len(r) != len(m):
        raise InputError(f"residual has {len(r)} rows for {len(m)} points")
    r = np.where(np.isfinite(r), r, 0.0)
    lines = []
    if crs:
        lines.append(f"{CRS_PREFIX} {' '.join(str(crs).split())}")
    lines.append(HEADER)
    for (X, Y), (x, y), e, (dx, dy) in zip(m, s, en, r):
        lines.append(",".join([_fmt(X), _fmt(Y), _fmt(x), _fmt(y), "1" if e else "0",
                               _fmt(dx), _fmt(dy), _fmt(math.hypot(dx, dy))]))
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(lines) + "\n")


def source_to_pixel(source_xy, transform=None) -> np.ndarray:
    """Georeferencer source coordinates → fotogeo ``(col, row)`` (GDAL corner convention).

    ``transform`` is the source raster's affine geotransform when it is georeferenced;
    ``None`` (unreferenced raster) means ``col = sourceX``, ``row = -sourceY``.

    >>> source_to_pixel([[0.5, -0.5]]).tolist()
    [[0.5, 0.5]]
    """
    s = as_points(source_xy, name="source coordinates")
    if transform is None:
        return np.column_stack([s[:, 0], -s[:, 1]])
    from ..pixels import map_to_pixel
    return map_to_pixel(transform, s)


def pixel_to_source(colrow, transform=None) -> np.ndarray:
    """Inverse of :func:`source_to_pixel`.

    >>> pixel_to_source([[10.0, 20.0]]).tolist()
    [[10.0, -20.0]]
    """
    p = as_points(colrow, name="pixel coordinates")
    if transform is None:
        return np.column_stack([p[:, 0], -p[:, 1]])
    from ..pixels import pixel_to_map
    return pixel_to_map(transform, p)
