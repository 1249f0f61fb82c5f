"""``fotogeo:orient`` and ``fotogeo:comparemodels`` — orientation models fitted to GCPs."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorDestination,
)

from ..postprocess import load_on_completion, style_output
from .base import FotogeoAlgorithm, tr
from .register import RESAMPLINGS, RegisterAlgorithm

# Mirror of sorted(fotogeo.models.MODELS) (fotogeo is imported lazily; a test checks they agree).
MODELS = ("affine", "affine-height", "bilinear", "collinearity", "dlt", "poly1", "poly2", "poly3", "poly3d-1",
          "poly3d-2", "poly3d-3", "projective", "rfm", "rfm-common", "rfm-common-i2g", "rfm-i2g", "rfm-poly",
          "rfm-poly-i2g", "similarity")
SPREADS = ("homogeneous", "heterogeneous")
GCP_FILTER = "GCP files (*.gpkg *.points *.csv *.geojson *.shp);;All files (*.*)"
FIELDS = ("col", "row", "z", "role", "id")

REFERENCE_004 = ("Öztürk, Karşlı, Dihkan: orientation of aerial photographs from map GCPs with affine-with-height, "
                 "bilinear, projective, DLT and rational function models (fotogeo's source paper 004).")

GCP_HELP = ("GCPs: a point layer of the project, or a point layer file (GeoPackage, Shapefile, GeoJSON), with "
            "the image position in fields col, "
            "row (GDAL corner convention: 0,0 = top-left corner of the top-left pixel), optional z, role "
            "(control / check) and id; a CSV with map columns x, y (CRS parameter needed); or a QGIS "
            "Georeferencer .points file (enabled = control, disabled = check). The field names can be changed "
            "under Advanced. Heights for 3-D models: the z field, else the DEM, else the constant height.")


class _GcpAlgorithm(FotogeoAlgorithm):
    """Parameters shared by orient and comparemodels: the image, GCP source, heights, camera."""

    GROUP = ("orientation", "Orientation")
    IMAGE, GCPS, LAYER, CRS, DEM, HEIGHT, CAMERA = "IMAGE", "GCPS", "LAYER", "CRS", "DEM", "HEIGHT", "CAMERA"
    GCP_LAYER_IN = "GCP_LAYER_INPUT"

    def add_gcp_parameters(self):
        self.addParameter(QgsProcessingParameterRasterLayer(self.IMAGE, tr("Image")))
        self.addParameter(QgsProcessingParameterFile(self.GCPS, tr("GCP file (layer, CSV or .points)"),
                                                     fileFilter=GCP_FILTER, optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            self.GCP_LAYER_IN, tr("… or a GCP point layer of the project"), [QgsProcessing.TypeVectorPoint],
            optional=True))
        self.addParameter(QgsProcessingParameterString(self.LAYER, tr("Layer of a multi-layer GCP file"),
                                                       optional=True))
        self.addParameter(QgsProcessingParameterCrs(
            self.CRS, tr("Map CRS of the GCPs (for CSV, .points without #CRS, layers without CRS)"), optional=True))
        self.addParameter(QgsProcessingParameterRasterLayer(self.DEM, tr("DEM for GCPs without height"),
                                                            optional=True))
        self.addParameter(QgsProcessingParameterNumber(self.HEIGHT, tr("Constant height for GCPs without height"),
                                                       QgsProcessingParameterNumber.Double, optional=True))
        self.addParameter(QgsProcessingParameterFile(self.CAMERA, tr("Interior orientation YAML (collinearity)"),
                                                     optional=True, fileFilter="YAML (*.yaml *.yml)"))
        for f in FIELDS:
            p = QgsProcessingParameterString(f"{f.upper()}_FIELD", tr(f"Field: {f}"), defaultValue=f)
            p.setFlags(p.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
            self.addParameter(p)

    def gcp_source(self, parameters, context, feedback) -> tuple[str, str | None]:
        """``(path, layer name)`` of the GCPs: the file, or the project layer (exported if it is not a file)."""
        given = [bool(parameters.get(self.GCPS)), bool(parameters.get(self.GCP_LAYER_IN))]
        if given.count(True) != 1:
            raise QgsProcessingException("give the GCPs either as a file (GCPS) or as a point layer "
                                         "(GCP_LAYER_INPUT), not both and not neither")
        if given[0]:
            return (self.parameterAsFile(parameters, self.GCPS, context),
                    self.parameterAsString(parameters, self.LAYER, context) or None)
        path, layer = self.parameterAsCompatibleSourceLayerPathAndLayerName(
            parameters, self.GCP_LAYER_IN, context, ["gpkg", "shp", "geojson"], "gpkg", feedback)
        if not path:
            raise QgsProcessingException(self.invalidSourceError(parameters, self.GCP_LAYER_IN))
        return path, layer or None

    def gcp_arguments(self, parameters, context, layer=None) -> dict:
        crs = self.parameterAsCrs(parameters, self.CRS, context)
        camera = self.parameterAsFile(parameters, self.CAMERA, context)
        return dict(
            layer=layer,
            crs=RegisterAlgorithm.crs_spec(crs) if crs.isValid() else None,
            dem=self.raster_path(parameters, self.DEM, context) if parameters.get(self.DEM) else None,
            height=self.optional_double(parameters, self.HEIGHT, context),
            camera=camera or None,
            fields={f: self.parameterAsString(parameters, f"{f.upper()}_FIELD", context) or f for f in FIELDS},
        )


class OrientAlgorithm(_GcpAlgorithm):
    ALG_ID = "orient"
    DISPLAY = "Orient image from GCPs"
    HELP = ("Fits an orientation model (ground → image) to the control points of an image and measures it "
            "at the check points: similarity, affine, projective, polynomials 1-3 (2-D), affine with height, "
            "bilinear, 3-D polynomials, DLT, rational function models (separate, common or no denominator; "
            "ground→image or image→ground, '-i2g') and collinearity with a known camera. Least squares with "
            "data snooping flags blunders (optionally removed and refitted).\n\n"
            "Outputs (each optional): JSON report (RMS x, y, xy, min, max, median in pixels, or mm with a scan "
            "pixel size, per-point residuals, blunders, warnings); GeoPackage with the layers gcps and "
            "error_vectors (arrows from each GCP to where the model puts its image point on the ground); a "
            "PNG plot of the residual vectors; a Georeferencer .points file with residuals; for RFMs a GeoTIFF "
            "copy of the image carrying the model as GDAL RPC metadata (usable by gdalwarp -rpc and QGIS); for "
            "poly1-3 a GeoTIFF copy carrying the control points as GDAL GCPs (gdalwarp -order 1-3 reproduces the "
            "model); "
            "a rectified GeoTIFF in the GCP CRS.\n\n" + GCP_HELP + "\n\nReference: " + REFERENCE_004)

    MODEL, SCAN_PIXEL_UM, SNOOPING, REMOVE_BLUNDERS = "MODEL", "SCAN_PIXEL_UM", "SNOOPING", "REMOVE_BLUNDERS"
    EXAGGERATION, RESOLUTION, RESAMPLING = "EXAGGERATION", "RESOLUTION", "RESAMPLING"
    REPORT, VECTORS, PLOT, POINTS, RPC, RECTIFY = "REPORT", "VECTORS", "PLOT", "POINTS", "RPC", "RECTIFY"
    GCP_TIFF = "GCP_TIFF"
    GCP_LAYER, ERROR_VECTORS = "GCP_LAYER", "ERROR_VECTORS"
    CONTROL_RMS, CHECK_RMS, BLUNDERS, MODEL_NAME = "CONTROL_RMS_XY_PX", "CHECK_RMS_XY_PX", "BLUNDERS", "MODEL_NAME"

    def initAlgorithm(self, config=None):
        Num = QgsProcessingParameterNumber
        self.add_gcp_parameters()
        self.addParameter(QgsProcessingParameterEnum(self.MODEL, tr("Model"), options=list(MODELS),
                                                     defaultValue=MODELS.index("poly1")))
        self.addParameter(QgsProcessingParameterBoolean(self.SNOOPING, tr("Data snooping (flag blunders)"),
                                                        defaultValue=True))
        self.addParameter(QgsProcessingParameterBoolean(self.REMOVE_BLUNDERS, tr("Remove flagged blunders and refit"),
                                                        defaultValue=False))
        advanced = [
            Num(self.SCAN_PIXEL_UM, tr("Scan pixel size in µm (report residuals in mm on the photo)"), Num.Double,
                optional=True, minValue=0.0),
            Num(self.EXAGGERATION, tr("Error vector exaggeration (drawing scale)"), Num.Double, defaultValue=1.0,
                minValue=0.001),
            Num(self.RESOLUTION, tr("Rectified pixel size (0 = the image's ground sample distance)"), Num.Double,
                defaultValue=0.0, minValue=0.0),
            QgsProcessingParameterEnum(self.RESAMPLING, tr("Rectification resampling"), options=list(RESAMPLINGS),
                                       defaultValue=0),
        ]
        for p in advanced:
            p.setFlags(p.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
            self.addParameter(p)
        self.addParameter(QgsProcessingParameterFileDestination(self.REPORT, tr("Report (JSON)"), "JSON (*.json)",
                                                                optional=True, createByDefault=True))
        self.addParameter(QgsProcessingParameterVectorDestination(
            self.VECTORS, tr("GCPs and error vectors (GeoPackage)"), QgsProcessing.TypeVectorPoint, optional=True,
            createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(self.PLOT, tr("Residual plot (PNG)"), "PNG (*.png)",
                                                                optional=True, createByDefault=False))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.POINTS, tr("Georeferencer points file with residuals"), "Georeferencer points (*.points)",
            optional=True, createByDefault=False))
        self.addParameter(QgsProcessingParameterRasterDestination(
            self.RPC, tr("Image with the RFM as GDAL RPC metadata (RFM models)"), optional=True,
            createByDefault=False))
        self.addParameter(QgsProcessingParameterRasterDestination(
            self.GCP_TIFF, tr("Image with the control points as GDAL GCPs (poly1-3)"), optional=True,
            createByDefault=False))
        self.addParameter(QgsProcessingParameterRasterDestination(self.RECTIFY, tr("Rectified image"), optional=True,
                                                                  createByDefault=False))
        self.addOutput(QgsProcessingOutputVectorLayer(self.GCP_LAYER, tr("GCPs with residuals")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.ERROR_VECTORS, tr("Error vectors")))
        self.addOutput(QgsProcessingOutputNumber(self.CONTROL_RMS, tr("RMS xy at control points (px)")))
        self.addOutput(QgsProcessingOutputNumber(self.CHECK_RMS, tr("RMS xy at check points (px)")))
        self.addOutput(QgsProcessingOutputNumber(self.BLUNDERS, tr("Flagged blunders")))
        self.addOutput(QgsProcessingOutputString(self.MODEL_NAME, tr("Model")))

    def processAlgorithm(self, parameters, context, feedback):
        orient = self.tool("tools.orient", "orient")
        image = self.raster_path(parameters, self.IMAGE, context)
        gcps, gcp_layer = self.gcp_source(parameters, context, feedback)
        outputs = {
            "report": self.parameterAsFileOutput(parameters, self.REPORT, context),
            "vectors": self.parameterAsOutputLayer(parameters, self.VECTORS, context),
            "plot": self.parameterAsFileOutput(parameters, self.PLOT, context),
            "points": self.parameterAsFileOutput(parameters, self.POINTS, context),
            "rpc": self.parameterAsOutputLayer(parameters, self.RPC, context),
            "gcp_tiff": self.parameterAsOutputLayer(parameters, self.GCP_TIFF, context),
            "rectify": self.parameterAsOutputLayer(parameters, self.RECTIFY, context),
        }
        outputs = {k: v for k, v in outputs.items() if v}
        if "vectors" in outputs and os.path.splitext(outputs["vectors"])[1].lower() != ".gpkg":
            raise QgsProcessingException(f"VECTORS must be a GeoPackage (.gpkg); got {outputs['vectors']!r}")
        for key in ("rpc", "gcp_tiff", "rectify"):
            if key in outputs and not outputs[key].lower().endswith((".tif", ".tiff")):
                raise QgsProcessingException(f"{key.upper()}: fotogeo writes GeoTIFF; give a file name ending "
                                             f"in .tif (got {outputs[key]!r})")
        model = self.enum_value(parameters, self.MODEL, context, MODELS)
        resolution = self.parameterAsDouble(parameters, self.RESOLUTION, context)
        rep = self.run_tool(
            orient, image, gcps, model=model, feedback=feedback, overwrite=True,
            snooping=self.parameterAsBoolean(parameters, self.SNOOPING, context),
            remove_blunders=self.parameterAsBoolean(parameters, self.REMOVE_BLUNDERS, context),
            scan_pixel_um=self.optional_double(parameters, self.SCAN_PIXEL_UM, context) or None,
            exaggeration=self.parameterAsDouble(parameters, self.EXAGGERATION, context),
            resolution=resolution if resolution > 0 else None,
            resampling=self.enum_value(parameters, self.RESAMPLING, context, RESAMPLINGS),
            **self.gcp_arguments(parameters, context, gcp_layer), **outputs)
        feedback.pushInfo(f"model {rep['model_name']}: {rep['n_gcps']} GCPs")
        for role in ("control", "check", "blunder"):
            s = rep.get(role) or {}
            if s.get("n"):
                feedback.pushInfo(f"{role}: n={s['n']}, RMS x {s['rms_x_px']:.3f} px, y {s['rms_y_px']:.3f} px, "
                                  f"xy {s['rms_xy_px']:.3f} px, max {s['max_px']:.3f} px")
        for f in rep.get("snooping", []):
            feedback.pushWarning(f"blunder? GCP {f['id']}: {f['reason']}{' (removed)' if f['removed'] else ''}")
        for w in rep.get("warnings", []):
            feedback.pushWarning(w)
        nan = float("nan")
        result = {self.CONTROL_RMS: float((rep.get("control") or {}).get("rms_xy_px", nan)),
                  self.CHECK_RMS: float((rep.get("check") or {}).get("rms_xy_px", nan)),
                  self.BLUNDERS: len(rep.get("snooping", [])), self.MODEL_NAME: rep["model_name"]}
        for key, name in (("report", self.REPORT), ("plot", self.PLOT), ("points", self.POINTS), ("rpc", self.RPC),
                          ("gcp_tiff", self.GCP_TIFF), ("rectify", self.RECTIFY), ("vectors", self.VECTORS)):
            result[name] = outputs.get(key)
        result[self.GCP_LAYER] = result[self.ERROR_VECTORS] = None
        if "vectors" in outputs:
            vec = outputs["vectors"]
            result[self.GCP_LAYER] = f"{vec}|layername=gcps"
            result[self.ERROR_VECTORS] = f"{vec}|layername=error_vectors"
            if context.willLoadLayerOnCompletion(vec):  # the GeoPackage opens on its first layer: gcps
                style_output(context, vec, "tie_points")
                load_on_completion(context, result[self.ERROR_VECTORS], tr("Error vectors"), self.ERROR_VECTORS,
                                   "error_vectors")
        return result
