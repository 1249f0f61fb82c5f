"""Import and export of the picker's GCPs: QGIS Georeferencer ``.points`` and ODM ``gcp_list.txt``.

``.points`` goes through fotogeo's own converters in the worker session (``points_to_layer`` /
``layer_to_points``, :mod:`fotogeo.tools.points`), so the picker writes exactly what the
Processing algorithms and ``fotogeo orient`` read: ``sourceX = col``, ``sourceY = −row``
(unreferenced convention), ``enable`` 1 for control and 0 for check points, ``#CRS`` the layer's.

ODM/OpenSfM ``gcp_list.txt`` (:func:`fotogeo.io.block.read_gcp_list` documents it): the CRS line,
then ``geo_x geo_y geo_z im_x im_y image_name gcp_name``; OpenSfM puts the centre of the top-left
pixel at (0, 0), so ``im = (col, row) − 0.5``. Only lines of the picker's image are imported.
A heightless GCP cannot be written to it (ODM needs Z): the fit's heights (DEM or constant) are used.
"""
from __future__ import annotations

import os
import re
import tempfile

from qgis.core import QgsCoordinateReferenceSystem, QgsCoordinateTransform, QgsPointXY, QgsProject, QgsVectorLayer

from .gcp_layer import Gcp, GcpLayer

_ODM_UTM = re.compile(r"^WGS84\s+UTM\s+(\d{1,2})([NS])$", re.IGNORECASE)


class PickerFileError(ValueError):
    """A file cannot be imported/exported; the message names it and the fix."""


def export_points(session, store: GcpLayer, path: str) -> dict:
    """Write the GCPs to a ``.points`` file (fotogeo's ``layer_to_points`` on a GeoPackage copy)."""
    with tempfile.TemporaryDirectory(prefix="fotogeo-picker-") as folder:
        gpkg = store.export_gpkg(os.path.join(folder, "gcps.gpkg"))
        return session.call("layer_to_points", source=gpkg, output=path, layer="gcps", overwrite=True)


def import_points(session, path: str, store: GcpLayer) -> list[Gcp]:
    """The GCPs of a ``.points`` file, in the layer's CRS, with new ids after the layer's own."""
    with tempfile.TemporaryDirectory(prefix="fotogeo-picker-") as folder:
        gpkg = os.path.join(folder, "in.gpkg")
        session.call("points_to_layer", points=path, output=gpkg, crs=None if _has_crs_line(path) else
                     store.crs.toWkt(QgsCoordinateReferenceSystem.WKT_PREFERRED))
        layer = QgsVectorLayer(f"{gpkg}|layername=gcps", "in", "ogr")
        source = GcpLayer(layer)
        gcps = source.gcps()
        crs = layer.crs()
        del source, layer
    return _renumbered(_to_crs(gcps, crs, store.crs), store)


def _has_crs_line(path: str) -> bool:
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.readline().startswith("#CRS:")
    except OSError as e:
        raise PickerFileError(f"cannot read {path!r}: {e.strerror}") from None


def _to_crs(gcps: list[Gcp], source: QgsCoordinateReferenceSystem, target: QgsCoordinateReferenceSystem):
    if not source.isValid() or source == target:
        return gcps
    t = QgsCoordinateTransform(source, target, QgsProject.instance())
    out = []
    for g in gcps:
        p = t.transform(QgsPointXY(g.x, g.y))
        out.append(Gcp(g.id, g.col, g.row, p.x(), p.y(), g.z, g.role))
    return out


def _renumbered(gcps: list[Gcp], store: GcpLayer) -> list[Gcp]:
    """Imported points keep their ids unless the layer already uses them."""
    used = {g.id for g in store.gcps()}
    out, n = [], 1
    for g in gcps:
        gid = g.id
        if gid in used:
            while str(n) in used:
                n += 1
            gid = str(n)
        used.add(gid)
        out.append(Gcp(gid, g.col, g.row, g.x, g.y, g.z, g.role))
    return out


def odm_crs(text: str) -> QgsCoordinateReferenceSystem:
    """The CRS of a gcp_list.txt first line (``EPSG:32635``, ``WGS84 UTM 35N`` or a PROJ string)."""
    m = _ODM_UTM.match(text.strip())
    if m:
        text = f"EPSG:{32600 if m.group(2).upper() == 'N' else 32700}{int(m.group(1)):02d}"
    crs = QgsCoordinateReferenceSystem(text.strip())
    if not crs.isValid():
        crs = QgsCoordinateReferenceSystem.fromProj(text.strip())
    return crs


def import_gcp_list(path: str, image_name: str, store: GcpLayer) -> list[Gcp]:
    """The GCPs measured on ``image_name`` (file name or stem) in an ODM ``gcp_list.txt``."""
    try:
        with open(path, encoding="utf-8-sig") as f:
            lines = [ln.split("#", 1)[0].strip() for ln in f]
    except (OSError, UnicodeDecodeError) as e:
        raise PickerFileError(f"cannot read GCP list {path!r} as text: {e}") from None
    lines = [ln for ln in lines if ln]
    crs = odm_crs(lines[0]) if lines else QgsCoordinateReferenceSystem()
    if not crs.isValid():
        raise PickerFileError(f"GCP list {path!r}: its first line {lines[0] if lines else ''!r} is not a CRS "
                              f"(EPSG:code, 'WGS84 UTM 35N' or a PROJ string)")
    stem = os.path.splitext(os.path.basename(image_name))[0]
    gcps, frames = [], set()
    for ln in lines[1:]:
        parts = ln.split()
        try:
            x, y, z, ix, iy = (float(v) for v in parts[:5])
            frame = os.path.splitext(os.path.basename(parts[5]))[0]
        except (ValueError, IndexError):
            raise PickerFileError(f"GCP list {path!r}: expected 'geo_x geo_y geo_z im_x im_y image_name "
                                  f"[gcp_name]'; got {ln!r}") from None
        frames.add(frame)
        if frame == stem:
            name = parts[6] if len(parts) > 6 else str(len(gcps) + 1)
            gcps.append(Gcp(name, ix + 0.5, iy + 0.5, x, y, z, "control"))
    if not gcps:
        raise PickerFileError(f"GCP list {path!r} has no measurement on image {stem!r} (it names "
                              f"{', '.join(sorted(frames)[:5]) or 'no image'}); open that image in the picker")
    return _renumbered(_to_crs(gcps, crs, store.crs), store)


def export_gcp_list(store: GcpLayer, fit: dict, image_name: str, path: str) -> int:
    """Write the GCPs as an ODM ``gcp_list.txt`` for ``image_name``; heights from the fit. Returns the count."""
    heights = {p["id"]: p.get("z") for p in (fit or {}).get("points", [])}
    crs = store.crs
    crs_line = crs.authid() if crs.authid().upper().startswith("EPSG:") else crs.toProj()
    gcps = store.gcps()
    missing = [g.id for g in gcps if (g.z if g.z is not None else heights.get(g.id)) is None]
    if missing:
        raise PickerFileError(f"GCP(s) {', '.join(missing[:10])} have no height; ODM's gcp_list.txt needs Z: "
                              f"choose a DEM or a constant height (or fill the z field) first")
    lines = [crs_line]
    for g in gcps:
        z = g.z if g.z is not None else heights[g.id]
        lines.append(f"{g.x!r} {g.y!r} {z!r} {g.col - 0.5!r} {g.row - 0.5!r} {os.path.basename(image_name)} {g.id}")
    tmp = f"{path}.part"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, path)
    return len(gcps)
