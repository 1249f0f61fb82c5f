"""Styles applied to fotogeo outputs when Processing loads them into the project.

``styles/tie_points.qml`` colours points by ``role`` (control blue, check red; by ``class`` where a layer has it:
suspect orange, blunder magenta, :func:`by_legend_class`; categories without a feature are dropped);
and labels each with its id and residual (px); ``styles/error_vectors.qml`` draws error vectors
as arrows, coloured by ``role`` too, and :func:`show_legend` puts the layer's exaggeration
sentence (its ``legend`` field) into the legend. ``styles/uncertainty.qml`` (rasters of a σ in metres,
``fotogeo ortho --uncertainty``) is a pseudocolour ramp (viridis) with a continuous legend labelled in
metres; :func:`stretch_to_data` spreads it over the raster's own minimum … maximum. ``styles/dsm.qml`` (a surface
model, ``fotogeo dsm``: band 1 the height, 2 the pair count, 3 the spread) shows band 1 alone as a hypsometric ramp
(green, yellow, brown, white) with a legend in metres, spread over the heights' 2 … 98 % cumulative cut (the style's
min/max origin) so that a few blunders do not flatten it. ``styles/coreg_windows.qml``
draws co-registration windows: a reliable one (status ``ok``) as a green dot with an arrowhead along its shift,
any other as a small grey cross. A DSM beside which a ``.qml`` fotogeo did not write lies (a user's style, or QGIS's
"Save as Default") keeps it: the run writes none (:func:`keep_users_style`) and the layer loads with it
(:func:`dsm_look`).
They are set through :class:`QgsProcessingLayerPostProcessorInterface`, which QGIS runs in
the main thread for every output layer loaded on completion.
"""
from __future__ import annotations

import collections
import os

from qgis.core import (
    QgsLayerTreeLayer,
    QgsRasterBandStats,
    QgsRasterLayer,
    QgsRasterMinMaxOrigin,
    QgsProcessingContext,
    QgsProcessingLayerPostProcessorInterface,
    QgsProcessingUtils,
    QgsProject,
    QgsRendererCategory,
    QgsVectorLayer,
    QgsWkbTypes,
)
from qgis.PyQt.QtCore import QTimer

STYLE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "styles")
STYLES = ("tie_points", "gcps", "error_vectors", "error_grid", "footprints", "uncertainty", "coreg_windows", "dsm")


def style_path(style: str) -> str:
    return os.path.join(STYLE_DIR, f"{style}.qml")


class LoadedRun:
    """The layers one algorithm run loads: keeps its vector layers above its rasters in the layer tree.

    Processing adds the layers of a run in the order of their sources (so a ``.gpkg`` comes
    before a ``.tif``), each on top of the tree: without help the raster would hide the tie
    points and error vectors. Each layer's post-processor reports here once it is added.
    """

    def __init__(self):
        self.vector_ids: list[str] = []

    def place(self, layer, context) -> None:
        project = (context.project() if context is not None else None) or QgsProject.instance()
        node = project.layerTreeRoot().findLayer(layer.id())
        if node is None:
            return
        if isinstance(layer, QgsVectorLayer):
            self.vector_ids.append(layer.id())
            self._points_on_top(node.parent())
            return
        parent = node.parent()
        children = parent.children()
        below = [i for i, n in enumerate(children) if isinstance(n, QgsLayerTreeLayer) and n.layerId() in self.vector_ids]
        if below and children.index(node) < max(below):
            parent.insertChildNode(max(below) + 1, node.clone())
            parent.removeChildNode(node)

    def _points_on_top(self, parent) -> None:
        """Reorder the run's vector layers under ``parent``, from the place of the topmost: points above lines
        above polygons (a footprint outline never covers the control points), otherwise as added. The clones
        go in before the nodes come out: a layer left without a node is removed from the project."""
        nodes = [n for n in parent.children()
                 if isinstance(n, QgsLayerTreeLayer) and n.layerId() in self.vector_ids and n.layer() is not None]
        ranked = sorted(nodes, key=lambda n: _GEOMETRY_RANK.get(n.layer().geometryType(), 3))
        if ranked == nodes:
            return
        top = parent.children().index(nodes[0])
        for k, node in enumerate(ranked):
            parent.insertChildNode(top + k, node.clone())
        for node in nodes:
            parent.removeChildNode(node)


