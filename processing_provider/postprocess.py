"""Styles applied to fotogeo outputs when Processing loads them into the project.

``styles/tie_points.qml`` colours points by ``role`` (control blue, check red);
``styles/error_vectors.qml`` draws error vectors as arrows, coloured by ``role`` too.
They are set through :class:`QgsProcessingLayerPostProcessorInterface`, which QGIS runs in
the main thread for every output layer loaded on completion.
"""
from __future__ import annotations

import collections
import os

from qgis.core import QgsProcessingContext, QgsProcessingLayerPostProcessorInterface, QgsProcessingUtils, QgsVectorLayer

STYLE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "styles")
STYLES = ("tie_points", "error_vectors")


def style_path(style: str) -> str:
    return os.path.join(STYLE_DIR, f"{style}.qml")


class StylePostProcessor(QgsProcessingLayerPostProcessorInterface):
    """Loads one QML style onto the output layer (stateless, so one instance per style serves all runs)."""

    def __init__(self, style: str):
        super().__init__()
        self.style = style

    def postProcessLayer(self, layer, context, feedback):
        if not isinstance(layer, QgsVectorLayer) or not layer.isValid():
            return
        message, ok = layer.loadNamedStyle(style_path(self.style))
        if not ok and feedback is not None:
            feedback.reportError(f"fotogeo: could not apply style {self.style!r}: {message}")
        layer.triggerRepaint()


# A context takes ownership of its post-processors and deletes them with itself, so every
# layer gets a new instance; Python keeps a reference to the recent ones as well, so that the
# wrapper cannot be collected before QGIS has used it.
_RECENT: collections.deque = collections.deque(maxlen=64)


def post_processor(style: str) -> StylePostProcessor:
    if style not in STYLES:
        raise ValueError(f"unknown style {style!r}; one of {', '.join(STYLES)}")
    processor = StylePostProcessor(style)
    _RECENT.append(processor)
    return processor


def load_on_completion(context, uri: str, name: str, output_name: str, style: str | None,
                       raster: bool = False) -> None:
    """Ask Processing to load ``uri`` (vector, or raster) on completion as ``name``, styled with ``style``."""
    hint = QgsProcessingUtils.LayerHint.Raster if raster else QgsProcessingUtils.LayerHint.Vector
    details = QgsProcessingContext.LayerDetails(name, context.project(), output_name, hint)
    if style:
        details.setPostProcessor(post_processor(style))
    context.addLayerToLoadOnCompletion(uri, details)


def style_output(context, key: str, style: str) -> None:
    """Set ``style`` on an output Processing already loads on completion (e.g. a vector destination)."""
    if context.willLoadLayerOnCompletion(key):
        context.layerToLoadOnCompletionDetails(key).setPostProcessor(post_processor(style))
