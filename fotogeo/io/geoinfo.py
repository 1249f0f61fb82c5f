"""senseFly ``geoinfo.txt``: the eMotion geotag file of a flight (one line per image).

Format (``#Rev: sensefly/geoinfo/2``, as in the snowpeak flight of ``../shared/data``): ``#`` comment
lines, then a line of column names, then one tab-separated line per image (a trailing tab is
usual)::

    #Rev: sensefly/geoinfo/2
    fileName  latitude  longitude  altitude_amsl  altitude_wgs84  heading  pitch  roll
    IMG_2280.JPG  37.5448844  139.0463838  223.854  262.075  307.860  11.598  -0.402

Columns are found by name (case-insensitive, any order; lines without tabs are split on
whitespace): ``fileName``, ``latitude``, ``longitude`` (WGS 84 degrees) are required, and at
least one of ``altitude_wgs84`` (the height above the WGS 84 ellipsoid) and ``altitude_amsl`` (above
mean sea level, i.e. the geoid); ``heading``, ``pitch``, ``roll`` (degrees) are the autopilot's
attitude of the aircraft body, read with
:func:`fotogeo.geometry.attitude.rotation_from_body_ypr` (Pix4D's convention; eMotion writes
the same values as the images' ``sensefly:Yaw/Pitch/Roll`` XMP tags). The eBee RTK user manual
(senseFly 2014, §5.1) states that eMotion geotags are WGS 84 with heights above the ellipsoid; on the
snowpeak images the EXIF ``GPSAltitude`` equals this file's ``altitude_wgs84`` (262.075 m for
IMG_2280).

:func:`read_geoinfo` returns one :class:`GeoinfoRecord` per frame, keyed by the frame key (the
file name without folder and extension, :func:`fotogeo.io.block.frame_key`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError
from .block import frame_key
from .text import read_text_file

_REQUIRED = ("filename", "latitude", "longitude")
_OPTIONAL = ("altitude_amsl", "altitude_wgs84", "heading", "pitch", "roll")
_HINT = ("a senseFly geoinfo.txt: a line of column names (fileName latitude longitude altitude_amsl "
         "altitude_wgs84 heading pitch roll), then one tab-separated line per image")


@dataclass(frozen=True)
class GeoinfoRecord:
    """One image of a ``geoinfo.txt`` (degrees and metres; ``None`` where the file has no column)."""

    file_name: str
    latitude: float
    longitude: float
    altitude_amsl: float | None = None
    altitude_wgs84: float | None = None
    heading: float | None = None
    pitch: float | None = None
    roll: float | None = None

    @property
    def attitude(self) -> tuple | None:
        """``(heading, pitch, roll)`` when all three are given, else ``None``."""
        v = (self.heading, self.pitch, self.roll)
        return None if None in v else v

    def height(self) -> tuple[float | None, str | None]:
        """``(Z, reference)``: the ellipsoidal height when given, else the height above mean sea level."""
        if self.altitude_wgs84 is not None:
            return self.altitude_wgs84, "ellipsoid"
        if self.altitude_amsl is not None:
            return self.altitude_amsl, "geoid"
        return None, None


def _split(line: str) -> list[str]:
    parts = line.split("\t") if "\t" in line else line.split()
    return [p.strip() for p in parts]


def _header(cells: list[str], where: str) -> dict[str, int]:
    cols = {c.lower(): i for i, c in enumerate(cells) if c}
    missing = [c for c in _REQUIRED if c not in cols]
    if missing:
        raise InputError(f"{where}: the column-name line lacks {', '.join(missing)}; expected {_HINT}")
    if "altitude_wgs84" not in cols and "altitude_amsl" not in cols:
        raise InputError(f"{where}: no altitude_wgs84 or altitude_amsl column; expected {_HINT}")
    return cols


def _value(cells, cols, name, where):
    i = cols.get(name)
    if i is None:
        return None
    text = cells[i] if i < len(cells) else ""
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{where}: {name} {text!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"{where}: {name} is {text!r}; give a finite number")
    return v


def read_geoinfo(path) -> dict[str, GeoinfoRecord]:
    """Records of a senseFly ``geoinfo.txt`` by frame key (module docstring); an
    :class:`InputError` naming the file and line for a malformed file or a frame listed twice."""
    what = f"geoinfo file {str(path)!r}"
    text = read_text_file(path, "geoinfo file", hint=_HINT)
    cols = None
    out: dict[str, GeoinfoRecord] = {}
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = _split(line)
        where = f"{what} line {lineno}"
        if cols is None:
            cols = _header(cells, where)
            continue
        name = cells[cols["filename"]] if cols["filename"] < len(cells) else ""
        if not name:
            raise InputError(f"{where}: no file name; expected {_HINT}")
        vals = {k: _value(cells, cols, k, where) for k in ("latitude", "longitude", *_OPTIONAL)}
        if not (-90 <= vals["latitude"] <= 90 and -180 <= vals["longitude"] <= 360):
            raise InputError(f"{where}: latitude {vals['latitude']} / longitude {vals['longitude']} are not "
                             f"WGS 84 degrees")
        key = frame_key(name)
        if key in out:
            raise InputError(f"{where}: image {name!r} is listed twice; keep one line per image")
        out[key] = GeoinfoRecord(name, **vals)
    if cols is None or not out:
        raise InputError(f"{what} lists no image; expected {_HINT}")
    return out