#: the order of a run's vector layers in the tree, top first
_GEOMETRY_RANK = {QgsWkbTypes.PointGeometry: 0, QgsWkbTypes.LineGeometry: 1, QgsWkbTypes.PolygonGeometry: 2}


class StylePostProcessor(QgsProcessingLayerPostProcessorInterface):
    """Loads one QML style (None: keeps the layer's style) onto the output layer, unticks the categories
    ``hidden`` (e.g. the many control points of a registration: optional, the check points stay visible);
    places it in its run and expands it in the layer tree (its legend readable at once)."""

    def __init__(self, style: str | None, run: LoadedRun | None = None, hidden: tuple = ()):
        super().__init__()
        self.style, self.run, self.hidden = style, run, tuple(hidden)

    def postProcessLayer(self, layer, context, feedback):
        if layer is None or not layer.isValid():
            return
        if self.style and isinstance(layer, QgsVectorLayer):
            message, ok = layer.loadNamedStyle(style_path(self.style))
            if not ok and feedback is not None:
                feedback.reportError(f"fotogeo: could not apply style {self.style!r}: {message}")
            by_legend_class(layer)
            drop_empty_categories(layer)
            draw_shown_only(layer)
            hide_categories(layer, self.hidden)
            show_legend(layer)
            layer.setRenderer(layer.renderer().clone())  # tells the legend (an edit in place would not)
            layer.triggerRepaint()
        if self.style and isinstance(layer, QgsRasterLayer):
            message, ok = layer.loadNamedStyle(style_path(self.style))
            if not ok and feedback is not None:
                feedback.reportError(f"fotogeo: could not apply style {self.style!r}: {message}")
            stretch_to_data(layer)
            layer.triggerRepaint()
        if self.run is not None:
            self.run.place(layer, context)
        project = (context.project() if context is not None else None) or QgsProject.instance()
        unique_name(layer, project)
        if isinstance(layer, QgsVectorLayer):
            expand_later(project, layer.id())
        elif isinstance(layer, QgsRasterLayer) and layer.renderer() is not None and \
                layer.renderer().type() == "multibandcolor":  # an RGB orthophoto's Band 1/2/3 legend says nothing
            expand_later(project, layer.id(), expanded=False)


def stretch_to_data(layer) -> tuple | None:
    """Spread a pseudocolour raster's ramp over its band's minimum … maximum — or, when the style's min/max origin
    is a cumulative cut, over those quantiles of its values (the style's 0 … 1 is a placeholder: QGIS does not
    recompute a loaded style's range); returns that range, None for another renderer or a raster without valid
    cells. The layer gets a new renderer: its legend's labels follow (an edit in place would not tell it)."""
    renderer = layer.renderer().clone() if layer.renderer() is not None else None
    shader = getattr(renderer, "shader", lambda: None)()
    ramp = shader.rasterShaderFunction() if shader is not None else None
    if ramp is None:
        return None
    band, origin = renderer.band(), renderer.minMaxOrigin()
    if origin.limits() == QgsRasterMinMaxOrigin.CumulativeCut:
        lo, hi = layer.dataProvider().cumulativeCut(band, origin.cumulativeCutLower(), origin.cumulativeCutUpper())
    else:
        stats = layer.dataProvider().bandStatistics(band, QgsRasterBandStats.Min | QgsRasterBandStats.Max)
        lo, hi = stats.minimumValue, stats.maximumValue
    lo, hi = float(lo), float(hi)
    if not (hi >= lo) or abs(lo) == float("inf") or abs(hi) == float("inf"):
        return None
    hi = hi if hi > lo else lo + max(abs(lo), 1.0) * 1e-3
    shader.setMinimumValue(lo)
    shader.setMaximumValue(hi)
    ramp.setMinimumValue(lo)
    ramp.setMaximumValue(hi)
    ramp.classifyColorRamp(0, -1)
    renderer.setClassificationMin(lo)
    renderer.setClassificationMax(hi)
    layer.setRenderer(renderer)
    return lo, hi


