"""``fotogeo:comparemodels`` — orientation models compared over control-point counts and spreads."""
from __future__ import annotations

from qgis.core import QgsProcessingOutputNumber, QgsProcessingParameterFileDestination, QgsProcessingUtils

from fotogeo.options import COMPARE, GCP

from ..postprocess import load_on_completion
from .base import tr
from .orient import GCP_HELP, REFERENCE_ORIENTATION, _GcpAlgorithm


class CompareModelsAlgorithm(_GcpAlgorithm):
    ALG_ID = "comparemodels"
    DISPLAY = "Compare models"
    SUMMARY = "Compare orientation models on GCPs"
    HELP = ("Table 1 of Öztürk, Karşlı & Dihkan for your GCPs: every chosen model × number of control points × spread "
            "(homogeneous = stratified over the image; heterogeneous = clustered around two centres), over "
            "seeded trials. All GCPs are pooled; in each trial the points not chosen as control points are the "
            "check points. Reported per row: median RMS x / y at control and check points, RMS xy and maximum at "
            "check points (pixels), and why a model could not be fitted. Writes a CSV table (and optionally "
            "Markdown); the CSV opens in QGIS as a table layer (Open Attribute Table).\n\n" + GCP_HELP + "\n\nReference: " + REFERENCE_ORIENTATION)

    OPTIONS = (GCP, COMPARE)
    TABLE, MARKDOWN, ROWS = "TABLE", "MARKDOWN", "ROWS"

    def initAlgorithm(self, config=None):
        self.add_gcp_parameters()
        self.add_options(COMPARE)
        self.addParameter(QgsProcessingParameterFileDestination(self.TABLE, tr("Comparison table (CSV)"),
                                                                "CSV (*.csv)", optional=True, createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(self.MARKDOWN, tr("Comparison table (Markdown)"),
                                                                "Markdown (*.md)", optional=True,
                                                                createByDefault=False))
        self.addOutput(QgsProcessingOutputNumber(self.ROWS, tr("Table rows")))

    def processAlgorithm(self, parameters, context, feedback):
        options = self.option_arguments(parameters, context, COMPARE)
        table = self.parameterAsFileOutput(parameters, self.TABLE, context) or \
            QgsProcessingUtils.generateTempFilename("comparemodels.csv")
        markdown = self.parameterAsFileOutput(parameters, self.MARKDOWN, context) or None
        image = self.raster_path(parameters, self.IMAGE, context)
        gcps, gcp_layer = self.gcp_source(parameters, context, feedback)
        rows = self.run_tool("compare_models", image, gcps, table=table, markdown=markdown, overwrite=True,
                             feedback=feedback, **options, **self.gcp_arguments(parameters, context, gcp_layer))
        fitted = [r for r in rows if r.get("check_rms_xy_px") is not None]
        if fitted:
            best = min(fitted, key=lambda r: r["check_rms_xy_px"])
            feedback.pushInfo(f"{len(rows)} rows; lowest check RMS xy: {best['model']} ({best['spread']}, "
                              f"{best['n_control']} control points) {best['check_rms_xy_px']:.3f} px")
        if context.project() is not None:  # the table opens in QGIS (Open Attribute Table), not as text in the log
            load_on_completion(context, f"{table}|option:AUTODETECT_TYPE=YES", tr("Orientation models compared"),
                               self.TABLE, None)
        return {self.TABLE: table, self.MARKDOWN: markdown, self.ROWS: len(rows)}
