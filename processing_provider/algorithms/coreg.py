"""``fotogeo:coreg`` — area-based co-registration of two georeferenced images of one area."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterDestination,
)

from fotogeo.options.coreg import COREG

from ..postprocess import LoadedRun, load_on_completion, style_output
from .widgets import layer_roles
from .base import FotogeoAlgorithm, RasterFileParameter, tr


class CoregAlgorithm(FotogeoAlgorithm):
    ALG_ID = "coreg"
    DISPLAY = "Co-register images (area-based, local shifts)"
    GROUP = ("registration", "Registration")
    HELP = ("Co-registers a target image to a reference image of the same area — another date, another sensor, "
            "another pixel size — where feature matching fails on seasonal change, clouds or radiometry. Both "
            "images must be georeferenced and agree to within a few target pixels (<i>Largest window shift</i>).\n\n"
            "A grid of windows over the overlap is matched by phase correlation and least-squares matching on "
            "gradient-orientation images (robust to seasonal and sensor radiometry and to contrast inversion); "
            "each window gets a reliability (peak ratio, correlation gain, LSM σ); outliers are rejected against "
            "a global affine model and against their neighbours; a smooth displacement field (the global model "
            "plus a thin-plate spline, stiffer with <i>Field smoothing</i>) is fitted through the reliable "
            "windows, in passes on the deformed target. Too few reliable windows are refused, never a wild "
            "field.\n\n"
            "Outputs: the target corrected on its own grid (every band); a GeoPackage layer <i>windows</i> "
            "(shift dx, dy in target pixels, reliability, status, residual to the field); the field as a 2-band "
            "raster (dx, dy in target pixels); a JSON report with the shifts before and after (RMS, CE90).\n\n"
            "References: Scheffler et al. (2017) AROSICS; Ackermann (1984) least-squares matching; "
            "Scarano (2002) iterative window deformation.")

    OPTIONS = (COREG,)
    REFERENCE, TARGET, OUTPUT, SHIFTS, FIELD, REPORT = "REFERENCE", "TARGET", "OUTPUT", "SHIFTS", "FIELD", "REPORT"
    WINDOWS, RELIABLE, RMS_BEFORE, RMS_AFTER = "WINDOWS", "RELIABLE", "MEDIAN_SHIFT_BEFORE_PX", "RMS_AFTER_PX"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFileParameter(self.REFERENCE, tr("Reference image (georeferenced)")))
        self.addParameter(RasterFileParameter(self.TARGET, tr("Target image to correct (georeferenced)")))
        self.add_options(COREG)
        layer_roles(self, {self.REFERENCE: ("", "reference"), self.TARGET: (self.REFERENCE, "image")})  # two layers, no DEM
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, tr("Corrected target")))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.SHIFTS, tr("Window shifts (GeoPackage) [beside the raster]"), "GeoPackage (*.gpkg)", optional=True,
            createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.FIELD, tr("Displacement field (GeoTIFF) [beside the raster]"), "GeoTIFF (*.tif)", optional=True,
            createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.REPORT, tr("Report (JSON) [beside the raster]"), "JSON (*.json)", optional=True,
            createByDefault=True))
        self.addOutput(QgsProcessingOutputVectorLayer(self.WINDOWS, tr("Window shifts")))
        self.addOutput(QgsProcessingOutputNumber(self.RELIABLE, tr("Reliable windows")))
        self.addOutput(QgsProcessingOutputNumber(self.RMS_BEFORE, tr("Median window shift before (target px)")))
        self.addOutput(QgsProcessingOutputNumber(self.RMS_AFTER, tr("RMS left by the field (target px)")))

    def processAlgorithm(self, parameters, context, feedback):
        reference = self.raster_path(parameters, self.REFERENCE, context)
        target = self.raster_path(parameters, self.TARGET, context)
        output = self.raster_output(parameters, self.OUTPUT, context)
        shifts = self.file_output_or_beside(parameters, self.SHIFTS, context, output, ".gpkg")
        field = self.file_output_or_beside(parameters, self.FIELD, context, output, "_field.tif")
        report = self.file_output_or_beside(parameters, self.REPORT, context, output, ".json")
        if not shifts.lower().endswith(".gpkg"):
            raise QgsProcessingException(f"Window shifts must be a GeoPackage file ending in .gpkg; got {shifts!r}")
        rep = self.run_tool("coregister", reference, target, output, shifts=shifts, field=field, report=report,
                            overwrite=True, feedback=feedback, **self.option_arguments(parameters, context))
        for line in rep["summary"]:
            feedback.pushInfo(line)
        uri = f"{shifts}|layername=windows"
        if context.willLoadLayerOnCompletion(output):
            stem = os.path.splitext(os.path.basename(target))[0]  # the layers named after the image corrected
            run = LoadedRun()
            style_output(context, output, None, run, name=f"{stem} {tr('co-registered')}")
            load_on_completion(context, uri, f"{stem} {tr('window shifts')}", self.WINDOWS, "coreg_windows", run=run)
        nan = float("nan")
        return {self.OUTPUT: output, self.SHIFTS: shifts, self.FIELD: field, self.REPORT: report, self.WINDOWS: uri,
                self.RELIABLE: int(rep["windows"]["reliable"]),
                self.RMS_BEFORE: float(rep["before"].get("median", nan)),
                self.RMS_AFTER: float(rep["after"].get("rms", nan))}
