"""``fotogeo:comparemodels`` — orientation models compared over control-point counts and spreads."""
from __future__ import annotations

from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterString,
)

from .base import tr
from .orient import GCP_HELP, MODELS, REFERENCE_004, SPREADS, _GcpAlgorithm


class CompareModelsAlgorithm(_GcpAlgorithm):
    ALG_ID = "comparemodels"
    DISPLAY = "Compare orientation models on GCPs"
    HELP = ("Table 1 of the source paper for your GCPs: every chosen model × number of control points × spread "
            "(homogeneous = stratified over the image; heterogeneous = clustered around two centres), over "
            "seeded trials. All GCPs are pooled; in each trial the points not chosen as control points are the "
            "check points. Reported per row: median RMS x / y at control and check points, RMS xy and maximum at "
            "check points (pixels), and why a model could not be fitted. Writes a CSV table (and optionally "
            "Markdown) and prints the table in the log.\n\n" + GCP_HELP + "\n\nReference: " + REFERENCE_004)

    MODELS_PARAM, COUNTS, SPREADS_PARAM, TRIALS, SEED = "MODELS", "COUNTS", "SPREADS", "TRIALS", "SEED"
    TABLE, MARKDOWN, ROWS = "TABLE", "MARKDOWN", "ROWS"

    def initAlgorithm(self, config=None):
        self.add_gcp_parameters()
        self.addParameter(QgsProcessingParameterEnum(self.MODELS_PARAM, tr("Models (none = all that the GCPs allow)"),
                                                     options=list(MODELS), allowMultiple=True, optional=True))
        self.addParameter(QgsProcessingParameterString(self.COUNTS, tr("Control-point counts (comma-separated)"),
                                                       defaultValue="40,20,15,10,6"))
        self.addParameter(QgsProcessingParameterEnum(self.SPREADS_PARAM, tr("Spreads"), options=list(SPREADS),
                                                     allowMultiple=True, defaultValue=[0, 1]))
        self.addParameter(QgsProcessingParameterNumber(self.TRIALS, tr("Seeded trials per cell (median reported)"),
                                                       QgsProcessingParameterNumber.Integer, defaultValue=5,
                                                       minValue=1))
        self.addParameter(QgsProcessingParameterNumber(self.SEED, tr("Random seed"),
                                                       QgsProcessingParameterNumber.Integer, defaultValue=0,
                                                       minValue=0))
        self.addParameter(QgsProcessingParameterFileDestination(self.TABLE, tr("Comparison table (CSV)"),
                                                                "CSV (*.csv)", optional=True, createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(self.MARKDOWN, tr("Comparison table (Markdown)"),
                                                                "Markdown (*.md)", optional=True,
                                                                createByDefault=False))
        self.addOutput(QgsProcessingOutputNumber(self.ROWS, tr("Table rows")))

    def processAlgorithm(self, parameters, context, feedback):
        compare_models = self.tool("tools.compare", "compare_models")
        markdown_table = self.tool("tools.compare", "markdown_table")
        text = self.parameterAsString(parameters, self.COUNTS, context)
        try:
            counts = tuple(int(c) for c in text.replace(" ", "").split(",") if c)
        except ValueError:
            raise QgsProcessingException(f"COUNTS must be whole numbers separated by commas, e.g. 40,20,10; "
                                         f"got {text!r}") from None
        if not counts or min(counts) < 1:
            raise QgsProcessingException(f"COUNTS needs at least one positive number of control points; got {text!r}")
        models = [MODELS[i] for i in self.parameterAsEnums(parameters, self.MODELS_PARAM, context)] or None
        spreads = tuple(SPREADS[i] for i in self.parameterAsEnums(parameters, self.SPREADS_PARAM, context))
        if not spreads:
            raise QgsProcessingException("SPREADS: choose at least one of homogeneous, heterogeneous")
        table = self.parameterAsFileOutput(parameters, self.TABLE, context) or None
        markdown = self.parameterAsFileOutput(parameters, self.MARKDOWN, context) or None
        image = self.raster_path(parameters, self.IMAGE, context)
        gcps, gcp_layer = self.gcp_source(parameters, context, feedback)
        rows = self.run_tool(compare_models, image, gcps, models=models, counts=counts, spreads=spreads,
                             trials=self.parameterAsInt(parameters, self.TRIALS, context),
                             seed=self.parameterAsInt(parameters, self.SEED, context), table=table,
                             markdown=markdown, overwrite=True, feedback=feedback,
                             **self.gcp_arguments(parameters, context, gcp_layer))
        feedback.pushInfo(markdown_table(rows))
        return {self.TABLE: table, self.MARKDOWN: markdown, self.ROWS: len(rows)}
