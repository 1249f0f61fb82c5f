"""``fotogeo:register`` — register an image to a georeferenced orthophoto (Dihkan 2019 pipeline)."""
from __future__ import annotations

import os

from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterRasterLayer,
)

from ..postprocess import load_on_completion
from .base import REFERENCES, FotogeoAlgorithm, tr

# Mirrors of fotogeo's option lists (fotogeo is imported lazily; tests check they agree).
DETECTORS = ("surf", "sift")
PLANAR = ("projective", "affine", "similarity")
TERRAIN = ("auto", "dlt", "rfm", "rfm-common", "rfm-poly", "collinearity")
#: index 0 = the tool's default (model None): projective without a DEM, auto with one
MODELS = ("default",) + PLANAR + TERRAIN
RESAMPLINGS = ("nearest", "bilinear", "cubic")
CONTRASTS = ("adaptive", "equalize", "linear")
REFINES = ("none", "lsm")


class RegisterAlgorithm(FotogeoAlgorithm):
    ALG_ID = "register"
    DISPLAY = "Register image to orthophoto"
    GROUP = ("registration", "Registration")
    HELP = ("Registers a target image (an aerial frame, a satellite scene, any image of the area) to a "
            "georeferenced reference orthophoto, following Dihkan (2019): PCA band fusion with a robust "
            "contrast stretch; SURF keypoints (Hessian-determinant detector on an integral image, 64-D "
            "Haar-wavelet descriptors; Bay et al. 2008) or OpenCV SIFT; SSD matching with the "
            "nearest/second-nearest ratio test; RANSAC and a robust least-squares fit of a projective "
            "(homography), affine or similarity model; a share of the inliers held out as check points; "
            "resampling of every band onto the output grid (nearest neighbour by default). Advanced: "
            "contrast of the fused images (adaptive = histogram equalisation + CLAHE), least-squares "
            "refinement of the tie points (lsm), nodata overrides, "
            "keypoint budget, seed.\n\n"
            "Outputs: the registered GeoTIFF; a GeoPackage with the layers <i>tie_points</i> (field "
            "<i>role</i> = control/check, residuals dx, dy) and <i>error_vectors</i> (lines from the "
            "reference position to the model's, with dx, dy, length in metres; drawn scaled by "
            "<i>exaggeration</i>); a JSON report with RMSE at control and check points, timings and "
            "versions.\n\n"
            "With a DEM the registration is terrain-aware: every tie point gets its DEM height, a 3-D "
            "ground-to-image model is fitted (auto keeps the simplest of collinearity — with the camera's "
            "interior orientation —, DLT and the rational function models whose check RMSE is within 5 % of the "
            "best) and the output is orthorectified with the DEM heights.\n\n"
            "Output CRS: empty = the UTM zone of the reference centre. Resolution 0 = the reference's "
            "pixel size. A single homography cannot model strong relief (give a DEM): expect metre-level residuals on "
            "mountainous frames.\n\n"
            f"References: {REFERENCES['dihkan']} {REFERENCES['surf']} {REFERENCES['ransac']}")

    REFERENCE, TARGET, DETECTOR, MODEL, RESAMPLING = "REFERENCE", "TARGET", "DETECTOR", "MODEL", "RESAMPLING"
    CRS, RESOLUTION, RATIO, MUTUAL, RANSAC_THRESHOLD = "CRS", "RESOLUTION", "RATIO", "MUTUAL", "RANSAC_THRESHOLD"
    CHECK_FRACTION, MAX_KEYPOINTS, HESSIAN_THRESHOLD = "CHECK_FRACTION", "MAX_KEYPOINTS", "HESSIAN_THRESHOLD"
    SEED, MAX_MATCH_PIXELS, EXAGGERATION = "SEED", "MAX_MATCH_PIXELS", "EXAGGERATION"
    CONTRAST, REFERENCE_NODATA, TARGET_NODATA = "CONTRAST", "REFERENCE_NODATA", "TARGET_NODATA"
    REFINE, DEM, CAMERA = "REFINE", "DEM", "CAMERA"
    OUTPUT, VECTORS, REPORT = "OUTPUT", "VECTORS", "REPORT"
    TIE_POINTS, ERROR_VECTORS = "TIE_POINTS", "ERROR_VECTORS"
    INLIERS, CONTROL_RMSE, CHECK_RMSE, OUTPUT_CRS = "INLIERS", "CONTROL_RMSE_M", "CHECK_RMSE_M", "OUTPUT_CRS"

    def initAlgorithm(self, config=None):
        Num = QgsProcessingParameterNumber
        advanced = []
        self.addParameter(QgsProcessingParameterRasterLayer(self.REFERENCE, tr("Reference orthophoto (georeferenced)")))
        self.addParameter(QgsProcessingParameterRasterLayer(self.TARGET, tr("Target image to register")))
        self.addParameter(QgsProcessingParameterEnum(self.DETECTOR, tr("Keypoint detector"), options=list(DETECTORS),
                                                     defaultValue=0))
        self.addParameter(QgsProcessingParameterEnum(
            self.MODEL, tr("Geometric model (default: projective; with a DEM: auto)"), options=list(MODELS),
            defaultValue=0))
        self.addParameter(QgsProcessingParameterRasterLayer(
            self.DEM, tr("DEM (terrain-aware registration: 3-D model, orthorectified output)"), optional=True))
        self.addParameter(QgsProcessingParameterFile(
            self.CAMERA, tr("Interior orientation YAML of the target camera (model collinearity)"), optional=True,
            fileFilter="YAML (*.yaml *.yml)"))
        self.addParameter(QgsProcessingParameterEnum(self.RESAMPLING, tr("Resampling"), options=list(RESAMPLINGS),
                                                     defaultValue=0))
        self.addParameter(QgsProcessingParameterCrs(self.CRS, tr("Output CRS (empty = UTM zone of the reference)"),
                                                    optional=True))
        self.addParameter(Num(self.RESOLUTION, tr("Output pixel size in output CRS units (0 = the reference's)"),
                              Num.Double, defaultValue=0.0, minValue=0.0))
        self.addParameter(Num(self.RATIO, tr("Ratio test (nearest / second-nearest distance)"), Num.Double,
                              defaultValue=0.8, minValue=0.05, maxValue=1.0))
        self.addParameter(Num(self.RANSAC_THRESHOLD, tr("RANSAC threshold (reference pixels)"), Num.Double,
                              defaultValue=3.0, minValue=0.01))
        self.addParameter(Num(self.CHECK_FRACTION, tr("Fraction of inliers held out as check points"), Num.Double,
                              defaultValue=0.3, minValue=0.0, maxValue=0.89))
        advanced += [
            QgsProcessingParameterBoolean(self.MUTUAL, tr("Keep only mutual nearest neighbours"), defaultValue=True),
            Num(self.MAX_KEYPOINTS, tr("Maximum keypoints per image"), Num.Integer, defaultValue=8000, minValue=10),
            Num(self.HESSIAN_THRESHOLD, tr("SURF Hessian threshold (0 = automatic)"), Num.Double,
                defaultValue=0.0, minValue=0.0),
            Num(self.MAX_MATCH_PIXELS, tr("Decimate images larger than this many pixels for matching"), Num.Integer,
                defaultValue=16_000_000, minValue=10_000),
            Num(self.SEED, tr("Random seed"), Num.Integer, defaultValue=0, minValue=0),
            Num(self.EXAGGERATION, tr("Error vector exaggeration (drawing scale)"), Num.Double,
                defaultValue=1.0, minValue=0.001),
            QgsProcessingParameterEnum(self.CONTRAST, tr("Contrast of the fused images for matching"),
                                       options=list(CONTRASTS), defaultValue=0),
            QgsProcessingParameterEnum(self.REFINE, tr("Refine tie points before the fit (lsm = least-squares "
                                                       "matching)"), options=list(REFINES), defaultValue=0),
            Num(self.REFERENCE_NODATA, tr("Reference nodata value (empty = the file's)"), Num.Double,
                defaultValue=None, optional=True),
            Num(self.TARGET_NODATA, tr("Target nodata value (empty = the file's)"), Num.Double,
                defaultValue=None, optional=True),
        ]
        for p in advanced:
            p.setFlags(p.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
            self.addParameter(p)
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, tr("Registered raster")))
        # optional: left empty they are written beside the raster (OUT.gpkg, OUT.json), as the CLI does
        self.addParameter(QgsProcessingParameterFileDestination(
            self.VECTORS, tr("Tie points and error vectors (GeoPackage) [beside the raster]"), "GeoPackage (*.gpkg)",
            optional=True, createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.REPORT, tr("Report (JSON) [beside the raster]"), "JSON (*.json)", optional=True,
            createByDefault=True))
        self.addOutput(QgsProcessingOutputVectorLayer(self.TIE_POINTS, tr("Tie points")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.ERROR_VECTORS, tr("Error vectors")))
        self.addOutput(QgsProcessingOutputNumber(self.INLIERS, tr("Inliers (control + check)")))
        self.addOutput(QgsProcessingOutputNumber(self.CONTROL_RMSE, tr("RMSE at control points (m)")))
        self.addOutput(QgsProcessingOutputNumber(self.CHECK_RMSE, tr("RMSE at check points (m)")))
        self.addOutput(QgsProcessingOutputString(self.OUTPUT_CRS, tr("Output CRS")))

    @staticmethod
    def crs_spec(crs: QgsCoordinateReferenceSystem) -> str:
        """'auto' for an empty CRS parameter, else an authority code or WKT pyproj understands."""
        if not crs.isValid():
            return "auto"
        if crs.authid().upper().startswith(("EPSG:", "ESRI:", "IAU")):
            return crs.authid()
        return crs.toWkt(QgsCoordinateReferenceSystem.WKT_PREFERRED)

    def processAlgorithm(self, parameters, context, feedback):
        register = self.tool("tools.register", "register")
        reference = self.raster_path(parameters, self.REFERENCE, context)
        target = self.raster_path(parameters, self.TARGET, context)
        output = self.raster_output(parameters, self.OUTPUT, context)
        vectors = self.parameterAsFileOutput(parameters, self.VECTORS, context) or os.path.splitext(output)[0] + ".gpkg"
        report = self.parameterAsFileOutput(parameters, self.REPORT, context) or os.path.splitext(output)[0] + ".json"
        if not vectors.lower().endswith(".gpkg"):
            raise QgsProcessingException(f"VECTORS must be a GeoPackage file ending in .gpkg; got {vectors!r}")
        hessian = self.parameterAsDouble(parameters, self.HESSIAN_THRESHOLD, context)
        resolution = self.parameterAsDouble(parameters, self.RESOLUTION, context)
        options = dict(
            detector=self.enum_value(parameters, self.DETECTOR, context, DETECTORS),
            model=MODELS[self.parameterAsEnum(parameters, self.MODEL, context)] if
            self.parameterAsEnum(parameters, self.MODEL, context) else None,
            resampling=self.enum_value(parameters, self.RESAMPLING, context, RESAMPLINGS),
            dst_crs=self.crs_spec(self.parameterAsCrs(parameters, self.CRS, context)),
            resolution=resolution if resolution > 0 else None,
            ratio=self.parameterAsDouble(parameters, self.RATIO, context),
            mutual=self.parameterAsBoolean(parameters, self.MUTUAL, context),
            ransac_threshold=self.parameterAsDouble(parameters, self.RANSAC_THRESHOLD, context),
            check_fraction=self.parameterAsDouble(parameters, self.CHECK_FRACTION, context),
            max_keypoints=self.parameterAsInt(parameters, self.MAX_KEYPOINTS, context),
            hessian_threshold=hessian if hessian > 0 else None,
            max_match_pixels=self.parameterAsInt(parameters, self.MAX_MATCH_PIXELS, context),
            seed=self.parameterAsInt(parameters, self.SEED, context),
            exaggeration=self.parameterAsDouble(parameters, self.EXAGGERATION, context),
            contrast=self.enum_value(parameters, self.CONTRAST, context, CONTRASTS),
            refine=self.enum_value(parameters, self.REFINE, context, REFINES),
            reference_nodata=self.optional_double(parameters, self.REFERENCE_NODATA, context),
            target_nodata=self.optional_double(parameters, self.TARGET_NODATA, context),
        )
        feedback.pushInfo("options: " + ", ".join(f"{k}={v}" for k, v in options.items() if k != "dst_crs")
                          + f", output CRS={'auto' if options['dst_crs'] == 'auto' else 'given'}")
        dem = self.raster_path(parameters, self.DEM, context) if parameters.get(self.DEM) else None
        camera = self.parameterAsFile(parameters, self.CAMERA, context) or None
        result = self.run_tool(register, reference, target, output, vectors=vectors, report=report, dem=dem,
                               camera=camera, overwrite=True, feedback=feedback, **options)
        rep = result.report
        feedback.pushInfo(f"keypoints target/reference {rep['keypoints']['target']}/{rep['keypoints']['reference']}, "
                          f"matches {rep['matches']}, inliers {rep['inliers']}")
        for role in ("control", "check"):
            s = rep[role]
            if s.get("n"):
                feedback.pushInfo(f"{role}: n={s['n']}, RMSE {s['rmse_m']:.3f} m ({s['rmse_px']:.2f} reference px)")
        tie_uri = f"{vectors}|layername=tie_points"
        err_uri = f"{vectors}|layername=error_vectors"
        if context.willLoadLayerOnCompletion(output):
            # the user asked for the raster to be loaded: load the two vector layers, styled, with it
            load_on_completion(context, err_uri, tr("Error vectors"), self.ERROR_VECTORS, "error_vectors")
            load_on_completion(context, tie_uri, tr("Tie points"), self.TIE_POINTS, "tie_points")
        nan = float("nan")
        return {self.OUTPUT: output, self.VECTORS: vectors, self.REPORT: report,
                self.TIE_POINTS: tie_uri, self.ERROR_VECTORS: err_uri,
                self.INLIERS: int(rep["inliers"]),
                self.CONTROL_RMSE: float(rep["control"].get("rmse_m", nan)),
                self.CHECK_RMSE: float(rep["check"].get("rmse_m", nan)),
                self.OUTPUT_CRS: rep["output_crs"]}
