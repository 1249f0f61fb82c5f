"""The manifest of a batch: one row per scene, as CSV and as a GeoPackage layer ``scenes`` of footprints.

Both files are rewritten whole at each update through a temporary file renamed over the old
one (``os.replace``), so a reader — or a batch resumed after a crash — always sees a complete
manifest. Footprints are polygons in WGS 84 longitude/latitude (EPSG:4326), so scenes
registered into different output CRSs share one layer; the CSV carries the same polygon as WKT.
"""
from __future__ import annotations

import csv
import os
import tempfile
from pathlib import Path

from ..errors import OutputError

#: the columns of a manifest row, in file order
FIELDS = ("scene", "target", "status", "inliers", "check_n", "check_rmse_m", "check_rmse_px", "control_rmse_m",
          "model", "output_crs", "output", "seconds", "worker", "error", "footprint_wkt")
#: what ``status`` may say: not run yet, registered, failed (``error`` says why)
STATUSES = ("pending", "ok", "failed")
_NUMBERS = {"inliers": int, "check_n": int, "check_rmse_m": float, "check_rmse_px": float, "control_rmse_m": float,
            "seconds": float}
LAYER_DESCRIPTION = ("fotogeo register-batch: one feature per scene, its footprint (WGS 84) on the map; status ok, "
                     "failed (error says why) or pending; inliers, check-point RMSE (m, reference px), seconds.")


def _replace(path: Path, write) -> None:
    """Call ``write(temporary path)`` then rename the temporary over ``path`` (atomic on one file system)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".part{path.suffix}", dir=path.parent)
    os.close(fd)
    os.unlink(tmp)
    try:
        write(Path(tmp))
        os.replace(tmp, path)
    except OSError as e:
        raise OutputError(f"cannot write the manifest {str(path)!r} ({e.strerror or e}); is the folder writable "
                          f"and the disk not full?") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_csv(path, rows: list[dict]) -> None:
    """The manifest CSV (columns :data:`FIELDS`), replaced atomically."""
    def write(tmp):
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, FIELDS, extrasaction="ignore")
            w.writeheader()
            for row in rows:
                w.writerow({k: "" if row.get(k) is None else row.get(k) for k in FIELDS})
    _replace(Path(path), write)


def read_csv(path) -> list[dict]:
    """The rows of a manifest CSV (numbers as numbers, empty as None); [] if there is none."""
    path = Path(path)
    if not path.is_file():
        return []
    rows = []
    with open(path, newline="", encoding="utf-8") as f:
        for raw in csv.DictReader(f):
            row = {}
            for k in FIELDS:
                v = raw.get(k)
                v = None if v in (None, "") else v
                row[k] = _NUMBERS[k](float(v)) if v is not None and k in _NUMBERS else v
            rows.append(row)
    return rows


def write_gpkg(path, rows: list[dict]) -> None:
    """The manifest GeoPackage (layer ``scenes``, footprints in EPSG:4326), replaced atomically."""
    import shapely
    from .vector import write_layers
    columns = {k: [row.get(k) for row in rows] for k in FIELDS if k != "footprint_wkt"}
    for k, kind in _NUMBERS.items():
        columns[k] = [float("nan") if v is None else kind(v) for v in columns[k]]
    columns["geometry"] = [None if not row.get("footprint_wkt") else shapely.from_wkt(row["footprint_wkt"])
                           for row in rows]
    _replace(Path(path), lambda tmp: write_layers(tmp, {"scenes": columns}, "EPSG:4326",
                                                  {"scenes": LAYER_DESCRIPTION}))