def expand_later(project, layer_id: str, expanded: bool = True) -> None:
    """Expand (or collapse) the layer's node once the legend has been rebuilt (the tree view collapses a node
    whose legend it refreshes, while the node still says expanded: toggled, the view follows; left alone, the
    six orthophotos of a drone block came out expanded and collapsed in turn)."""
    def expand():
        node = project.layerTreeRoot().findLayer(layer_id)
        if node is not None:
            node.setExpanded(not expanded)
            node.setExpanded(expanded)
    expand()
    QTimer.singleShot(0, expand)


def by_legend_class(layer) -> bool:
    """Categorise by the ``class`` field where the layer has one (fotogeo.tools.common.gcp_style: a point's role, or
    ``blunder`` / ``suspect`` where the blunder test flagged it) instead of ``role``; returns whether it did."""
    renderer = layer.renderer()
    if getattr(renderer, "classAttribute", lambda: None)() != "role" or layer.fields().indexOf("class") < 0:
        return False
    renderer.setClassAttribute("class")
    return True


def draw_shown_only(layer) -> bool:
    """Draw only the features whose ``shown`` field is 1 (error vectors thinned to one arrow per cell of the
    extent, fotogeo.io.vector.readable_subset; the others stay in the layer and its table). Returns whether the
    layer has the field."""
    from qgis.core import QgsProperty, QgsSymbolLayer
    if layer.fields().indexOf("shown") < 0:
        return False
    enabled = QgsProperty.fromExpression('coalesce("shown", 1) = 1')
    renderer = layer.renderer()
    for i, category in enumerate(getattr(renderer, "categories", lambda: [])()):
        symbol = category.symbol().clone()  # categories() gives copies: change and set back
        for symbol_layer in symbol.symbolLayers():
            symbol_layer.setDataDefinedProperty(QgsSymbolLayer.PropertyLayerEnabled, enabled)
        renderer.updateCategorySymbol(i, symbol)
    return True


def drop_empty_categories(layer) -> list:
    """Remove the categories no feature of ``layer`` falls in (an empty "other", a blunder class without a
    blunder): the legend lists what the map shows. Returns the values removed."""
    renderer = layer.renderer()
    categories = getattr(renderer, "categories", lambda: [])()
    index = layer.fields().indexOf(getattr(renderer, "classAttribute", lambda: "")())
    if not categories or index < 0:
        return []
    present = {str(v) if v is not None else "" for v in layer.uniqueValues(index)}
    named = {str(c.value()) for c in categories if str(c.value()) != ""}
    removed = []
    for i in reversed(range(len(categories))):
        value = str(categories[i].value())
        empty = not (present - named) if value == "" else value not in present
        if empty:
            renderer.deleteCategory(i)
            removed.append(value)
    return removed


def hide_categories(layer, values) -> None:
    """Untick (do not draw, keep in the legend) the categories of ``layer`` whose value is in ``values``."""
    renderer = layer.renderer()
    for i, category in enumerate(getattr(renderer, "categories", lambda: [])()):
        if category.value() in values:
            renderer.updateCategoryRenderState(i, False)


def unique_name(layer, project) -> str:
    """Give ``layer`` a name no other layer of ``project`` has ("frame registered (2)" after a second run)."""
    taken = {other.name() for other in project.mapLayers().values() if other.id() != layer.id()}
    base, n = layer.name(), 2
    name = base
    while name in taken:
        name, n = f"{base} ({n})", n + 1
    if name != base:
        layer.setName(name)
    return name


#: the value of the legend-only category that carries the exaggeration sentence (no feature has it)
LEGEND_VALUE = "__scale__"


def show_legend(layer) -> str | None:
    """Put the layer's ``legend`` field (error vectors: "x20; 1 mm on the map = 0.25 m of error (at
    1:50 000)", see fotogeo.io.vector) into its legend: a legend line of its own (a category no feature
    belongs to, drawn with the check points' arrow), and the layer's abstract (its tooltip). Returns the
    text, or None for a layer without it."""
    if layer.fields().indexOf("legend") < 0:
        return None
    feature = next(layer.getFeatures(), None)
    text = feature["legend"] if feature is not None else None
    if not text:
        return None
    renderer = layer.renderer()
    categories = getattr(renderer, "categories", lambda: [])()
    if categories and all(c.value() != LEGEND_VALUE for c in categories):
        sample = next((c for c in categories if c.value() == "check"), categories[0])
        renderer.addCategory(QgsRendererCategory(LEGEND_VALUE, sample.symbol().clone(), f"drawn {text}"))
    layer.setAbstract(f"Error vectors drawn {text}.")
    return text


