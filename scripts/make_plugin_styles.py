"""Regenerate processing_provider/styles/*.qml with PyQGIS (run once after changing a style).

    QT_QPA_PLATFORM=offscreen .venv/bin/python scripts/make_plugin_styles.py

tie_points.qml: points categorised by ``role`` — control blue circles, check red triangles
(dense registration tie points: unlabelled, labels would bury the image).
gcps.qml: the same symbols, labelled "id: residual px" (small, white buffer): GCP layers (orient,
points-to-layer), a few dozen points each.
error_vectors.qml: lines drawn as arrows from the reference position, categorised by ``role``.
error_grid.qml: the registration's mean residual per grid cell, one dark-orange arrow per cell.
uncertainty.qml: a σ raster in metres (``fotogeo ortho --uncertainty``), pseudocolour (viridis, interpolated) with a
continuous legend whose labels end in " m" (3 decimals); the ramp's 0 … 1 is a placeholder the plugin stretches
over each raster's range (``processing_provider.postprocess.stretch_to_data``).

``--only NAME ...`` regenerates just those styles.
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
    QgsPalLayerSettings,
    QgsTextBufferSettings,
    QgsTextFormat,
    QgsVectorLayerSimpleLabeling,
    QgsRendererCategory,
    QgsSingleSymbolRenderer,
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


def arrow_symbol(colour: str, width: float = 0.3) -> QgsLineSymbol:
    """A straight arrow from the line's start, plain single head."""
    arrow = QgsArrowSymbolLayer()
    arrow.setIsCurved(False)
    arrow.setIsRepeated(False)
    arrow.setArrowWidth(width)
    arrow.setArrowStartWidth(width)
    arrow.setHeadLength(1.6)
    arrow.setHeadThickness(1.0)
    arrow.setHeadType(QgsArrowSymbolLayer.HeadSingle)
    arrow.setArrowType(QgsArrowSymbolLayer.ArrowPlain)
    arrow.subSymbol().setColor(QColor(colour))
    arrow.subSymbol().symbolLayer(0).setStrokeColor(QColor(colour))
    sym = QgsLineSymbol()
    sym.changeSymbolLayer(0, arrow)
    return sym


def tie_points_labeling():
    settings = QgsPalLayerSettings()
    # residual_px (orient's gcps layer) or residual (points-to-layer); attribute() is NULL, not an error, when missing
    settings.fieldName = ("concat(\"id\", ': ', format_number(coalesce(attribute('residual_px'), "
                          "attribute('residual')), 2), ' px')")
    settings.isExpression = True
    settings.dist = 1.0
    fmt = QgsTextFormat()
    fmt.setSize(8)
    buffer = QgsTextBufferSettings()
    buffer.setEnabled(True)
    buffer.setSize(0.8)
    buffer.setColor(QColor("#ffffff"))
    buffer.setOpacity(0.8)
    fmt.setBuffer(buffer)
    settings.setFormat(fmt)
    return QgsVectorLayerSimpleLabeling(settings)


def error_grid_renderer():
    return QgsSingleSymbolRenderer(arrow_symbol("#d95f02", 0.5))


def error_vectors_renderer():
    cats = []
    for value, label, colour in ROLES + ((None, "other", "#888888"),):
        cats.append(QgsRendererCategory(value, arrow_symbol(colour), label))
    return QgsCategorizedSymbolRenderer("role", cats)


def uncertainty_style(path: Path) -> None:
    """Write uncertainty.qml (module docstring) from a small σ raster's pseudocolour renderer."""
    import tempfile

    import numpy as np
    import rasterio
    from affine import Affine
    from qgis.core import (QgsBasicNumericFormat, QgsColorRampLegendNodeSettings, QgsColorRampShader,
                           QgsRasterLayer, QgsRasterShader, QgsSingleBandPseudoColorRenderer, QgsStyle)
    with tempfile.TemporaryDirectory() as tmp:
        tif = Path(tmp) / "sigma.tif"
        with rasterio.open(tif, "w", driver="GTiff", width=4, height=4, count=1, dtype="float32", crs="EPSG:32635",
                           transform=Affine(1, 0, 500000, 0, -1, 4400000), nodata=float("nan")) as ds:
            ds.write(np.linspace(0, 1, 16, dtype=np.float32).reshape(1, 4, 4))
        layer = QgsRasterLayer(str(tif), "sigma")
        ramp = QgsColorRampShader(0.0, 1.0, QgsStyle.defaultStyle().colorRamp("Viridis"),
                                  QgsColorRampShader.Interpolated, QgsColorRampShader.Continuous)
        ramp.classifyColorRamp(5, -1)
        legend = QgsColorRampLegendNodeSettings()
        legend.setSuffix(" m")
        legend.setUseContinuousLegend(True)
        number = QgsBasicNumericFormat()
        number.setNumberDecimalPlaces(3)
        legend.setNumericFormat(number)
        ramp.setLegendSettings(legend)
        shader = QgsRasterShader()
        shader.setRasterShaderFunction(ramp)
        renderer = QgsSingleBandPseudoColorRenderer(layer.dataProvider(), 1, shader)
        renderer.setClassificationMin(0.0)
        renderer.setClassificationMax(1.0)
        layer.setRenderer(renderer)
        msg, ok = layer.saveNamedStyle(str(path), categories=QgsMapLayer.Symbology)
    if not ok:
        sys.exit(f"could not write {path}: {msg}")
    print(f"wrote {path}")


def main():
    only = set(sys.argv[sys.argv.index("--only") + 1:]) if "--only" in sys.argv else None
    app = QgsApplication([], False)
    app.initQgis()
    OUT.mkdir(parents=True, exist_ok=True)
    for name, geom, renderer in (("tie_points", "Point", tie_points_renderer()),
                                 ("gcps", "Point", tie_points_renderer()),
                                 ("error_vectors", "LineString", error_vectors_renderer()),
                                 ("error_grid", "LineString", error_grid_renderer())):
        if only is not None and name not in only:
            continue
        layer = QgsVectorLayer(f"{geom}?field=role:string&field=dx:double&field=dy:double", name, "memory")
        layer.setRenderer(renderer)
        categories = QgsMapLayer.Symbology
        if name == "gcps":
            layer.setLabeling(tie_points_labeling())
            layer.setLabelsEnabled(True)
            categories |= QgsMapLayer.Labeling
        path = OUT / f"{name}.qml"
        msg, ok = layer.saveNamedStyle(str(path), categories=categories)
        if not ok:
            sys.exit(f"could not write {path}: {msg}")
        print(f"wrote {path}")
    if only is None or "uncertainty" in only:
        uncertainty_style(OUT / "uncertainty.qml")


if __name__ == "__main__":
    main()
