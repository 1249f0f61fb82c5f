"""``fotogeo:measuretargets`` — X-shaped targets measured to sub-pixel precision."""
from __future__ import annotations

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
)

from .base import FotogeoAlgorithm, tr
from .transfer import OUTPUT_FILTER, TABLE_FILTER, _advanced, _table_output


POLARITIES = ("auto", "bright", "dark")


class MeasureTargetsAlgorithm(FotogeoAlgorithm):
    ALG_ID = "measuretargets"
    DISPLAY = "Measure X-shaped targets"
    GROUP = ("matching", "Area-based matching")
    REQUIRES = ("numpy", "rasterio", "pyproj", "shapely", "geopandas", "pyogrio", "cv2")
    HELP = ("Measures X-shaped fiducial or calibration targets to sub-pixel near approximate positions: an "
            "edge method (thresholds from the target's and the background's grey levels) gives the approximate "
            "centre, then least-squares matching against a synthetic X template refines it (fotogeo's source "
            "paper 000).\n\nPoint table (CSV or vector layer file): approximate positions in col, row (GDAL "
            "corner convention). Output (CSV or GeoPackage, by suffix): per target col, row, sigma_x, sigma_y "
            "(px), status, and the approximation. Polarity: bright targets on a dark background, dark on bright, "
            "or auto.")

    IMAGE, POINTS, HALF_WINDOW, POLARITY, OUTPUT = "IMAGE", "POINTS", "HALF_WINDOW", "POLARITY", "OUTPUT"
    TARGETS, MEASURED = "TARGETS", "MEASURED"
    FIELDS = (("COL_FIELD", "col"), ("ROW_FIELD", "row"), ("ID_FIELD", "id"))

    def initAlgorithm(self, config=None):
        self.addParameter(QgsProcessingParameterRasterLayer(self.IMAGE, tr("Image")))
        self.addParameter(QgsProcessingParameterFile(self.POINTS, tr("Approximate target positions"),
                                                     fileFilter=TABLE_FILTER))
        self.addParameter(QgsProcessingParameterNumber(self.HALF_WINDOW, tr("Half window (px)"),
                                                       QgsProcessingParameterNumber.Integer, defaultValue=12,
                                                       minValue=4))
        self.addParameter(QgsProcessingParameterEnum(self.POLARITY, tr("Target polarity"), options=list(POLARITIES),
                                                     defaultValue=0))
        for name, default in self.FIELDS:
            _advanced(self, QgsProcessingParameterString(name, tr(f"Field: {default}"), defaultValue=default))
        self.addParameter(QgsProcessingParameterFileDestination(self.OUTPUT, tr("Measured targets"), OUTPUT_FILTER))
        self.addOutput(QgsProcessingOutputNumber(self.TARGETS, tr("Targets")))
        self.addOutput(QgsProcessingOutputNumber(self.MEASURED, tr("Measured targets")))

    def processAlgorithm(self, parameters, context, feedback):
        measure_targets = self.tool("tools.targets", "measure_targets")
        f = {name: self.parameterAsString(parameters, name, context) or default for name, default in self.FIELDS}
        output = _table_output(self, parameters, self.OUTPUT, context)
        r = self.run_tool(
            measure_targets, self.raster_path(parameters, self.IMAGE, context),
            self.parameterAsFile(parameters, self.POINTS, context), output,
            half_window=self.parameterAsInt(parameters, self.HALF_WINDOW, context),
            polarity=self.enum_value(parameters, self.POLARITY, context, POLARITIES),
            approx_fields=(f["COL_FIELD"], f["ROW_FIELD"]), id_field=f["ID_FIELD"], overwrite=True,
            feedback=feedback)
        feedback.pushInfo(f"{r['measured']} of {r['targets']} targets measured")
        return {self.OUTPUT: output, self.TARGETS: r["targets"], self.MEASURED: r["measured"]}
