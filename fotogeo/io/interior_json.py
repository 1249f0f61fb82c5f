"""The interior-orientation JSON of a scan (``fotogeo interior``): written by
:func:`interior_record`, read back by :func:`read_interior`.

Keys: ``scan``, ``camera_report``, ``model`` (affine or projective), ``pixel_to_photo`` (2x3
affine or 3x3 matrix: GDAL corner-convention pixels → photo mm, x right, y up),
``photo_to_pixel`` (3x3), ``scan_pixel_um``, ``rotation_deg``, ``rms_px``, ``max_residual_px``,
``fiducials`` (per mark ``id``, ``col``, ``row``, ``x_mm``, ``y_mm``, ``residual_px``,
``residual_col``, ``residual_row``, ``sigma_col``, ``sigma_row``, ``ncc``), ``missing`` (``id``,
``reason``), ``focal_mm``, ``principal_point_mm``, ``warnings`` and, after a resampling,
``standard_frame`` (``image``, ``camera``, ``pixel_um``, ``size``, ``frame_mm``).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..orientation.interior import InteriorOrientation

CONVENTION = "pixel (col, row): GDAL corner convention; photo (x, y): mm, x right, y up, the report's frame"


def _num(v):
    return None if v is None or not np.isfinite(v) else round(float(v), 6)


def interior_record(scan, report, io: InteriorOrientation, marks: dict, missing: dict, warnings: list) -> dict:
    """The JSON mapping of one scan (module docstring); ``marks``: id → MarkResult of the marks used."""
    fid = []
    for k, i in enumerate(io.ids):
        m = marks[i]
        fid.append({"id": i, "col": _num(io.pixel[k, 0]), "row": _num(io.pixel[k, 1]), "x_mm": io.photo[k, 0],
                    "y_mm": io.photo[k, 1], "residual_px": _num(io.residual_lengths[k]),
                    "residual_col": _num(io.residual_px[k, 0]), "residual_row": _num(io.residual_px[k, 1]),
                    "sigma_col": _num(m.sigma[0]), "sigma_row": _num(m.sigma[1]), "ncc": _num(m.ncc)})
    return {"scan": str(scan), "camera_report": report.source, "camera": report.name, "convention": CONVENTION,
            "model": io.model, "pixel_to_photo": io.pixel_to_photo_list(),
            "photo_to_pixel": np.linalg.inv(io.matrix).tolist(), "scan_pixel_um": _num(io.pixel_size_mm * 1000),
            "rotation_deg": _num(io.rotation_deg), "rms_px": _num(io.rms_px),
            "max_residual_px": _num(io.residual_lengths.max()), "fiducials": fid,
            "missing": [{"id": i, "reason": r} for i, r in missing.items()], "focal_mm": report.focal_mm,
            "principal_point_mm": list(report.principal_point_mm), "warnings": list(warnings)}


def read_interior(path) -> InteriorOrientation:
    """The pixel → photo transform of an interior-orientation JSON (its marks and residuals too)."""
    try:
        d = json.loads(Path(path).read_text())
        M = np.asarray(d["pixel_to_photo"], float)
        M = np.vstack([M, [0.0, 0.0, 1.0]]) if M.shape == (2, 3) else M
        if M.shape != (3, 3) or not np.isfinite(M).all():
            raise ValueError("pixel_to_photo must be a 2x3 or 3x3 matrix of numbers")
        f = d.get("fiducials", [])
        pix = np.array([[m["col"], m["row"]] for m in f], float).reshape(-1, 2)
        photo = np.array([[m["x_mm"], m["y_mm"]] for m in f], float).reshape(-1, 2)
        res = np.array([[m["residual_col"], m["residual_row"]] for m in f], float).reshape(-1, 2)
        return InteriorOrientation(str(d.get("model", "affine")), M, tuple(m["id"] for m in f), pix, photo, res)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(f"interior orientation {str(path)!r} cannot be read ({exc}); give a JSON written by "
                         "fotogeo interior") from None
