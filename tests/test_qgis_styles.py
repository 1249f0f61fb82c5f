"""The styles of fotogeo's vector outputs in headless QGIS (issue 11): GCP / tie-point labels
(id and residual) and the error vectors' exaggeration sentence in the legend."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsVectorLayer  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from processing_provider.postprocess import show_legend, style_path  # noqa: E402


def _layer(tmp_path, name, geometry, columns):
    import geopandas as gpd
    gpd.GeoDataFrame(columns, geometry=geometry, crs="EPSG:32735").to_file(tmp_path / f"{name}.gpkg", layer=name)
    layer = QgsVectorLayer(f"{tmp_path / name}.gpkg|layername={name}", name, "ogr")
    assert layer.isValid()
    return layer


def test_gcp_labels_show_id_and_residual(qgis_app, tmp_path):
    import shapely
    layer = _layer(tmp_path, "gcps", shapely.points([[0, 0], [10, 10]]),
                   {"id": ["P1", "P2"], "role": ["control", "check"], "residual_px": [0.1234, 2.5]})
    message, ok = layer.loadNamedStyle(style_path("gcps"))
    assert ok, message
    assert layer.labelsEnabled()
    settings = layer.labeling().settings()
    assert settings.isExpression and '"id"' in settings.fieldName and "residual_px" in settings.fieldName
    from qgis.core import QgsExpression, QgsExpressionContext, QgsExpressionContextUtils
    ctx = QgsExpressionContext(QgsExpressionContextUtils.globalProjectLayerScopes(layer))
    feature = next(layer.getFeatures())
    ctx.setFeature(feature)
    assert QgsExpression(settings.fieldName).evaluate(ctx) == "P1: 0.12 px"
    # a points-to-layer GCP layer names its residual 'residual'; dense tie points stay unlabelled
    other = _layer(tmp_path, "gcps2", shapely.points([[0, 0]]), {"id": ["Q7"], "role": ["check"], "residual": [1.0]})
    other.loadNamedStyle(style_path("gcps"))
    ctx.setFeature(next(other.getFeatures()))
    assert QgsExpression(settings.fieldName).evaluate(ctx) == "Q7: 1.00 px"
    tie = _layer(tmp_path, "tie", shapely.points([[0, 0]]), {"id": ["T1"], "role": ["control"]})
    tie.loadNamedStyle(style_path("tie_points"))
    assert not tie.labelsEnabled()


def test_error_vector_legend_states_the_exaggeration(qgis_app, tmp_path):
    import shapely
    legend = "x200; 1 mm on the map = 0.1 m of error (at 1:20 000)"
    lines = shapely.linestrings(np.array([[[0, 0], [5, 5]], [[10, 10], [12, 9]]], float))
    layer = _layer(tmp_path, "error_vectors", lines, {"role": ["control", "check"], "legend": [legend] * 2,
                                                      "exaggeration": [200.0, 200.0]})
    message, ok = layer.loadNamedStyle(style_path("error_vectors"))
    assert ok, message
    assert show_legend(layer) == legend
    labels = [c.label() for c in layer.renderer().categories()]
    # the sentence is a legend line of its own (the roles keep short labels), drawn with an arrow, once
    assert labels[:2] == ["Control point", "Check point"] and labels[-1] == f"drawn {legend}"
    show_legend(layer)
    assert [c.label() for c in layer.renderer().categories()] == labels
    from qgis.core import QgsLayerTree, QgsLayerTreeModel
    root = QgsLayerTree()
    node = root.addLayer(layer)
    model = QgsLayerTreeModel(root)
    assert f"drawn {legend}" in [n.data(0) for n in model.layerLegendNodes(node)]
    assert legend in layer.abstract()
    plain = _layer(tmp_path, "plain", shapely.points([[0, 0]]), {"role": ["control"]})
    assert show_legend(plain) is None


def test_run_layers_get_unique_names_and_optional_control(qgis_app, tmp_path):
    """A second run's layers do not repeat the first's names; a registration's control points start unticked."""
    import shapely
    from qgis.core import QgsProject
    from processing_provider.postprocess import hide_categories, unique_name
    project = QgsProject()
    first = _layer(tmp_path, "a", shapely.points([[0, 0]]), {"role": ["control"]})
    first.setName("frame registered")
    project.addMapLayer(first)
    for expected in ("frame registered (2)", "frame registered (3)"):
        again = _layer(tmp_path, "a", shapely.points([[0, 0]]), {"role": ["check"]})
        again.setName("frame registered")
        project.addMapLayer(again)
        assert unique_name(again, project) == expected == again.name()
    assert unique_name(first, project) == "frame registered"
    tie = _layer(tmp_path, "tie2", shapely.points([[0, 0], [1, 1]]), {"role": ["control", "check"]})
    tie.loadNamedStyle(style_path("tie_points"))
    hide_categories(tie, ("control",))
    shown = {c.value(): c.renderState() for c in tie.renderer().categories()}
    assert shown["control"] is False and shown["check"] is True


