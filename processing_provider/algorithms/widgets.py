"""Dialog defaults Processing cannot declare: raster inputs pre-filled by the role of a layer.

QGIS opens every required layer input of an algorithm dialog on the active layer, so *Target*
would start equal to *Reference* (and Run registers the orthophoto to itself), and a DEM that happens
to be active would become the reference image. A parameter with
``metadata={"widget_wrapper": {"class": OtherLayer, "other": "REFERENCE", "role": "image"}}`` gets a
layer combo box that, once all the dialog's widgets exist, moves off the ``other`` input's layer and —
with ``role="image"`` — off a layer that looks like a DEM (:func:`looks_like_dem`) to the next raster
layer of the project (top of the layer tree first), or to empty when there is none; ``role="reference"`` moves
off a DEM and off an image that is not a map product too (no georeference, or a rotated one: a raw frame with an
approximate georeference; orthophotos and map-geometry scenes are north-up); ``role="dem"``
(an optional DEM input) starts on the first layer that looks like a DEM. Only the desktop dialog reads
this metadata; ``qgis_process`` and scripts are unaffected. The dialog renders an algorithm's help as HTML (a
paragraph per line) while ``qgis_process help`` prints it as it is: :func:`plain_text` is the help it prints.
"""
from __future__ import annotations

import html
import re
import warnings


#: words of a layer's name that say it holds heights
DEM_WORDS = {"dem", "dsm", "dtm", "elev", "elevation", "height", "heights", "srtm", "lidar"}


def looks_like_dem(name: str, bands: int) -> bool:
    """Whether a raster layer looks like a DEM: one band, and a word of its name says heights (dem, dsm, dtm,
    elev… — a word, so that "demo" is not one). The band's type does not decide: DEMs come as float and as
    16-bit integers (SRTM).

    >>> looks_like_dem("dem", 1), looks_like_dem("ngi_dsm_5m", 1), looks_like_dem("DTM 2015", 1)
    (True, True, True)
    >>> looks_like_dem("orthophoto", 3), looks_like_dem("frame 0182", 1), looks_like_dem("demo_scene", 1)
    (False, False, False)
    """
    return bands == 1 and bool(DEM_WORDS & set(re.split(r"[^a-z]+", name.lower())))


def plain_text(text: str) -> str:
    """An algorithm's help (HTML) as plain text: its tags dropped, its entities decoded.

    >>> plain_text("<b>Uncertainty</b>: &lt;name&gt;_ortho_sigma.tif, σ &gt; 0")
    'Uncertainty: <name>_ortho_sigma.tif, σ > 0'
    """
    return html.unescape(re.sub(r"<[^<>]+>", "", text))


def other_layer(layers, taken, avoid=lambda layer: False):
    """The first layer of ``layers`` (in layer-tree order) that is not ``taken`` and not ``avoid``-ed, or None.

    >>> other_layer(["a", "b", "c"], "a"), other_layer(["a"], "a"), other_layer([], None)
    ('b', None, None)
    >>> other_layer(["dem", "b", "c"], "b", lambda name: name == "dem")
    'c'
    """
    return next((layer for layer in layers if layer != taken and not avoid(layer)), None)


def layer_is_dem(layer) -> bool:
    """:func:`looks_like_dem` of a QGIS raster layer."""
    return layer is not None and looks_like_dem(layer.name(), layer.bandCount())


def layer_is_not_a_map(layer) -> bool:
    """A raster layer that is no map product: without a geotransform (QGIS places it in pixel units, (0, −height)
    to (width, 0)), or with a rotated one (a raw frame's approximate georeference)."""
    from qgis.core import QgsRectangle
    if layer is None:
        return False
    if layer.extent() == QgsRectangle(0, -layer.height(), layer.width(), 0):
        return True
    if layer.providerType() != "gdal":
        return False
    from osgeo import gdal
    ds = gdal.OpenEx(layer.source().split("|")[0], gdal.OF_RASTER | gdal.OF_READONLY)
    gt = ds.GetGeoTransform() if ds is not None else None
    return gt is not None and (gt[2] != 0 or gt[4] != 0)


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


def layer_roles(algorithm, roles: dict) -> None:
    """Give the algorithm's raster parameters ``{name: (other, role)}`` their :class:`OtherLayer` defaults
    (a name the algorithm does not have is skipped)."""
    for name, (other, role) in roles.items():
        definition = algorithm.parameterDefinition(name)
        if definition is not None:
            definition.setMetadata({**definition.metadata(), "widget_wrapper": {"class": OtherLayer, "other": other,
                                                                                "role": role}})


class OtherLayer:
    """``widget_wrapper`` class of a raster input that must not start on the ``other`` input's layer.

    A factory (the processing GUI instantiates the class it finds in the metadata): the wrapper
    itself subclasses Processing's raster wrapper, imported only when a dialog is built.
    """

    def __new__(cls, param, dialog, row=0, col=0, other: str = "", role: str = "", **kwargs):
        with warnings.catch_warnings():  # the Python raster wrapper is deprecated for QGIS 4; 3.22 is the target
            warnings.simplefilter("ignore", DeprecationWarning)
            from processing.gui.wrappers import RasterWidgetWrapper

            class _Wrapper(RasterWidgetWrapper):
                def postInitialize(self, wrappers):  # noqa: N802 - QGIS API
                    super().postInitialize(wrappers)
                    mine = _layer_of(self.value())
                    if role == "dem":
                        if mine is None:
                            self.combo.setLayer(next((lay for lay in _raster_layers() if layer_is_dem(lay)), None))
                        return
                    sibling = next((w for w in wrappers if w.parameterDefinition().name() == other), None)
                    taken = _layer_of(_wrapper_value(sibling)) if sibling is not None else None
                    avoid = {"image": layer_is_dem,
                             "reference": lambda layer: layer_is_dem(layer) or layer_is_not_a_map(layer)}.get(
                        role, lambda layer: False)
                    same = taken is not None and mine is not None and mine.id() == taken.id()
                    if mine is None or same or avoid(mine):
                        self.combo.setLayer(other_layer(_raster_layers(), taken, avoid))

            return _Wrapper(param, dialog, row, col, **kwargs)
