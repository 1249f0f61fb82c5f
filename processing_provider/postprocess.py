"""Styles applied to fotogeo outputs when Processing loads them into the project.

``styles/tie_points.qml`` colours points by ``role`` (control blue, check red);
and labels each with its id and residual (px); ``styles/error_vectors.qml`` draws error vectors
as arrows, coloured by ``role`` too, and :func:`show_legend` puts the layer's exaggeration
sentence (its ``legend`` field) into the legend.
They are set through :class:`QgsProcessingLayerPostProcessorInterface`, which QGIS runs in
the main thread for every output layer loaded on completion.
"""
from __future__ import annotations

import collections
import os

from qgis.core import (
    QgsLayerTreeLayer,
    QgsProcessingContext,
    QgsProcessingLayerPostProcessorInterface,
    QgsProcessingUtils,
    QgsProject,
    QgsVectorLayer,
)

STYLE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "styles")
STYLES = ("tie_points", "gcps", "error_vectors", "error_grid")


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
            return
        parent = node.parent()
        children = parent.children()
        below = [i for i, n in enumerate(children) if isinstance(n, QgsLayerTreeLayer) and n.layerId() in self.vector_ids]
        if below and children.index(node) < max(below):
            parent.insertChildNode(max(below) + 1, node.clone())
            parent.removeChildNode(node)


class StylePostProcessor(QgsProcessingLayerPostProcessorInterface):
    """Loads one QML style (None: keeps the layer's style) onto the output layer; places it in its run."""

    def __init__(self, style: str | None, run: LoadedRun | None = None):
        super().__init__()
        self.style, self.run = style, run

    def postProcessLayer(self, layer, context, feedback):
        if layer is None or not layer.isValid():
            return
        if self.style and isinstance(layer, QgsVectorLayer):
            message, ok = layer.loadNamedStyle(style_path(self.style))
            if not ok and feedback is not None:
                feedback.reportError(f"fotogeo: could not apply style {self.style!r}: {message}")
            show_legend(layer)
            layer.triggerRepaint()
        if self.run is not None:
            self.run.place(layer, context)


def show_legend(layer) -> str | None:
    """Put the layer's ``legend`` field (error vectors: "x20; 1 mm on the map = 0.25 m of error (at
    1:50 000)", see fotogeo.io.vector) into its legend: appended to each category's label and
    set as the layer's abstract. Returns the text, or None for a layer without it."""
    if layer.fields().indexOf("legend") < 0:
        return None
    feature = next(layer.getFeatures(), None)
    text = feature["legend"] if feature is not None else None
    if not text:
        return None
    renderer = layer.renderer()
    if hasattr(renderer, "categories"):
        for i, category in enumerate(renderer.categories()):
            renderer.updateCategoryLabel(i, f"{category.label()} ({text})")
    layer.setAbstract(f"Error vectors drawn {text}.")
    return text


# A context takes ownership of its post-processors and deletes them with itself, so every
# layer gets a new instance; Python keeps a reference to the recent ones as well, so that the
# wrapper cannot be collected before QGIS has used it.
_RECENT: collections.deque = collections.deque(maxlen=64)


def post_processor(style: str | None, run: LoadedRun | None = None) -> StylePostProcessor:
    if style is not None and style not in STYLES:
        raise ValueError(f"unknown style {style!r}; one of {', '.join(STYLES)}")
    processor = StylePostProcessor(style, run)
    _RECENT.append(processor)
    return processor


def load_on_completion(context, uri: str, name: str, output_name: str, style: str | None,
                       raster: bool = False, run: LoadedRun | None = None) -> None:
    """Ask Processing to load ``uri`` (vector or raster; a CSV loads as a table) on completion as ``name``, styled with
    ``style``; with ``run`` its vectors stay above its rasters."""
    hint = (QgsProcessingUtils.LayerHint.Raster if raster else QgsProcessingUtils.LayerHint.Vector)
    details = QgsProcessingContext.LayerDetails(name, context.project(), output_name, hint)
    if style or run is not None:
        details.setPostProcessor(post_processor(style, run))
    context.addLayerToLoadOnCompletion(uri, details)


def style_output(context, key: str, style: str | None, run: LoadedRun | None = None) -> None:
    """Set ``style`` on an output Processing already loads on completion (e.g. a vector destination)."""
    if context.willLoadLayerOnCompletion(key):
        context.layerToLoadOnCompletionDetails(key).setPostProcessor(post_processor(style, run))
