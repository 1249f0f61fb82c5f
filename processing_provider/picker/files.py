"""Import and export of the picker's GCPs: QGIS Georeferencer ``.points`` and ODM ``gcp_list.txt``.

``.points`` goes through fotogeo's own converters in the worker session (``points_to_layer`` /
``layer_to_points``, :mod:`fotogeo.tools.points.layers`), so the picker writes exactly what the
Processing algorithms and ``fotogeo orient`` read: ``sourceX = col``, ``sourceY = −row``
(unreferenced convention), ``enable`` 1 for enabled control points and 0 for check and disabled points (fotogeo
reads 0 back as a check point, the Georeferencer as a disabled one), ``#CRS`` the layer's.

ODM/OpenSfM ``gcp_list.txt`` goes through fotogeo's reader and writer in the worker session as well
(``read_image_gcps`` / ``write_image_gcps``, :mod:`fotogeo.tools.gcp.files`; the format and OpenSfM's
pixel-centre convention: :mod:`fotogeo.io.block`). Only lines of the picker's image are imported.
A heightless GCP cannot be written to it (ODM needs Z): the fit's heights (DEM or constant) are used.
"""
from __future__ import annotations

import os
import tempfile
from dataclasses import replace

from qgis.core import QgsCoordinateReferenceSystem, QgsCoordinateTransform, QgsPointXY, QgsProject, QgsVectorLayer

from .gcp_layer import Gcp, GcpLayer

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
        out.append(replace(g, x=p.x(), y=p.y()))
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
        out.append(replace(g, id=gid, fid=-1))
    return out


def import_gcp_list(session, path: str, image_name: str, store: GcpLayer) -> list[Gcp]:
    """The GCPs measured on ``image_name`` in an ODM ``gcp_list.txt``, read by fotogeo's own reader in the
    worker (``read_image_gcps``), in the layer's CRS."""
    got = session.call("read_image_gcps", path=path, image=image_name)
    gcps = [Gcp(r["id"], r["col"], r["row"], r["x"], r["y"], r["z"], r["role"]) for r in got["gcps"]]
    return _renumbered(_to_crs(gcps, QgsCoordinateReferenceSystem.fromWkt(got["crs"]), store.crs), store)


def export_gcp_list(session, store: GcpLayer, fit: dict, image_name: str, path: str) -> int:
    """Write the GCPs as an ODM ``gcp_list.txt`` for ``image_name`` (fotogeo's writer in the worker,
    ``write_image_gcps``); heightless points take the fit's height (DEM or constant); disabled points are left out
    (ODM would use them). Returns the count."""
    heights = {p["id"]: p.get("z") for p in (fit or {}).get("points", [])}
    rows = [dict(g.request(), z=g.z if g.z is not None else heights.get(g.id)) for g in store.gcps() if g.enabled]
    if not rows:
        raise PickerFileError("every GCP is disabled: tick 'on' for the ones to write to the gcp_list.txt")
    crs = store.crs.toWkt(QgsCoordinateReferenceSystem.WKT_PREFERRED)
    return session.call("write_image_gcps", gcps=rows, crs=crs, image=image_name, output=path)["count"]