# A context takes ownership of its post-processors and deletes them with itself, so every
# layer gets a new instance; Python keeps a reference to the recent ones as well, so that the
# wrapper cannot be collected before QGIS has used it.
_RECENT: collections.deque = collections.deque(maxlen=64)


def post_processor(style: str | None, run: LoadedRun | None = None, hidden: tuple = ()) -> StylePostProcessor:
    if style is not None and style not in STYLES:
        raise ValueError(f"unknown style {style!r}; one of {', '.join(STYLES)}")
    processor = StylePostProcessor(style, run, hidden)
    _RECENT.append(processor)
    return processor


def load_on_completion(context, uri: str, name: str, output_name: str, style: str | None,
                       raster: bool = False, run: LoadedRun | None = None, hidden: tuple = ()) -> None:
    """Ask Processing to load ``uri`` (vector or raster; a CSV loads as a table) on completion as ``name``, styled with
    ``style`` (categories ``hidden`` unticked); with ``run`` its vectors stay above its rasters."""
    hint = (QgsProcessingUtils.LayerHint.Raster if raster else QgsProcessingUtils.LayerHint.Vector)
    details = QgsProcessingContext.LayerDetails(name, context.project(), output_name, hint)
    details.forceName = True  # the run's own name ("frame_0182 tie points"), not the file's
    if style or run is not None or hidden:
        details.setPostProcessor(post_processor(style, run, hidden))
    context.addLayerToLoadOnCompletion(uri, details)


def file_layer_name(path: str) -> str | None:
    """The name a raster output's layer takes: its file's stem ("dsm_0182" for dsm_0182.tif), as the tools' outputs
    are named in the project; None for a temporary output (``OUTPUT.tif`` in Processing's temporary folder: the
    parameter's description says more than that file's name)."""
    if os.path.abspath(path).startswith(os.path.abspath(QgsProcessingUtils.tempFolder()) + os.sep):
        return None
    return os.path.splitext(os.path.basename(path))[0]


def style_output(context, key: str, style: str | None, run: LoadedRun | None = None, name: str | None = None) -> None:
    """Set ``style`` on an output Processing already loads on completion (e.g. a vector destination), and
    its layer ``name`` when given (instead of the parameter's description, the same for every run). ``key`` may be
    the output's path as a tool reported it: it matches the path Processing holds however either is spelled."""
    same = os.path.normcase(os.path.abspath(key))
    key = next((k for k in context.layersToLoadOnCompletion() if os.path.normcase(os.path.abspath(k)) == same), key)
    if context.willLoadLayerOnCompletion(key):
        details = context.layerToLoadOnCompletionDetails(key)
        details.setPostProcessor(post_processor(style, run))
        if name:
            details.name, details.forceName = name, True


def keep_users_style(arguments: dict, dsm, feedback, label: str) -> None:
    """Keep a QGIS style beside the DSM ``dsm`` that fotogeo did not write (:func:`fotogeo.io.qml.users_style`): the
    run writes none (``arguments["qgis_style"]`` off) and the log says so, naming the parameter ``label``. The tool
    would replace it, the plugin passing ``overwrite`` always (QGIS asked about the DSM, not about its style)."""
    from fotogeo.io.qml import users_style
    mine = users_style(dsm) if dsm and arguments.get("qgis_style") else None
    if mine is not None:
        arguments["qgis_style"] = False
        feedback.pushWarning(f"kept the QGIS style {str(mine)!r}: fotogeo did not write it (a style of yours?); "
                             f"delete it to have fotogeo's written, or untick “{label}” to say so")


def dsm_look(dsm) -> str | None:
    """The style a loaded DSM gets: the plugin's ``dsm``, or None (its own) when a style fotogeo did not write lies
    beside it (QGIS loads that as the layer's default)."""
    from fotogeo.io.qml import users_style
    return None if users_style(dsm) is not None else "dsm"
