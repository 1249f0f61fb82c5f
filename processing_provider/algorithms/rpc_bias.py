"""``fotogeo:rpcbias`` — a vendor RPC corrected with GCPs; the copy carries the corrected RPC."""
from __future__ import annotations

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterDestination,
)

from fotogeo.options import RPC_BIAS

from .base import tr
from .orient import _GcpAlgorithm


class RpcBiasAlgorithm(_GcpAlgorithm):
    ALG_ID = "rpcbias"
    DISPLAY = "Correct RPC (bias)"
    SUMMARY = "Correct a vendor RPC with GCPs (bias compensation)"
    HELP = ("Corrects the RPC (rational polynomial coefficients) of a satellite image with GCPs by an image-space "
            "shift (one GCP or more) or affinity (three or more), after Grodecki & Dial (2003), and writes a "
            "GeoTIFF copy of the image carrying the corrected RPC as GDAL metadata: QGIS and gdalwarp -rpc "
            "(with a DEM) then orthorectify it onto the GCPs. GCPs outside the image are skipped with a warning. "
            "Heights are taken as given: RPC heights are ellipsoidal (WGS 84), so give ellipsoidal GCP heights "
            "or a DEM in that datum.\n\nThe report (JSON) gives the correction, the residuals before and after "
            "at control and check points (pixels) and leave-one-out residuals.")

    OPTIONS = (RPC_BIAS,)
    OUTPUT, REPORT, RMS_BEFORE, RMS_AFTER = "OUTPUT", "REPORT", "RMS_BEFORE_PX", "RMS_AFTER_PX"

    def initAlgorithm(self, config=None):
        self.add_gcp_parameters("Image with a vendor RPC", RPC_BIAS)
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, tr("Image with the corrected RPC")))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.REPORT, tr("Report (JSON) [beside the image]"), "JSON (*.json)", optional=True,
            createByDefault=False))
        self.addOutput(QgsProcessingOutputNumber(self.RMS_BEFORE, tr("RMS at control points before (px)")))
        self.addOutput(QgsProcessingOutputNumber(self.RMS_AFTER, tr("RMS at control points after (px)")))

    def processAlgorithm(self, parameters, context, feedback):
        image = self.raster_path(parameters, self.IMAGE, context)
        output = self.raster_output(parameters, self.OUTPUT, context)
        report = self.parameterAsFileOutput(parameters, self.REPORT, context) or None
        gcps, layer = self.gcp_source(parameters, context, feedback)
        args = {**self.option_arguments(parameters, context, RPC_BIAS), "layer": layer}
        rep = self.run_tool("rpc_bias", image, gcps, output, report=report, overwrite=True, feedback=feedback,
                            **args)
        c = rep["correction"]
        feedback.pushInfo(f"{rep['method']} correction {c['shift_px'][0]:+.3f} {c['shift_px'][1]:+.3f} px (col, row); "
                          f"RMS at control points {c['rms_before_px']:.3f} -> {c['rms_after_px']:.3f} px")
        return {self.OUTPUT: output, self.REPORT: report or rep.get("report"),
                self.RMS_BEFORE: float(c["rms_before_px"]), self.RMS_AFTER: float(c["rms_after_px"])}
