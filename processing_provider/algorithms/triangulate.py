"""``fotogeo:triangulate`` — a block of frames oriented together by bundle adjustment (issue 13)."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFolderDestination,
)

from fotogeo.options import TRIANGULATE, YAML

from ..postprocess import LoadedRun, dsm_look, file_layer_name, keep_users_style, load_on_completion, style_output
from .base import REFERENCES, FotogeoAlgorithm, RasterFilesParameter, tr, with_help

CONTROL_FILTER = "Ground control (*.txt *.gpkg *.csv *.geojson *.shp);;All files (*.*)"
TABLE_FILTER = "Tables (*.csv *.gpkg *.geojson *.shp);;All files (*.*)"
TEXT_FILTER = "Text (*.txt);;All files (*.*)"
#: the block.gpkg layers the algorithm loads: (layer, output name, label, style of processing_provider/styles)
LAYERS = (("footprints", "FOOTPRINTS", "Frame footprints", "footprints"),  # outlines, below the points
          ("tie_points", "TIE_POINTS", "Tie points", None),
          ("control", "CONTROL", "Control and check points", "tie_points"))  # tie_points.qml: by role


def _layer_count(path: str) -> int:
    """The number of vector layers in the file ``path`` (0 when GDAL cannot open it)."""
    from osgeo import ogr
    ds = ogr.Open(path)
    return ds.GetLayerCount() if ds is not None else 0


class TriangulateAlgorithm(FotogeoAlgorithm):
    ALG_ID = "triangulate"
    DISPLAY = "Aerial triangulation"
    SUMMARY = "Aerial triangulation (bundle block adjustment)"
    ICON = "triangulation"
    GROUP = ("orientation", "Orientation")
    HELP = ("Orients a block of overlapping frames together: a bundle block adjustment with the collinearity "
            "equations (Levenberg–Marquardt on the reduced normal equations), ground control with its σ, "
            "self-calibration (f, principal point, Brown's k1–k3, p1–p2; by default for a camera guessed from the "
            "images' EXIF) with correlated parameters held fixed, "
            "Huber reweighting and Baarda's data snooping — the digital aerial triangulation of Yastıklı.\n\n"
            "Inputs: the frames; the camera (orthority YAML: pinhole, or brown with distortion — the camera.yaml "
            "a self-calibrating run writes); the approximate exterior orientation (name X Y Z omega phi kappa "
            "lines; frames without one are resected against their GCPs); ground control: ODM/OpenSfM "
            "gcp_list.txt, or a point layer (of the project, e.g. the GCP picker's, or a file) / CSV in any CRS "
            "with one row per (point, frame) measurement: id, frame, "
            "col, row (corner convention), z, optional role (control / check); and/or reference orthophoto(s) "
            "with a DEM, on which control is found automatically. Tie points: a table (frame, point, col, row), or "
            "left empty to match the overlapping frames (SURF, epipolar RANSAC, multi-ray tracks).\n\n"
            "Outputs in the folder: exterior_orientation.txt, camera.yaml (self-calibration), block.gpkg (tie "
            "points, control with residuals and role, frames, image residuals, footprints), report.json, "
            "report.html (residual vectors per frame, histogram, control layout, residuals sorted by size, mean "
            "σ per point type, matching statistics, timings) and, with Orthorectify, &lt;frame&gt;_ortho.tif; "
            "with Mosaic, mosaic.tif and its seamlines mosaic.gpkg.\n\n"
            "Undetermined frames (too few or clustered tie points, an angle σ above the limit, a prior its ties "
            "contradict) are dropped by default and named with the reason in a warning heading the log's summary "
            "and in report.json; 'fail' stops the run instead. A run that would drop more than half of the frames, or "
            "leave fewer than 2, is refused.\n\n"
            f"References: Brown (1971): close-range camera calibration. Baarda (1968): a testing procedure for "
            f"use in geodetic networks. Triggs et al. (2000): bundle adjustment — a modern synthesis. "
            f"{REFERENCES['surf']} {REFERENCES['ransac']}")

    OPTIONS = (TRIANGULATE,)
    WORDS = {"--camera": "Camera", "--eo": "Approximate exterior orientation", "--gcps": "Ground control",
             "--reference": "Reference orthophoto(s)", "--observations": "Tie-point table"}
    FRAMES, CAMERA, EO, OBSERVATIONS, GCPS, REFERENCE, OUTDIR = ("FRAMES", "CAMERA", "EO", "OBSERVATIONS", "GCPS",
                                                                 "REFERENCE", "OUTDIR")
    GCP_LAYER_IN = "GCP_LAYER_INPUT"  # the name orient and comparemodels give their GCP point layer
    REPORT_HTML, SIGMA0, IMAGE_RMS, CHECK_XY, CHECK_Z, BLUNDERS = ("REPORT_HTML", "SIGMA0", "IMAGE_RMS",
                                                                   "CHECK_RMSE_XY", "CHECK_RMSE_Z", "BLUNDERS")

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFilesParameter(self.FRAMES, tr("Frames"), QgsProcessing.TypeRaster))
        self.addParameter(QgsProcessingParameterFile(self.CAMERA, tr("Camera (interior orientation YAML; empty = "
                                                                     "the images' EXIF/XMP)"),
                                                     fileFilter=YAML, optional=True))
        self.addParameter(with_help(
            QgsProcessingParameterFile(self.EO, tr("Approximate exterior orientation (empty = GCPs, GPS or reference)"),
                                       fileFilter=TEXT_FILTER, optional=True),
            "Lines 'name X Y Z omega phi kappa' (map CRS, degrees). Empty: each frame resected from its GCPs, else "
            "the images' GPS with the attitude from the reference where they lack one, else each frame registered "
            "to the reference."))
        self.addParameter(QgsProcessingParameterFile(self.GCPS, tr("Ground control (gcp_list.txt, layer or CSV)"),
                                                     fileFilter=CONTROL_FILTER, optional=True))
        self.addParameter(with_help(QgsProcessingParameterFeatureSource(
            self.GCP_LAYER_IN, tr("… or a ground-control point layer of the project"), [QgsProcessing.TypeVectorPoint],
            optional=True), "One point per (point, frame) measurement with the fields id, frame, col, row (corner "
                            "convention), z and optionally role (control / check)."))
        self.addParameter(RasterFilesParameter(
            self.REFERENCE, tr("Reference orthophoto(s) for automatic control (with the DEM)"),
            QgsProcessing.TypeRaster, optional=True))
        self.addParameter(QgsProcessingParameterFile(self.OBSERVATIONS, tr("Tie-point table (empty = match the "
                                                                           "frames)"), fileFilter=TABLE_FILTER,
                                                     optional=True))
        self.add_options(TRIANGULATE)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTDIR, tr("Output folder")))
        for _, name, label, _ in LAYERS:
            self.addOutput(QgsProcessingOutputVectorLayer(name, tr(label)))
        self.addOutput(QgsProcessingOutputFile(self.REPORT_HTML, tr("Report (HTML)")))
        for name, label in ((self.SIGMA0, "σ0"), (self.IMAGE_RMS, "Image RMS (px)"),
                            (self.CHECK_XY, "Check-point RMSE planimetric (m)"),
                            (self.CHECK_Z, "Check-point RMSE height (m)"), (self.BLUNDERS, "Blunders culled")):
            self.addOutput(QgsProcessingOutputNumber(name, tr(label)))

    def processAlgorithm(self, parameters, context, feedback):
        frames = self.layer_paths(parameters, self.FRAMES, context)
        if not frames:
            raise QgsProcessingException("FRAMES: give the frames of the block")
        reference = self.layer_paths(parameters, self.REFERENCE, context) or None
        files = {k: self.parameterAsFile(parameters, k, context) or None
                 for k in (self.CAMERA, self.EO, self.OBSERVATIONS)}
        gcps = self._control_path(parameters, context, feedback)
        outdir = self.parameterAsString(parameters, self.OUTDIR, context)
        os.makedirs(outdir, exist_ok=True)
        arguments = self.option_arguments(parameters, context)
        keep_users_style(arguments, arguments.get("dsm"), feedback, self.OPTIONS[0]["qgis_style"].label)
        rep = self.run_tool("triangulate", frames, files[self.CAMERA], files[self.EO], files[self.OBSERVATIONS],
                            outdir, feedback=feedback, gcps=gcps, reference=reference, overwrite=True, **arguments)
        from fotogeo.tools.triangulate.outputs import accuracy_lines, dropped_lines, held_fixed_line, variance_lines
        for line in dropped_lines(rep):  # first, as a warning: the flag named by the dialog's label
            feedback.pushWarning(self.in_words(line))
        st = rep["statistics"]
        feedback.pushInfo(f"{st['n_frames']} frames, {st['n_points']} points, {st['n_observations']} observations: "
                          f"σ0 {rep['sigma0']:.3f}, image RMS {st['image_rms_px']:.3f} px, "
                          f"{st['n_blunders']} blunders culled")
        if st.get("covariance_rule"):  # whether σ0 widens the σ reported, as the command line says
            feedback.pushInfo(f"σ of the results: {st['covariance_rule']}")
        for line in variance_lines(rep):  # which observations drive σ0, and what to do
            feedback.pushInfo(self.in_words(line).replace("sigma", "σ"))  # flags first, then σ
        for line in accuracy_lines(rep):
            feedback.pushInfo(line)
        start = rep.get("start") or {}
        if start.get("source"):
            feedback.pushInfo(self.in_words(f"start: {start['source']}"))  # the dialog's labels, not the flags
        if start.get("crs_rule"):  # a drone flight gives no CRS: say which one the block is in, and why
            feedback.pushInfo(self.in_words(f"map CRS {rep.get('crs_name') or rep['crs']}: {start['crs_rule']}"))
        if start.get("heights"):
            feedback.pushInfo(f"GPS heights: {start['heights']}")
        for r in rep.get("restarted_frames") or []:
            feedback.pushWarning(self.in_words(f"re-started (attitude prior contradicted): {r['name']}: {r['reason']}"))
        if rep["fixed_parameters"]:  # one line, as the console's; the reasons in full are in report.html
            feedback.pushWarning(self.in_words(held_fixed_line(rep["fixed_parameters"])))
        return self._outputs(rep, outdir, context)

    def _control_path(self, parameters, context, feedback) -> str | None:
        """The ground control as a file path for the worker: the GCPS file, or the point layer's own file
        (a single-layer GeoPackage, Shapefile or GeoJSON) — any other layer (memory, a layer of a multi-layer
        GeoPackage, a selection, a database) exported by Processing to a GeoPackage in its temporary folder;
        None when neither is given (control from the reference orthophotos, or none)."""
        given = [bool(parameters.get(self.GCPS)), bool(parameters.get(self.GCP_LAYER_IN))]
        if all(given):
            raise QgsProcessingException(f"give the ground control either as a file ({self.GCPS}) or as a point "
                                         f"layer ({self.GCP_LAYER_IN}), not both")
        if given[0]:
            return self.parameterAsFile(parameters, self.GCPS, context) or None
        if not given[1]:
            return None
        path, layer = self.parameterAsCompatibleSourceLayerPathAndLayerName(
            parameters, self.GCP_LAYER_IN, context, ["gpkg", "shp", "geojson"], "gpkg", feedback)
        if path and layer and _layer_count(path) > 1:  # the worker reads a file's first layer: export this one
            path = self.parameterAsCompatibleSourceLayerPath(parameters, self.GCP_LAYER_IN, context, [], "gpkg",
                                                             feedback)
        if not path:
            raise QgsProcessingException(self.invalidSourceError(parameters, self.GCP_LAYER_IN))
        return path

    def _outputs(self, rep, outdir, context) -> dict:
        """The result dict; the block's layers (and orthophotos) loaded on completion, styled by role."""
        gpkg = os.path.join(outdir, "block.gpkg")
        check = rep["statistics"]["check"]
        nan = float("nan")
        result = {self.OUTDIR: outdir, self.REPORT_HTML: os.path.join(outdir, "report.html"),
                  self.SIGMA0: float(rep["sigma0"]), self.IMAGE_RMS: float(rep["statistics"]["image_rms_px"]),
                  self.CHECK_XY: float(check.get("rmse_planimetric_m", nan)),
                  self.CHECK_Z: float(check.get("rmse_z_m", nan)),
                  self.BLUNDERS: int(rep["statistics"]["n_blunders"])}
        for layer, name, _, _ in LAYERS:
            result[name] = f"{gpkg}|layername={layer}"
        surface = (rep.get("dsm") or {}).get("outputs", {}).get("dsm")
        if surface:  # --dsm: the destination parameter's output (QGIS loads it as it loads every destination)
            result["DSM"] = surface
        if context.project() is not None:  # the block's layers, vectors above the orthophotos
            run = LoadedRun()
            if surface:  # as fotogeo:dsm shows its DSM, when Processing loads it
                style_output(context, surface, dsm_look(surface), run, name=file_layer_name(surface))
            for frame, done in (rep.get("orthorectified") or {}).items():
                if "error" in done:  # not orthorectified (e.g. off the DEM): no file to load
                    continue
                load_on_completion(context, os.path.join(outdir, f"{frame}_ortho.tif"), f"{frame} {tr('ortho')}",
                                   self.OUTDIR, None, raster=True, run=run)
                if "sigma" in done:  # --uncertainty: the σ with its legend in metres, as fotogeo:ortho loads it
                    load_on_completion(context, done["sigma"]["path"], f"{frame} {tr('σ (m)')}", self.OUTDIR,
                                       "uncertainty", raster=True, run=run)
            if (rep.get("mosaic") or {}).get("output"):  # --mosaic: above the orthophotos it is made of
                load_on_completion(context, rep["mosaic"]["output"], tr("mosaic"), self.OUTDIR, None, raster=True,
                                   run=run)
            st = rep["statistics"]
            for layer, name, label, style in LAYERS:
                if layer == "control" and not ((st.get("control") or {}).get("n") or (st.get("check") or {}).get("n")):
                    continue  # no ground control (a drone flight on its GPS): an empty table, not a layer to show
                load_on_completion(context, result[name], tr(label), name, style, run=run)
        return result