def test_uncertainty_raster_legend_in_metres_over_its_range(qgis_app, tmp_path):
    """The σ raster of ``fotogeo ortho --uncertainty`` loads as a pseudocolour ramp spread over its own values,
    with a continuous legend whose labels end in metres."""
    import rasterio
    from affine import Affine
    from qgis.core import QgsRasterLayer
    from processing_provider.postprocess import stretch_to_data
    path = tmp_path / "frame_sigma.tif"
    values = np.linspace(0.2, 0.9, 100, dtype=np.float32).reshape(1, 10, 10)
    values[0, 0, 0] = np.nan
    with rasterio.open(path, "w", driver="GTiff", width=10, height=10, count=1, dtype="float32", crs="EPSG:32635",
                       transform=Affine(1, 0, 500000, 0, -1, 4400000), nodata=float("nan")) as ds:
        ds.write(values)
    layer = QgsRasterLayer(str(path), "sigma")
    message, ok = layer.loadNamedStyle(style_path("uncertainty"))
    assert ok, message
    lo, hi = stretch_to_data(layer)
    assert (lo, hi) == pytest.approx((float(np.nanmin(values)), 0.9), abs=1e-6)
    ramp = layer.renderer().shader().rasterShaderFunction()
    assert layer.renderer().type() == "singlebandpseudocolor"
    assert ramp.legendSettings().suffix() == " m" and ramp.legendSettings().useContinuousLegend()
    items = ramp.colorRampItemList()
    assert items[0].value == pytest.approx(lo) and items[-1].value == pytest.approx(hi)


def test_one_legend_with_a_blunder_class_and_no_empty_class(qgis_app, tmp_path):
    """orient's GCP layer (a ``class`` field): categorised by class, a flagged blunder in the blunder class
    whatever its role; only the classes present are listed — no empty "other", no blunder class without one."""
    import shapely

    from processing_provider.postprocess import StylePostProcessor
    layer = _layer(tmp_path, "gcps", shapely.points([[0, 0], [10, 10], [20, 5]]),
                   {"id": ["P1", "P2", "P3"], "role": ["control", "check", "control"],
                    "class": ["control", "check", "blunder"], "flag": ["", "", "blunder"], "w": [0.5, np.nan, 6.1]})
    StylePostProcessor("gcps").postProcessLayer(layer, None, None)
    renderer = layer.renderer()
    assert renderer.classAttribute() == "class"
    assert [c.value() for c in renderer.categories()] == ["control", "check", "blunder"]
    colour = {c.value(): c.symbol().color().name() for c in renderer.categories()}
    assert colour["blunder"] == "#c800c8"  # the magenta orient's plot draws it in
    from fotogeo.tools.orient.tool import PLOT_COLOURS
    assert tuple(reversed(PLOT_COLOURS["blunder"][0])) == (200, 0, 200)
    # a tie-point layer (no class field): by role, its empty classes dropped, an unmatched role still drawn
    tie = _layer(tmp_path, "tie", shapely.points([[0, 0], [1, 1]]), {"id": ["T1", "T2"], "role": ["control", "outlier"]})
    StylePostProcessor("tie_points").postProcessLayer(tie, None, None)
    assert tie.renderer().classAttribute() == "role"
    assert [c.value() for c in tie.renderer().categories()] == ["control", ""]


def test_error_vectors_draw_one_arrow_per_cell_at_full_extent(qgis_app, tmp_path):
    """637 check arrows (the NGI registration's count) thinned to one per cell: the others are in the layer and
    its table but not drawn; the exaggeration lowered so that the arrows drawn fit their cells."""
    import shapely

    from fotogeo.io.vector import error_vectors, fitting_exaggeration, readable_subset
    from processing_provider.postprocess import StylePostProcessor
    rng = np.random.default_rng(4)
    xy = rng.uniform(0, 3000, (637, 2))
    d = rng.normal(0, 2.0, (637, 2))
    shown = readable_subset(xy)
    assert 150 <= shown.sum() <= 17 * 17 and shown.sum() < 637 / 2
    k = fitting_exaggeration(500.0, np.hypot(*d[shown].T), xy)
    cell = 3000 / 16
    assert k < 500 and np.percentile(k * np.hypot(*d[shown].T), 90) <= 0.8 * cell * 1.01
    layer = _layer(tmp_path, "error_vectors", error_vectors(xy, xy + d, k),
                   {"role": ["check"] * 637, "shown": shown.astype(int), "legend": ["x10"] * 637})
    StylePostProcessor("error_vectors").postProcessLayer(layer, None, None)
    from qgis.core import QgsExpressionContext, QgsExpressionContextUtils, QgsSymbolLayer
    categories = layer.renderer().categories()  # kept: a category's symbol lives as long as the list
    symbol = categories[0].symbol().clone()
    prop = symbol.symbolLayer(0).dataDefinedProperties().property(QgsSymbolLayer.PropertyLayerEnabled)
    ctx = QgsExpressionContext(QgsExpressionContextUtils.globalProjectLayerScopes(layer))
    drawn = 0
    for feature in layer.getFeatures():
        ctx.setFeature(feature)
        drawn += bool(prop.valueAsBool(ctx, True)[0])
    assert layer.featureCount() == 637 and drawn == shown.sum()
