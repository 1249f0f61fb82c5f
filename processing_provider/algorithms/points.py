"""``fotogeo:pointstolayer`` and ``fotogeo:layertopoints`` — QGIS Georeferencer ``.points`` files."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterVectorDestination,
)

from fotogeo.options import LAYER_TO_POINTS, POINTS_TO_LAYER

from ..postprocess import style_output
from .base import FotogeoAlgorithm, tr

_CONVENTION = ("Source coordinates: for an unreferenced source raster QGIS writes sourceX = column and "
               "sourceY = -row (y up), with (0, 0) the top-left corner of the top-left pixel (GDAL/QGIS "
               "corner convention; the centre of that pixel is 0.5, -0.5). For a georeferenced source raster "
               "they are its map coordinates: give that raster so that they can be converted to pixels.")


class PointsToLayerAlgorithm(FotogeoAlgorithm):
    ALG_ID = "pointstolayer"
    DISPLAY = ".points file to GCP layer"
    SUMMARY = "Georeferencer points file to GCP layer"
    GROUP = ("gcp", "Ground control points")
    HELP = ("Converts a QGIS Georeferencer <i>.points</i> file (optional '#CRS: &lt;WKT&gt;' line, header "
            "mapX,mapY,sourceX,sourceY,enable,dX,dY,residual) into a GeoPackage point layer at the map "
            "positions, with the fields fotogeo's tools use: id, col, row (source pixel, GDAL corner "
            "convention), z (empty), role (enable 1 = control, 0 = check) and dx, dy, residual.\n\n"
            + _CONVENTION + "\n\nOutput CRS: the CRS parameter if set, else the file's #CRS line.")

    OPTIONS = (POINTS_TO_LAYER,)
    INPUT, OUTPUT, COUNT = "INPUT", "OUTPUT", "COUNT"

    def initAlgorithm(self, config=None):
        self.addParameter(QgsProcessingParameterFile(self.INPUT, tr("Georeferencer points file"),
                                                     extension="points"))
        self.add_options(POINTS_TO_LAYER)
        self.addParameter(QgsProcessingParameterVectorDestination(self.OUTPUT, tr("GCP layer (GeoPackage)"),
                                                                  QgsProcessing.TypeVectorPoint))
        self.addOutput(QgsProcessingOutputNumber(self.COUNT, tr("Number of points")))

    def processAlgorithm(self, parameters, context, feedback):
        points = self.parameterAsFile(parameters, self.INPUT, context)
        output = self.parameterAsOutputLayer(parameters, self.OUTPUT, context)
        if os.path.splitext(output)[1].lower() != ".gpkg":
            raise QgsProcessingException(f"OUTPUT must be a GeoPackage (.gpkg); got {output!r}")
        info = self.run_tool("points_to_layer", points, output, overwrite=True, feedback=feedback,
                             **self.option_arguments(parameters, context))
        feedback.pushInfo(f"{info['points']} points ({info['enabled']} enabled), CRS {info['crs']}, "
                          f"source coordinates: {info['source_convention']}")
        style_output(context, output, "gcps")
        return {self.OUTPUT: output, self.COUNT: info["points"]}


class LayerToPointsAlgorithm(FotogeoAlgorithm):
    ALG_ID = "layertopoints"
    DISPLAY = "GCP layer to .points file"
    SUMMARY = "GCP layer to Georeferencer points file"
    GROUP = ("gcp", "Ground control points")
    HELP = ("Writes a QGIS Georeferencer <i>.points</i> file from a point layer with the fields col, row "
            "(source pixel, GDAL corner convention) and optionally role (control = enabled, anything else "
            "= disabled), id (sort order) and dx, dy. A fotogeo <i>tie_points</i> layer from the register "
            "algorithm works directly (target_col, target_row). Map coordinates are the point positions; "
            "the #CRS line is the layer's CRS.\n\n" + _CONVENTION)

    OPTIONS = (LAYER_TO_POINTS,)
    INPUT, OUTPUT, COUNT = "INPUT", "OUTPUT", "COUNT"

    def initAlgorithm(self, config=None):
        self.addParameter(QgsProcessingParameterFeatureSource(self.INPUT, tr("GCP / tie point layer"),
                                                              [QgsProcessing.TypeVectorPoint]))
        self.add_options(LAYER_TO_POINTS)
        self.addParameter(QgsProcessingParameterFileDestination(self.OUTPUT, tr("Georeferencer points file"),
                                                                "Georeferencer points (*.points)"))
        self.addOutput(QgsProcessingOutputNumber(self.COUNT, tr("Number of points")))

    def processAlgorithm(self, parameters, context, feedback):
        # a GeoPackage/Shapefile layer is read where it is; anything else (memory layer, selection) is
        # first exported by Processing to a temporary GeoPackage
        path, layer = self.parameterAsCompatibleSourceLayerPathAndLayerName(
            parameters, self.INPUT, context, ["gpkg", "shp"], "gpkg", feedback)
        if not path:
            raise QgsProcessingException(self.invalidSourceError(parameters, self.INPUT))
        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        info = self.run_tool("layer_to_points", path, output, layer=layer or None, overwrite=True, feedback=feedback,
                             **self.option_arguments(parameters, context))
        feedback.pushInfo(f"{info['points']} points ({info['enabled']} enabled), CRS {info['crs']}")
        return {self.OUTPUT: output, self.COUNT: info["points"]}
