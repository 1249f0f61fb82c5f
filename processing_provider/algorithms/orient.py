"""``fotogeo:orient`` — an orientation model fitted to GCPs; the GCP parameters it shares with comparemodels."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterVectorDestination,
)

from fotogeo.options import GCP, ORIENT

from ..postprocess import LoadedRun, load_on_completion, style_output
from .base import FotogeoAlgorithm, RasterFileParameter, tr

GCP_FILTER = "GCP files (*.gpkg *.points *.csv *.geojson *.shp);;All files (*.*)"

REFERENCE_ORIENTATION = ("Öztürk, Karşlı, Dihkan: orientation of aerial photographs from map GCPs with affine-with-height, "
                 "bilinear, projective, DLT and rational function models.")

GCP_HELP = ("GCPs: a point layer of the project, or a point layer file (GeoPackage, Shapefile, GeoJSON), with "
            "the image position in fields col, "
            "row (GDAL corner convention: 0,0 = top-left corner of the top-left pixel), optional z, role "
            "(control / check) and id; a CSV with map columns x, y (CRS parameter needed); or a QGIS "
            "Georeferencer .points file (enabled = control, disabled = check). The field names can be changed "
            "under Advanced. Heights for 3-D models: the z field, else the DEM, else the constant height (the "
            "log says how many came from the DEM). A GCP whose image position lies outside the image is skipped "
            "with a warning naming it (and listed in the report); too few left for the model is an error.")


class _GcpAlgorithm(FotogeoAlgorithm):
    """Parameters shared by orient and comparemodels: the image, GCP source, heights, camera."""

    GROUP = ("orientation", "Orientation")
    IMAGE, GCPS, GCP_LAYER_IN, LAYER = "IMAGE", "GCPS", "GCP_LAYER_INPUT", "LAYER"

    def add_gcp_parameters(self, image_label: str = "Image", table=GCP):
        """The image, the GCPs (a file, or a point layer of the project) and the options of ``table``."""
        self.addParameter(RasterFileParameter(self.IMAGE, tr(image_label)))
        self.addParameter(QgsProcessingParameterFile(self.GCPS, tr("GCP file (layer, CSV or .points)"),
                                                     fileFilter=GCP_FILTER, optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            self.GCP_LAYER_IN, tr("… or a GCP point layer of the project"), [QgsProcessing.TypeVectorPoint],
            optional=True))
        self.add_options(table)

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
        """The tool's GCP keyword arguments (:data:`fotogeo.options.GCP`); ``layer`` from :meth:`gcp_source`."""
        return {**self.option_arguments(parameters, context, GCP), "layer": layer}


class OrientAlgorithm(_GcpAlgorithm):
    ALG_ID = "orient"
    DISPLAY = "Orient from GCPs"
    SUMMARY = "Orient image from GCPs"
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
            "a rectified GeoTIFF in the GCP CRS.\n\n" + GCP_HELP + "\n\nReference: " + REFERENCE_ORIENTATION)

    OPTIONS = (GCP, ORIENT)
    REPORT, VECTORS, PLOT, POINTS, RPC, RECTIFY = "REPORT", "VECTORS", "PLOT", "POINTS", "RPC", "RECTIFY"
    GCP_TIFF = "GCP_TIFF"
    GCP_LAYER, ERROR_VECTORS = "GCP_LAYER", "ERROR_VECTORS"
    CONTROL_RMS, CHECK_RMS, BLUNDERS, MODEL_NAME = "CONTROL_RMS_XY_PX", "CHECK_RMS_XY_PX", "BLUNDERS", "MODEL_NAME"

    def initAlgorithm(self, config=None):
        self.add_gcp_parameters()
        self.add_options(ORIENT)
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
        rep = self.run_tool("orient", image, gcps, feedback=feedback, overwrite=True,
                            **self.option_arguments(parameters, context, ORIENT),
                            **self.gcp_arguments(parameters, context, gcp_layer), **outputs)
        feedback.pushInfo(f"model {rep['model_name']}: {rep['n_gcps']} GCPs")
        for role in ("control", "check", "blunder"):
            s = rep.get(role) or {}
            if s.get("n"):
                feedback.pushInfo(f"{role}: n={s['n']}, RMS x {s['rms_x_px']:.3f} px, y {s['rms_y_px']:.3f} px, "
                                  f"xy {s['rms_xy_px']:.3f} px, max {s['max_px']:.3f} px")
        for f in rep.get("snooping", []):
            feedback.pushWarning(f"{f.get('flag', 'blunder')}: GCP {f['id']}: {f['reason']}{' (removed)' if f['removed'] else ''}")
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
        run = LoadedRun()  # the GCPs and error vectors stay above the rectified image, not under it
        stem = os.path.splitext(os.path.basename(image))[0]
        for key, label in (("rectify", tr("rectified")), ("rpc", tr("with RPC")), ("gcp_tiff", tr("with GCPs"))):
            if key in outputs:
                style_output(context, outputs[key], None, run, name=f"{stem} {label} ({rep['model_name']})")
        if "vectors" in outputs:
            vec = outputs["vectors"]
            result[self.GCP_LAYER] = f"{vec}|layername=gcps"
            result[self.ERROR_VECTORS] = f"{vec}|layername=error_vectors"
            if context.willLoadLayerOnCompletion(vec):  # the GeoPackage opens on its first layer: gcps
                name = f"{self.layer_stem(vec, parameters, self.IMAGE, context)} {rep['model_name']}"  # not "VECTORS"
                context.layerToLoadOnCompletionDetails(vec).name = f"{name} {tr('GCPs')}"
                style_output(context, vec, "gcps", run)
                load_on_completion(context, result[self.ERROR_VECTORS], f"{name} {tr('error vectors')}",
                                   self.ERROR_VECTORS, "error_vectors", run=run)
        return result
