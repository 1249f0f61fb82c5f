"""``fotogeo:comparemodels`` — orientation models compared over control-point counts and spreads."""
from __future__ import annotations

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterFolderDestination,
    QgsProcessingUtils,
)

from fotogeo.options import COMPARE, GCP

from ..postprocess import load_on_completion
from .base import tr
from .orient import GCP_HELP, REFERENCE_ORIENTATION, _GcpAlgorithm


class CompareModelsAlgorithm(_GcpAlgorithm):
    ALG_ID = "comparemodels"
    DISPLAY = "Compare models"
    SUMMARY = "Compare orientation models on GCPs"
    HELP = ("Table 1 of Öztürk, Karşlı & Dihkan for your GCPs: every chosen model × control/check set × layout. "
            "Sets are random (per count N — the rest are check points — or N/M, a pool of N+M points; per spread: "
            "homogeneous = stratified over the image, heterogeneous = clustered around two centres; over seeded "
            "trials) or fixed: the GCP file's role column and every role_<label> column. A count equal to the "
            "number of points gives the all-control row (the paper's 40/0, 60/0). Counts per model: "
            "dlt=6,10,15;rfm=40,50,60 (empty: the paper's 40…6 for classical models, 60…40 for RFMs). The "
            "paper's unregularised RFMs (rfm-plain, rfm-common-plain, rfm-poly-plain, rfm-plain-i2g) sit beside "
            "the regularised ones. Reported per row: mx, my at control (GCP) and check points (CP), min, median "
            "and max check error, in pixels or, with the scan pixel size, mm on the photo. Writes a CSV table, "
            "Markdown and HTML in the paper's layout, and error-vector plots per model and layout; the CSV opens "
            "in QGIS as a table layer (Open Attribute Table).\n\n" + GCP_HELP + "\n\nReference: " + REFERENCE_ORIENTATION)

    OPTIONS = (GCP, COMPARE)
    TABLE, MARKDOWN, HTML, PLOTS, ROWS = "TABLE", "MARKDOWN", "HTML", "PLOTS", "ROWS"

    def initAlgorithm(self, config=None):
        self.add_gcp_parameters()
        self.add_options(COMPARE)
        self.addParameter(QgsProcessingParameterFileDestination(self.TABLE, tr("Comparison table (CSV)"),
                                                                "CSV (*.csv)", optional=True, createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(self.MARKDOWN, tr("Comparison table (Markdown)"),
                                                                "Markdown (*.md)", optional=True,
                                                                createByDefault=False))
        self.addParameter(QgsProcessingParameterFileDestination(self.HTML, tr("Comparison table (HTML)"),
                                                                "HTML (*.html)", optional=True, createByDefault=False))
        self.addParameter(QgsProcessingParameterFolderDestination(self.PLOTS, tr("Error-vector plots (folder)"),
                                                                  optional=True, createByDefault=False))
        self.addOutput(QgsProcessingOutputNumber(self.ROWS, tr("Table rows")))

    def processAlgorithm(self, parameters, context, feedback):
        options = self.option_arguments(parameters, context, COMPARE)
        table = self.parameterAsFileOutput(parameters, self.TABLE, context) or \
            QgsProcessingUtils.generateTempFilename("comparemodels.csv")
        markdown = self.parameterAsFileOutput(parameters, self.MARKDOWN, context) or None
        html = self.parameterAsFileOutput(parameters, self.HTML, context) or None
        plots = self.parameterAsFileOutput(parameters, self.PLOTS, context) or None
        image = self.raster_path(parameters, self.IMAGE, context)
        gcps, gcp_layer = self.gcp_source(parameters, context, feedback)
        rows = self.run_tool("compare_models", image, gcps, table=table, markdown=markdown, html=html, plots=plots,
                             overwrite=True,
                             feedback=feedback, **options, **self.gcp_arguments(parameters, context, gcp_layer))
        from fotogeo.tools.orient.compare_rank import ranking  # standard library only
        feedback.pushInfo(f"{len(rows)} rows; {ranking(rows)[1]}")
        if context.project() is not None:  # the table opens in QGIS (Open Attribute Table), not as text in the log
            load_on_completion(context, f"{table}|option:AUTODETECT_TYPE=YES", tr("Orientation models compared"),
                               self.TABLE, None)
        return {self.TABLE: table, self.MARKDOWN: markdown, self.HTML: html, self.PLOTS: plots, self.ROWS: len(rows)}
