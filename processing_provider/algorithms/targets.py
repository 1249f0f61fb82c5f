"""``fotogeo:measuretargets`` — X-shaped targets measured to sub-pixel precision."""
from __future__ import annotations

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
)

from fotogeo.options import TARGETS as TARGET_OPTIONS

from .base import FotogeoAlgorithm, RasterFileParameter, tr
from .transfer import OUTPUT_FILTER, TABLE_FILTER, table_output


class MeasureTargetsAlgorithm(FotogeoAlgorithm):
    ALG_ID = "measuretargets"
    DISPLAY = "Measure X targets"
    SUMMARY = "Measure X-shaped targets"
    GROUP = ("matching", "Area-based matching")
    HELP = ("Measures X-shaped fiducial or calibration targets to sub-pixel near approximate positions: an "
            "edge method (thresholds from the target's and the background's grey levels) gives the approximate "
            "centre, then least-squares matching against a synthetic X template refines it (after "
            "Büyüksalih).\n\nPoint table (CSV or vector layer file): approximate positions in col, row (GDAL "
            "corner convention). Output (CSV or GeoPackage, by suffix): per target col, row, sigma_x, sigma_y "
            "(px), status, and the approximation. Polarity: bright targets on a dark background, dark on bright, "
            "or auto.")

    OPTIONS = (TARGET_OPTIONS,)
    IMAGE, POINTS, OUTPUT, TARGETS, MEASURED = "IMAGE", "POINTS", "OUTPUT", "TARGETS", "MEASURED"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFileParameter(self.IMAGE, tr("Image")))
        self.addParameter(QgsProcessingParameterFile(self.POINTS, tr("Approximate target positions"),
                                                     fileFilter=TABLE_FILTER))
        self.add_options(TARGET_OPTIONS)
        self.addParameter(QgsProcessingParameterFileDestination(self.OUTPUT, tr("Measured targets"), OUTPUT_FILTER))
        self.addOutput(QgsProcessingOutputNumber(self.TARGETS, tr("Targets")))
        self.addOutput(QgsProcessingOutputNumber(self.MEASURED, tr("Measured targets")))

    def processAlgorithm(self, parameters, context, feedback):
        output = table_output(self, parameters, self.OUTPUT, context)
        r = self.run_tool(
            "measure_targets", self.raster_path(parameters, self.IMAGE, context),
            self.parameterAsFile(parameters, self.POINTS, context), output, overwrite=True, feedback=feedback,
            **self.option_arguments(parameters, context))
        feedback.pushInfo(f"{r['measured']} of {r['targets']} targets measured")
        return {self.OUTPUT: output, self.TARGETS: r["targets"], self.MEASURED: r["measured"]}
