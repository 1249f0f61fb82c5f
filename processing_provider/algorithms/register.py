"""``fotogeo:register`` — register an image to a georeferenced orthophoto (Dihkan 2019 pipeline)."""
from __future__ import annotations

from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterDestination,
)

from fotogeo.options import REGISTER, REGISTER_TERRAIN

from ..postprocess import LoadedRun, load_on_completion, style_output
from .base import REFERENCES, FotogeoAlgorithm, RasterFileParameter, tr, with_help
from .widgets import layer_roles


class RegisterAlgorithm(FotogeoAlgorithm):
    ALG_ID = "register"
    DISPLAY = "Register to orthophoto"
    SUMMARY = "Register image to orthophoto"
    GROUP = ("registration", "Registration")
    HELP = ("Registers a target image (an aerial frame, a satellite scene, any image of the area) to a "
            "georeferenced reference orthophoto, following Dihkan (2019): PCA band fusion with a robust "
            "contrast stretch; SURF keypoints (Hessian-determinant detector on an integral image, 64-D "
            "Haar-wavelet descriptors; Bay et al. 2008) or OpenCV SIFT; SSD matching with the "
            "nearest/second-nearest ratio test; RANSAC and a robust least-squares fit of a projective "
            "(homography), affine or similarity model; a share of the inliers held out as check points; "
            "resampling of every band onto the output grid (nearest neighbour by default). Advanced: "
            "contrast of the fused images (adaptive = histogram equalisation + CLAHE), least-squares "
            "refinement of the tie points (auto = lsm), the bands fused for matching, nodata "
            "overrides, "
            "keypoint budget, seed.\n\n"
            "Outputs: the registered GeoTIFF; a GeoPackage with the layers <i>tie_points</i> (field "
            "<i>role</i> = control/check, residuals dx, dy) and <i>error_vectors</i> (lines from the "
            "reference position to the model's, with dx, dy, length in metres; drawn scaled by "
            "<i>exaggeration</i>); a JSON report with RMSE at control and check points, timings and "
            "versions.\n\n"
            "<b>Local co-registration</b> corrects what the model leaves (residual relief, lens or scanner "
            "distortion) by a smooth displacement field measured on a grid of windows against the reference "
            "(as in the Co-register algorithm); the window shifts go to the layer <i>local_windows</i>. When feature "
            "matching fails on a georeferenced target (seasonal change, clouds), a grid of windows gives the tie "
            "points instead; the log says so.\n\n"
            "With a DEM the registration is terrain-aware: every tie point gets its DEM height, a 3-D "
            "ground-to-image model is fitted (auto keeps the simplest of collinearity — with the camera's "
            "interior orientation —, DLT and the rational function models whose check RMSE is within 5 % of the "
            "best) and the output is orthorectified with the DEM heights.\n\n"
            "Output CRS: empty = the reference's CRS when it is projected (the output then lies on the "
            "reference's pixel grid), else the UTM zone of the reference centre. Resolution 0 = the reference's "
            "pixel size. A single homography cannot model strong relief (give a DEM): expect metre-level residuals on "
            "mountainous frames.\n\n"
            f"References: {REFERENCES['dihkan']} {REFERENCES['surf']} {REFERENCES['ransac']}")

    OPTIONS = (REGISTER_TERRAIN, REGISTER)
    REFERENCE, TARGET, OUTPUT, VECTORS, REPORT = "REFERENCE", "TARGET", "OUTPUT", "VECTORS", "REPORT"
    FIELD = "FIELD"
    TIE_POINTS, ERROR_VECTORS, ERROR_GRID = "TIE_POINTS", "ERROR_VECTORS", "ERROR_GRID"
    INLIERS, CONTROL_RMSE, CHECK_RMSE, OUTPUT_CRS = "INLIERS", "CONTROL_RMSE_M", "CHECK_RMSE_M", "OUTPUT_CRS"

    def initAlgorithm(self, config=None):
        # the dialog starts Reference and Target on two different layers, neither a DEM, and DEM on a layer that
        # looks like one (widgets.OtherLayer)
        self.addParameter(RasterFileParameter(self.REFERENCE, tr("Reference orthophoto (georeferenced)")))
        self.addParameter(RasterFileParameter(self.TARGET, tr("Target image to register")))
        for table in self.OPTIONS:
            self.add_options(table)
        layer_roles(self, {self.REFERENCE: ("", "reference"), self.TARGET: (self.REFERENCE, "image"),
                           "DEM": ("", "dem")})
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, tr("Registered raster")))
        # optional: left empty they are written beside the raster (OUT.gpkg, OUT.json), as the CLI does
        self.addParameter(QgsProcessingParameterFileDestination(
            self.VECTORS, tr("Tie points and error vectors (GeoPackage) [beside the raster]"), "GeoPackage (*.gpkg)",
            optional=True, createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.REPORT, tr("Report (JSON) [beside the raster]"), "JSON (*.json)", optional=True,
            createByDefault=True))
        self.addParameter(with_help(QgsProcessingParameterFileDestination(
            self.FIELD, tr("Local displacement field (GeoTIFF) [beside the raster]"), "GeoTIFF (*.tif)", optional=True,
            createByDefault=False), "Written with the local co-registration only: the shift of every cell."))
        self.addOutput(QgsProcessingOutputVectorLayer(self.TIE_POINTS, tr("Tie points")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.ERROR_VECTORS, tr("Error vectors")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.ERROR_GRID, tr("Mean error per grid cell")))
        self.addOutput(QgsProcessingOutputNumber(self.INLIERS, tr("Inliers (control + check)")))
        self.addOutput(QgsProcessingOutputNumber(self.CONTROL_RMSE, tr("RMSE at control points (m)")))
        self.addOutput(QgsProcessingOutputNumber(self.CHECK_RMSE, tr("RMSE at check points (m)")))
        self.addOutput(QgsProcessingOutputString(self.OUTPUT_CRS, tr("Output CRS")))

    def processAlgorithm(self, parameters, context, feedback):
        reference = self.raster_path(parameters, self.REFERENCE, context)
        target = self.raster_path(parameters, self.TARGET, context)
        output = self.raster_output(parameters, self.OUTPUT, context)
        vectors = self.file_output_or_beside(parameters, self.VECTORS, context, output, ".gpkg")
        report = self.file_output_or_beside(parameters, self.REPORT, context, output, ".json")
        if not vectors.lower().endswith(".gpkg"):
            raise QgsProcessingException(f"VECTORS must be a GeoPackage file ending in .gpkg; got {vectors!r}")
        options = self.option_arguments(parameters, context)
        shown = ", ".join(f"{k}={v}" for k, v in options.items() if k in REGISTER and k != "dst_crs")
        feedback.pushInfo(f"options: {shown}, output CRS={'auto' if options['dst_crs'] == 'auto' else 'given'}")
        field = (self.file_output_or_beside(parameters, self.FIELD, context, output, "_field.tif")
                 if options.get("local") else None)
        result = self.run_tool("register", reference, target, output, vectors=vectors, report=report, field=field,
                               overwrite=True, feedback=feedback, **options)
        rep = result["report"]
        for line in rep["summary"]:  # the command line's lines (fotogeo.tools.register.report.summary_lines)
            if line.startswith("hint:"):  # advice, in the dialog's words (the DEM parameter's label)
                feedback.pushWarning(self.in_words(line))
            else:
                feedback.pushInfo(line)
        tie_uri = f"{vectors}|layername=tie_points"
        err_uri = f"{vectors}|layername=error_vectors"
        grid_uri = f"{vectors}|layername=error_grid"
        if context.willLoadLayerOnCompletion(output):
            # the user asked for the raster to be loaded: load the two vector layers, styled, above it
            stem = self.layer_stem(output, parameters, self.TARGET, context)
            run = LoadedRun()
            style_output(context, output, None, run, name=f"{stem} {tr('registered')}")
            load_on_completion(context, grid_uri, f"{stem} {tr('mean error per cell')}", self.ERROR_GRID,
                               "error_grid", run=run)
            # control points optional (unticked): the check points, fewer, stay readable over the image
            load_on_completion(context, err_uri, f"{stem} {tr('error vectors')}", self.ERROR_VECTORS,
                               "error_vectors", run=run, hidden=("control",))
            load_on_completion(context, tie_uri, f"{stem} {tr('tie points')}", self.TIE_POINTS, "tie_points", run=run,
                               hidden=("control",))
        nan = float("nan")
        return {self.OUTPUT: output, self.VECTORS: vectors, self.REPORT: report, self.FIELD: field,
                self.TIE_POINTS: tie_uri, self.ERROR_VECTORS: err_uri, self.ERROR_GRID: grid_uri,
                self.INLIERS: int(rep["inliers"]),
                self.CONTROL_RMSE: float(rep["control"].get("rmse_m", nan)),
                self.CHECK_RMSE: float(rep["check"].get("rmse_m", nan)),
                self.OUTPUT_CRS: rep["output_crs"]}
