"""Camera calibration reports of film cameras (``interior --camera-report CAL.yaml``).

A YAML file (read by :func:`fotogeo.io.yaml_file.read_yaml_mapping`)::

    camera: RC30-like                # optional name
    focal_mm: 153.12                 # calibrated focal length
    principal_point_mm: [0.004, -0.008]
    fiducials_mm:                    # photo coordinates of the marks: x right, y up, mm
      1: [-106.002, 105.998]
      2: [105.996, 106.004]
      ...
    mark: x                          # x, cross, dot or corner [x]
    mark_size_mm: 4.0                # arm length tip to tip, or dot diameter [4]
    mark_width_mm: 0.3               # arm width [0.3]
    polarity: bright                 # bright marks on a dark border, dark, or auto [auto]
    frame_mm: [230, 230]             # the standard frame of a resampling [the fiducials' extent]

Photo coordinates are those of the calibration report (origin where it puts it, usually the
fiducial centre); the principal point is given in them.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError, one_line
from .yaml_file import read_yaml_mapping
from .text import read_text_file

MARKS = ("x", "cross", "dot", "corner")
POLARITIES = ("auto", "bright", "dark")


@dataclass(frozen=True)
class CalibrationReport:
    """What ``interior`` needs of a calibration report (module docstring); lengths in mm."""

    focal_mm: float
    principal_point_mm: tuple[float, float]
    fiducials_mm: dict  # id -> (x, y)
    mark: str = "x"
    mark_size_mm: float = 4.0
    mark_width_mm: float = 0.3
    polarity: str = "auto"
    frame_mm: tuple[float, float] | None = None
    name: str = ""
    source: str = ""


def _pair(value, key):
    if not isinstance(value, list) or len(value) != 2 or not all(isinstance(v, (int, float)) for v in value):
        raise ValueError(f"{key} must be two numbers [x, y]; got {str(value)[:40]!r}")
    return float(value[0]), float(value[1])


def _positive(d, key, default):
    v = d.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
        raise ValueError(f"{key} must be a positive number; got {str(v)[:40]!r}")
    return float(v)


def read_calibration_report(path) -> CalibrationReport:
    """Read a calibration report (module docstring); one :class:`InputError` names the file and the value."""
    path = Path(path)
    what = f"camera report {str(path)!r}"
    text = read_text_file(path, "camera report", hint="give the calibration report YAML")
    data, _ = read_yaml_mapping(text, f"{what}, ")
    try:
        fid = data.get("fiducials_mm")
        if not isinstance(fid, dict) or not fid:
            raise ValueError("fiducials_mm must list the marks, one 'id: [x, y]' line each (indented)")
        fiducials = {str(k): _pair(v, f"fiducials_mm {k}") for k, v in fid.items()}
        mark = str(data.get("mark", "x")).lower()
        if mark not in MARKS:
            raise ValueError(f"mark must be one of {', '.join(MARKS)}; got {mark!r}")
        polarity = str(data.get("polarity", "auto")).lower()
        if polarity not in POLARITIES:
            raise ValueError(f"polarity must be one of {', '.join(POLARITIES)}; got {polarity!r}")
        frame = data.get("frame_mm")
        return CalibrationReport(
            _positive(data, "focal_mm", None), _pair(data.get("principal_point_mm", [0.0, 0.0]), "principal_point_mm"),
            fiducials, mark, _positive(data, "mark_size_mm", 4.0), _positive(data, "mark_width_mm", 0.3), polarity,
            None if frame is None else _pair(frame, "frame_mm"), str(data.get("camera", "")), str(path))
    except ValueError as exc:
        raise InputError(one_line(f"{what}: {exc}; it needs focal_mm, principal_point_mm [x, y] and fiducials_mm "
                                  "{id: [x, y]} (optional mark, mark_size_mm, mark_width_mm, polarity, frame_mm)")) from None
