"""The co-registration windows' style: reliable windows (status ok) as a dot with an arrowhead along the shift,
every rejected window in one grey class; the legend has exactly these two entries."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsExpressionContext, QgsExpressionContextUtils, QgsRenderContext, QgsSymbolLayer  # noqa: E402
from test_qgis_styles import _layer  # noqa: E402

from processing_provider.postprocess import style_path  # noqa: E402


def test_reliable_windows_get_an_arrow_along_their_shift(qgis_app, tmp_path):  # noqa: F811
    import shapely
    layer = _layer(tmp_path, "windows", shapely.points([[0, 0], [100, 0], [200, 0]]),
                   {"dx_map": [3.0, 0.0, 1.0], "dy_map": [0.0, -2.0, 1.0], "status": ["ok", "ok", "ambiguous"]})
    message, ok = layer.loadNamedStyle(style_path("coreg_windows"))
    assert ok, message
    renderer = layer.renderer()
    assert [item.label() for item in renderer.legendSymbolItems()] == [
        "reliable window (arrow: the shift's direction)", "rejected window (see its status)"]
    ctx = QgsRenderContext()
    ctx.setExpressionContext(QgsExpressionContext(QgsExpressionContextUtils.globalProjectLayerScopes(layer)))
    renderer.startRender(ctx, layer.fields())
    angles, shapes = [], []
    for f in layer.getFeatures():
        ctx.expressionContext().setFeature(f)
        symbol = renderer.symbolsForFeature(f, ctx)[0]
        shapes.append(symbol.symbolLayerCount())
        if f["status"] == "ok":
            arrow = symbol.symbolLayer(1).dataDefinedProperties().property(QgsSymbolLayer.PropertyAngle)
            angles.append(round(arrow.valueAsDouble(ctx.expressionContext(), 0)[0], 6))
    renderer.stopRender(ctx)
    assert shapes == [2, 2, 1]  # dot + arrowhead for ok, a cross for the rejected
    assert angles == [0.0, 90.0]  # east, south: the arrowhead points east at 0°, turned by the azimuth of (dx, dy)
