"""The picker's GCPs as a QGIS point layer with the fields fotogeo's tools read.

One feature per GCP: the geometry is the map position (in the layer's CRS), the fields are
``id`` (text), ``col``, ``row`` (image position, GDAL corner convention: (0, 0) is the
top-left corner of the top-left pixel; the image canvas shows it at x = col, y = −row as the
Georeferencer and ``.points`` files do), ``z`` (height, NULL when unknown), ``role``
(``control`` fits the model, ``check`` measures it), ``enabled`` (0: the point is ignored, the
Georeferencer's disabled point; missing or NULL: enabled) and the last fit's ``dx``, ``dy``,
``residual`` (px), ``residual_map`` (map units) and ``flag``. :func:`fotogeo.io.gcps.read_gcps` reads such a layer directly (a memory layer is
written to a GeoPackage first, :meth:`GcpLayer.export_gpkg`), so the Processing algorithms and
``fotogeo orient`` take it as it is.

Edits go straight to the data provider (no edit session); the picker's undo stack
(:mod:`.commands`) records them. Edits made with QGIS's own tools are picked up too
(:attr:`GcpLayer.changed` fires after a commit).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from qgis.core import (
    NULL,
    QgsCoordinateReferenceSystem,
    QgsCoordinateTransform,
    QgsFeature,
    QgsField,
    QgsFields,
    QgsGeometry,
    QgsPointXY,
    QgsProject,
    QgsVectorFileWriter,
    QgsVectorLayer,
    QgsWkbTypes,
)
from qgis.PyQt.QtCore import QObject, QVariant, pyqtSignal

ROLES = ("control", "check")
FIELDS = (("id", QVariant.String), ("col", QVariant.Double), ("row", QVariant.Double), ("z", QVariant.Double),
          ("role", QVariant.String), ("enabled", QVariant.Int), ("dx", QVariant.Double), ("dy", QVariant.Double),
          ("residual", QVariant.Double), ("residual_map", QVariant.Double), ("flag", QVariant.String),
          ("w", QVariant.Double), ("redundancy", QVariant.Double), ("mdb", QVariant.Double))
#: the fields a fit writes (:meth:`GcpLayer.write_results`): name in the layer -> key in fit_gcps' point rows
RESULT_FIELDS = {"dx": "dx_px", "dy": "dy_px", "residual": "residual_px", "residual_map": "residual_map",
                 "flag": "flag", "w": "w", "redundancy": "redundancy", "mdb": "mdb_px"}


@dataclass(frozen=True)
class Gcp:
    """One GCP as the picker handles it (``fid`` is the feature id in the layer, -1 before it is added)."""

    id: str
    col: float
    row: float
    x: float
    y: float
    z: float | None = None
    role: str = "control"
    fid: int = -1
    enabled: bool = True

    def request(self) -> dict:
        """The point as the worker's ``fit_gcps`` takes it (:func:`fotogeo.tools.gcp.fit.fit_gcps`): a disabled
        point has the role ``disabled`` (left out of the fit and the RMS; its residual still shown)."""
        return {"id": self.id, "col": self.col, "row": self.row, "x": self.x, "y": self.y, "z": self.z,
                "role": self.role if self.enabled else "disabled"}


def _number(value):
    if value is None or value == NULL:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


class GcpLayer(QObject):
    """A fotogeo GCP point layer: reading, adding, moving, deleting and re-roling GCPs."""

    changed = pyqtSignal()

    def __init__(self, layer: QgsVectorLayer):
        super().__init__()
        missing = [name for name in ("col", "row") if layer.fields().indexOf(name) < 0]
        if missing:
            raise ValueError(f"layer {layer.name()!r} lacks the GCP field(s) {', '.join(missing)} (the image "
                             f"position): choose a layer made by the picker or by fotogeo's points-to-layer")
        self.layer = layer
        layer.afterCommitChanges.connect(self.changed.emit)

    @classmethod
    def create(cls, crs: QgsCoordinateReferenceSystem, name: str = "fotogeo GCPs", add_to_project: bool = True):
        """A new memory layer in ``crs`` with the GCP fields (added to the project: saved with it)."""
        layer = QgsVectorLayer("Point", name, "memory")
        layer.setCrs(crs)  # the very CRS given (a WKT round trip may differ and then need a transform)
        layer.dataProvider().addAttributes([QgsField(n, t) for n, t in FIELDS])
        layer.updateFields()
        if add_to_project:
            QgsProject.instance().addMapLayer(layer)
        return cls(layer)

    @classmethod
    def create_gpkg(cls, path: str, crs: QgsCoordinateReferenceSystem, name: str = "fotogeo GCPs",
                    add_to_project: bool = True):
        """A new GeoPackage point layer ``gcps`` at ``path`` (replaced if it exists) with the GCP fields."""
        fields = QgsFields()
        for n, t in FIELDS:
            fields.append(QgsField(n, t))
        options = QgsVectorFileWriter.SaveVectorOptions()
        options.driverName, options.layerName = "GPKG", "gcps"
        writer = QgsVectorFileWriter.create(path, fields, QgsWkbTypes.Point, crs,
                                            QgsProject.instance().transformContext(), options)
        error = writer.hasError()
        message = writer.errorMessage()
        del writer  # closes the file
        if error != QgsVectorFileWriter.NoError:
            raise ValueError(f"cannot create the GCP GeoPackage {path!r}: {message}")
        layer = QgsVectorLayer(f"{path}|layername=gcps", name, "ogr")
        if add_to_project:
            QgsProject.instance().addMapLayer(layer)
        return cls(layer)

    @property
    def crs(self) -> QgsCoordinateReferenceSystem:
        return self.layer.crs()

    def gcps(self) -> list[Gcp]:
        """Every GCP with a point geometry, in feature-id order."""
        out = []
        for f in sorted(self.layer.getFeatures(), key=lambda f: f.id()):
            geom = f.geometry()
            if geom is None or geom.isEmpty():
                continue
            p = geom.asPoint()
            col, row = _number(f["col"]), _number(f["row"])
            if col is None or row is None:
                continue
            role, gid = self._value(f, "role"), self._value(f, "id")
            role = str(role).lower() if role is not None else "control"
            gid = str(gid) if gid is not None else str(f.id())
            enabled = _number(self._value(f, "enabled"))
            out.append(Gcp(gid, col, row, p.x(), p.y(), _number(self._value(f, "z")), role, f.id(), enabled != 0))
        return out

    def _value(self, feature, name: str):
        """The attribute ``name`` of ``feature``; None when it is NULL or the layer has no such field
        (fotogeo's readers need only ``col`` and ``row``: id, role and z are optional)."""
        if self.layer.fields().indexOf(name) < 0:
            return None
        value = feature[name]
        return None if value is None or value == NULL else value

    def find(self, fid: int) -> Gcp | None:
        return next((g for g in self.gcps() if g.fid == fid), None)

    def next_id(self) -> str:
        """The smallest positive integer not yet used as an id."""
        used = {g.id for g in self.gcps()}
        n = 1
        while str(n) in used:
            n += 1
        return str(n)

    def _feature(self, gcp: Gcp) -> QgsFeature:
        values = self._attributes(gcp)  # first: it may add a field
        f = QgsFeature(self.layer.fields())
        f.setGeometry(QgsGeometry.fromPointXY(QgsPointXY(gcp.x, gcp.y)))
        for name, value in values.items():
            f[name] = value
        return f

    def _attributes(self, gcp: Gcp) -> dict:
        """The GCP's field values, for the fields the layer has."""
        values = {"id": gcp.id, "col": gcp.col, "row": gcp.row, "z": NULL if gcp.z is None else gcp.z,
                  "role": gcp.role, "enabled": int(gcp.enabled)}
        if not gcp.enabled:
            self._ensure_field("enabled", QVariant.Int)
        return {k: v for k, v in values.items() if self.layer.fields().indexOf(k) >= 0}

    def _ensure_field(self, name: str, kind) -> None:
        """Add field ``name`` to a layer made elsewhere (e.g. by points-to-layer) that lacks it."""
        if self.layer.fields().indexOf(name) < 0:
            if not self.layer.dataProvider().addAttributes([QgsField(name, kind)]):
                raise RuntimeError(f"the GCP layer {self.layer.name()!r} refused a new field {name!r} (read-only?)")
            self.layer.updateFields()

    def add(self, gcp: Gcp) -> Gcp:
        """Add ``gcp``; returns it with its feature id (and the id the layer knows it by)."""
        ok, features = self.layer.dataProvider().addFeatures([self._feature(gcp)])
        if not ok:
            raise RuntimeError(f"the GCP layer {self.layer.name()!r} refused a new point (is it read-only?)")
        self._touched()
        # as read back: a layer without an ``id`` field knows the point by its feature id
        return self.find(features[0].id()) or replace(gcp, fid=features[0].id())

    def delete(self, fid: int) -> None:
        self.layer.dataProvider().deleteFeatures([fid])
        self._touched()

    def update(self, gcp: Gcp) -> None:
        """Write position, height, role and enabled of ``gcp`` (by its ``fid``)."""
        values = self._attributes(gcp)  # first: it may add a field
        provider, fields = self.layer.dataProvider(), self.layer.fields()
        provider.changeGeometryValues({gcp.fid: QgsGeometry.fromPointXY(QgsPointXY(gcp.x, gcp.y))})
        provider.changeAttributeValues({gcp.fid: {fields.indexOf(name): value for name, value
                                                  in values.items() if name != "id"}})
        self._touched()

    def write_results(self, fit: dict | None) -> None:
        """Store the fit's residuals per point (fields of :data:`RESULT_FIELDS`; cleared without a fit)."""
        fields = self.layer.fields()
        rows = {p["id"]: p for p in (fit or {}).get("points", [])} if fit and fit.get("ok") else {}
        changes = {}
        for gcp in self.gcps():
            row = rows.get(gcp.id, {})
            changes[gcp.fid] = {fields.indexOf(name): (NULL if row.get(key) is None else row[key])
                                for name, key in RESULT_FIELDS.items() if fields.indexOf(name) >= 0}
        if changes:
            self.layer.dataProvider().changeAttributeValues(changes)
        self.layer.triggerRepaint()

    def export_gpkg(self, path: str, heights: bool = True, crs=None) -> str:
        """Write the layer to a GeoPackage (layer ``gcps``) the worker's tools read; returns ``path``.

        ``heights`` False leaves the ``z`` field out, so a tool takes every height from its DEM or constant;
        ``crs`` (a valid QgsCoordinateReferenceSystem other than the layer's): the points transformed into it.
        """
        options = QgsVectorFileWriter.SaveVectorOptions()
        options.driverName, options.layerName = "GPKG", "gcps"
        if crs is not None and crs.isValid() and crs != self.layer.crs():
            options.ct = QgsCoordinateTransform(self.layer.crs(), crs, QgsProject.instance().transformContext())
        if not heights:
            options.attributes = [i for i, f in enumerate(self.layer.fields()) if f.name() != "z"]
        result = QgsVectorFileWriter.writeAsVectorFormatV2(self.layer, path, QgsProject.instance().transformContext(),
                                                           options)
        if result[0] != QgsVectorFileWriter.NoError:
            raise RuntimeError(f"could not write the GCPs to {path}: {result[1]}")
        return path

    def _touched(self):
        self.layer.triggerRepaint()
