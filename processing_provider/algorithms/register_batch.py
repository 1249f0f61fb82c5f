"""``fotogeo:registerbatch`` — many scenes registered to one orthophoto on Dask (issue 15)."""
from __future__ import annotations

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterFolderDestination,
)

from fotogeo.options import REGISTER, REGISTER_BATCH, REGISTER_TERRAIN

from .base import REFERENCES, FotogeoAlgorithm, RasterFileParameter, RasterFilesParameter, tr


class RegisterBatchAlgorithm(FotogeoAlgorithm):
    ALG_ID = "registerbatch"
    DISPLAY = "Register batch (Dask)"
    SUMMARY = "Register many images to an orthophoto (batch, Dask)"
    GROUP = ("registration", "Registration")
    HELP = ("Registers every target image to one georeferenced reference (an orthophoto, a mosaic or a VRT) with "
            "the pipeline of <i>Register image to orthophoto</i> (Dihkan 2019), one Dask task per scene: on a local "
            "cluster (one worker per CPU, or <i>workers</i>) or on a running Dask cluster given by its scheduler "
            "address (tcp://host:8786; its workers must see the same paths). A scene that fails is recorded with "
            "its message and the batch goes on; with <i>resume</i> a second run skips the scenes already done.\n\n"
            "Outputs in the folder: &lt;scene&gt;.tif/.gpkg/.json per scene, and the manifest: manifest.csv and the "
            "layer <i>scenes</i> of manifest.gpkg (footprint in WGS 84, status, inliers, check RMSE, time, error). "
            "With a DEM each scene is registered terrain-aware.\n\n"
            f"References: {REFERENCES['dihkan']} {REFERENCES['surf']} {REFERENCES['ransac']}")

    OPTIONS = (REGISTER_BATCH, REGISTER_TERRAIN, REGISTER)
    REFERENCE, TARGETS, OUTDIR = "REFERENCE", "TARGETS", "OUTDIR"
    MANIFEST, OK, FAILED, SKIPPED = "MANIFEST", "OK", "FAILED", "SKIPPED"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFileParameter(self.REFERENCE, tr("Reference orthophoto (georeferenced)")))
        self.addParameter(RasterFilesParameter(self.TARGETS, tr("Target images"),
                                               QgsProcessing.TypeRaster))
        for table in self.OPTIONS:
            self.add_options(table)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTDIR, tr("Output folder")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.MANIFEST, tr("Scenes (manifest)")))
        for name, label in ((self.OK, "Scenes registered"), (self.FAILED, "Scenes failed"),
                            (self.SKIPPED, "Scenes done before (skipped)")):
            self.addOutput(QgsProcessingOutputNumber(name, tr(label)))

    def processAlgorithm(self, parameters, context, feedback):
        reference = self.raster_path(parameters, self.REFERENCE, context)
        targets = self.layer_paths(parameters, self.TARGETS, context)
        if not targets:
            raise QgsProcessingException("TARGETS: give at least one target image")
        outdir = self.parameterAsString(parameters, self.OUTDIR, context)
        result = self.run_tool("register_batch", reference, targets, outdir, feedback=feedback,
                               **self.option_arguments(parameters, context))
        feedback.pushInfo(f"{result['ok']} registered, {result['skipped']} done before, {result['failed']} failed")
        for row in result["rows"]:
            if row.get("status") == "failed":
                feedback.pushWarning(f"{row['scene']}: {row.get('error')}")
        return {self.OUTDIR: outdir, self.MANIFEST: f"{result['manifest_gpkg']}|layername=scenes",
                self.OK: int(result["ok"]), self.FAILED: int(result["failed"]), self.SKIPPED: int(result["skipped"])}
