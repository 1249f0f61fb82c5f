"""Dialog defaults Processing cannot declare: a raster input that starts on another layer than a sibling input.

QGIS opens every required layer input of an algorithm dialog on the active layer, so *Target*
would start equal to *Reference* (and Run registers the orthophoto to itself). A parameter with
``metadata={"widget_wrapper": {"class": OtherLayer, "other": "REFERENCE"}}`` gets a layer combo box
that, once all the dialog's widgets exist, moves off the ``other`` input's layer to the next raster
layer of the project (top of the layer tree first) — or to empty when there is none. Only the
desktop dialog reads this metadata; ``qgis_process`` and scripts are unaffected.
"""
from __future__ import annotations

import warnings


def other_layer(layers, taken):
    """The first layer of ``layers`` (in layer-tree order) that is not ``taken``, or None.

    >>> other_layer(["a", "b", "c"], "a"), other_layer(["a"], "a"), other_layer([], None)
    ('b', None, None)
    """
    return next((layer for layer in layers if layer != taken), None)


def _wrapper_value(wrapper):
    """A sibling wrapper's current value (a C++ wrapper's ``parameterValue``, a Python one's ``value``)."""
    read = getattr(wrapper, "parameterValue", None) or getattr(wrapper, "value", None)
    return read() if read is not None else None


def _layer_of(value):
    from qgis.core import QgsMapLayer, QgsProject
    if isinstance(value, QgsMapLayer):
        return value
    project = QgsProject.instance()
    if isinstance(value, str):
        return project.mapLayer(value) or next(iter(project.mapLayersByName(value)), None) or next(
            (lay for lay in project.mapLayers().values() if lay.source() == value), None)
    return None


def _raster_layers():
    from qgis.core import QgsProject, QgsRasterLayer
    return [node.layer() for node in QgsProject.instance().layerTreeRoot().findLayers()
            if isinstance(node.layer(), QgsRasterLayer)]


class OtherLayer:
    """``widget_wrapper`` class of a raster input that must not start on the ``other`` input's layer.

    A factory (the processing GUI instantiates the class it finds in the metadata): the wrapper
    itself subclasses Processing's raster wrapper, imported only when a dialog is built.
    """

    def __new__(cls, param, dialog, row=0, col=0, other: str = "", **kwargs):
        with warnings.catch_warnings():  # the Python raster wrapper is deprecated for QGIS 4; 3.22 is the target
            warnings.simplefilter("ignore", DeprecationWarning)
            from processing.gui.wrappers import RasterWidgetWrapper

            class _Wrapper(RasterWidgetWrapper):
                def postInitialize(self, wrappers):  # noqa: N802 - QGIS API
                    super().postInitialize(wrappers)
                    sibling = next((w for w in wrappers if w.parameterDefinition().name() == other), None)
                    taken = _layer_of(_wrapper_value(sibling)) if sibling is not None else None
                    mine = _layer_of(self.value())
                    if taken is None or mine is None or mine.id() != taken.id():
                        return
                    self.combo.setLayer(other_layer(_raster_layers(), taken))

            return _Wrapper(param, dialog, row, col, **kwargs)
