"""Regenerate processing_provider/styles/*.qml with PyQGIS (run once after changing a style).

    QT_QPA_PLATFORM=offscreen .venv/bin/python scripts/make_plugin_styles.py

tie_points.qml: points categorised by ``role`` — control blue circles, check red triangles.
error_vectors.qml: lines drawn as arrows from the reference position, categorised by ``role``.
"""
from __future__ import annotations

import sys
from pathlib import Path

from qgis.core import (
    QgsApplication,
    QgsArrowSymbolLayer,
    QgsCategorizedSymbolRenderer,
    QgsLineSymbol,
    QgsMapLayer,
    QgsMarkerSymbol,
    QgsRendererCategory,
    QgsVectorLayer,
)
from qgis.PyQt.QtGui import QColor

OUT = Path(__file__).resolve().parents[1] / "processing_provider" / "styles"
ROLES = (("control", "Control point", "#1f78b4"), ("check", "Check point", "#e31a1c"))


def tie_points_renderer():
    cats = []
    for value, label, colour in ROLES:
        shape = "circle" if value == "control" else "triangle"
        sym = QgsMarkerSymbol.createSimple({"name": shape, "color": colour, "outline_color": "#ffffff",
                                            "outline_width": "0.2", "size": "2.4"})
        cats.append(QgsRendererCategory(value, sym, label))
    other = QgsMarkerSymbol.createSimple({"name": "square", "color": "#888888", "size": "2"})
    cats.append(QgsRendererCategory(None, other, "other"))
    return QgsCategorizedSymbolRenderer("role", cats)


def error_vectors_renderer():
    cats = []
    for value, label, colour in ROLES + ((None, "other", "#888888"),):
        arrow = QgsArrowSymbolLayer()
        arrow.setIsCurved(False)
        arrow.setIsRepeated(False)
        arrow.setArrowWidth(0.3)
        arrow.setArrowStartWidth(0.3)
        arrow.setHeadLength(1.6)
        arrow.setHeadThickness(1.0)
        arrow.setHeadType(QgsArrowSymbolLayer.HeadSingle)
        arrow.setArrowType(QgsArrowSymbolLayer.ArrowPlain)
        arrow.subSymbol().setColor(QColor(colour))
        arrow.subSymbol().symbolLayer(0).setStrokeColor(QColor(colour))
        sym = QgsLineSymbol()
        sym.changeSymbolLayer(0, arrow)
        cats.append(QgsRendererCategory(value, sym, label))
    return QgsCategorizedSymbolRenderer("role", cats)


def main():
    app = QgsApplication([], False)
    app.initQgis()
    OUT.mkdir(parents=True, exist_ok=True)
    for name, geom, renderer in (("tie_points", "Point", tie_points_renderer()),
                                 ("error_vectors", "LineString", error_vectors_renderer())):
        layer = QgsVectorLayer(f"{geom}?field=role:string&field=dx:double&field=dy:double", name, "memory")
        layer.setRenderer(renderer)
        path = OUT / f"{name}.qml"
        msg, ok = layer.saveNamedStyle(str(path), categories=QgsMapLayer.Symbology)
        if not ok:
            sys.exit(f"could not write {path}: {msg}")
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
