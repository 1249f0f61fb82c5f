"""``fotogeo:demo`` — a generated scene registered and checked against its known truth."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingOutputRasterLayer,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterFolderDestination,
)

from fotogeo.options import DEMO

from ..postprocess import LoadedRun, load_on_completion
from .base import FotogeoAlgorithm, tr


class DemoAlgorithm(FotogeoAlgorithm):
    ALG_ID = "demo"
    DISPLAY = "Registration demo"
    SUMMARY = "Demo: register a generated scene and compare with its truth"
    GROUP = ("registration", "Registration")
    HELP = ("Generates a realistic scene without any download — a fractal DEM, a textured orthophoto "
            "(EPSG:32635, 4 m) and a frame rendered through a known rotated and tilted camera with other "
            "radiometry and noise — registers the frame to the orthophoto with the register algorithm (the "
            "paper's homography, and terrain-aware with the scene's DEM), and compares the fitted models with "
            "the known geometry on a dense grid. The results load into the project: reference, registered "
            "frame(s), tie points and error vectors. Then renders a small aerial block (2 strips of 4 frames, "
            "60 %/30 % overlap, relief) and triangulates it with 5 GCPs (the triangulate algorithm), comparing "
            "12 check points and the adjusted orientations with the truth; its footprints and tie points load "
            "too. A quick check that fotogeo and its dependencies work in this QGIS.")

    OPTIONS = (DEMO,)
    OUTPUT = "OUTPUT"
    REFERENCE, REGISTERED, TIE_POINTS, ERROR_VECTORS = "REFERENCE", "REGISTERED", "TIE_POINTS", "ERROR_VECTORS"
    CHECK_RMSE, TRUTH_RMSE, BEST_RMSE = "CHECK_RMSE_M", "TRUTH_RMSE_M", "BEST_HOMOGRAPHY_RMSE_M"
    ORTHORECTIFIED, TERRAIN_TRUTH_RMSE = "ORTHORECTIFIED", "TERRAIN_TRUTH_RMSE_M"
    BLOCK_FOOTPRINTS, BLOCK_TIE_POINTS = "BLOCK_FOOTPRINTS", "BLOCK_TIE_POINTS"
    BLOCK_CHECK_PLAN, BLOCK_CHECK_Z = "BLOCK_CHECK_RMSE_PLAN_M", "BLOCK_CHECK_RMSE_Z_M"

    def initAlgorithm(self, config=None):
        self.add_options(DEMO)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, tr("Folder for the scene and results")))
        self.addOutput(QgsProcessingOutputRasterLayer(self.REFERENCE, tr("Reference orthophoto")))
        self.addOutput(QgsProcessingOutputRasterLayer(self.REGISTERED, tr("Registered frame")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.TIE_POINTS, tr("Tie points")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.ERROR_VECTORS, tr("Error vectors")))
        self.addOutput(QgsProcessingOutputNumber(self.CHECK_RMSE, tr("RMSE at check points (m)")))
        self.addOutput(QgsProcessingOutputNumber(self.TRUTH_RMSE, tr("RMSE against the true geometry (m)")))
        self.addOutput(QgsProcessingOutputNumber(self.BEST_RMSE, tr("Best possible homography RMSE (m)")))
        self.addOutput(QgsProcessingOutputRasterLayer(self.ORTHORECTIFIED, tr("Terrain-aware (orthorectified) frame")))
        self.addOutput(QgsProcessingOutputNumber(self.TERRAIN_TRUTH_RMSE,
                                                 tr("Terrain-aware RMSE against the true geometry (m)")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.BLOCK_FOOTPRINTS, tr("Block footprints")))
        self.addOutput(QgsProcessingOutputVectorLayer(self.BLOCK_TIE_POINTS, tr("Block tie points")))
        self.addOutput(QgsProcessingOutputNumber(self.BLOCK_CHECK_PLAN,
                                                 tr("Block: check-point RMSE in plan against the truth (m)")))
        self.addOutput(QgsProcessingOutputNumber(self.BLOCK_CHECK_Z,
                                                 tr("Block: check-point RMSE in height against the truth (m)")))

    def processAlgorithm(self, parameters, context, feedback):
        folder = self.parameterAsString(parameters, self.OUTPUT, context)
        os.makedirs(folder, exist_ok=True)
        res = self.run_tool("run_demo", folder, feedback=feedback, **self.option_arguments(parameters, context))
        reg, truth = res["registration"], res["truth"]
        rep = reg["report"]
        feedback.pushInfo(f"keypoints {rep['keypoints']['target']} / {rep['keypoints']['reference']}, matches "
                          f"{rep['matches']}, inliers {rep['inliers']}; check RMSE {rep['check']['rmse_m']:.2f} m; "
                          f"against the truth {truth['dense_rmse_m']:.2f} m (best possible homography "
                          f"{truth['best_homography_rmse_m']:.2f} m)")
        result = {self.OUTPUT: folder, self.REFERENCE: os.path.join(folder, "reference.tif"),
                  self.REGISTERED: reg["output"], self.TIE_POINTS: f"{reg['vectors']}|layername=tie_points",
                  self.ERROR_VECTORS: f"{reg['vectors']}|layername=error_vectors",
                  self.CHECK_RMSE: float(rep["check"]["rmse_m"]), self.TRUTH_RMSE: float(truth["dense_rmse_m"]),
                  self.BEST_RMSE: float(truth["best_homography_rmse_m"])}
        terrain = res.get("terrain")  # the terrain-aware run, with the scene's DEM
        result[self.ORTHORECTIFIED] = terrain["output"] if terrain is not None else None
        result[self.TERRAIN_TRUTH_RMSE] = (float(res["terrain_truth"]["dense_rmse_m"]) if terrain is not None
                                           else float("nan"))
        if terrain is not None:
            feedback.pushInfo(f"terrain-aware: model {terrain['report']['model'].get('model')}, against the truth "
                              f"{result[self.TERRAIN_TRUTH_RMSE]:.2f} m")
        vectors = [(self.ERROR_VECTORS, "Demo error vectors", "error_vectors"),
                   (self.TIE_POINTS, "Demo tie points", "tie_points")]
        block = res.get("block")  # the rendered aerial block, triangulated
        if block is not None:
            vectors += self._block_results(block, result, feedback)
        if context.project() is not None:  # a demo is for looking at: load its layers, vectors above rasters
            run = LoadedRun()
            rasters = [(self.REFERENCE, "Demo reference"), (self.REGISTERED, "Demo registered")]
            if terrain is not None:
                rasters.append((self.ORTHORECTIFIED, "Demo orthorectified"))
            for key, name in rasters:
                load_on_completion(context, result[key], tr(name), key, None, raster=True, run=run)
            for key, name, style in vectors:
                load_on_completion(context, result[key], tr(name), key, style, run=run)
        return result

    def _block_results(self, block, result, feedback) -> list:
        """The block's numbers into ``result`` and the feedback; its layers to load (key, name, style)."""
        rep, t = block["report"], block["truth"]
        gpkg = os.path.join(rep["folder"], "block.gpkg")
        result.update({self.BLOCK_FOOTPRINTS: f"{gpkg}|layername=footprints",
                       self.BLOCK_TIE_POINTS: f"{gpkg}|layername=tie_points",
                       self.BLOCK_CHECK_PLAN: float(t["check_planimetric_m"]), self.BLOCK_CHECK_Z: float(t["check_z_m"])})
        feedback.pushInfo(f"aerial triangulation: {len(rep['frames'])} frames, {rep['matching']['tracks']} tie tracks, "
                          f"sigma0 {rep['sigma0']:.2f}; check points n={t['check_n']} against the truth: "
                          f"{t['check_planimetric_m']:.2f} m in plan ({t['check_planimetric_gsd']:.2f} GSD), "
                          f"{t['check_z_m']:.2f} m in height ({t['check_z_gsd']:.2f} GSD); projection centres "
                          f"{t['centre_rmse_m']:.2f} m, angles {t['angle_rmse_deg']:.3f} deg")
        return [(self.BLOCK_FOOTPRINTS, "Demo block footprints", None),
                (self.BLOCK_TIE_POINTS, "Demo block tie points", "tie_points")]
