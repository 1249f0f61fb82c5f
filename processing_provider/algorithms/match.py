"""``fotogeo:matchfeatures`` — detect and match features only: a tie-point layer."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterVectorDestination,
)

from fotogeo.options import MATCH

from ..postprocess import style_output
from .base import REFERENCES, FotogeoAlgorithm, RasterFileParameter, tr


class MatchFeaturesAlgorithm(FotogeoAlgorithm):
    ALG_ID = "matchfeatures"
    DISPLAY = "Match features"
    SUMMARY = "Detect and match features (tie points)"
    GROUP = ("registration", "Registration")
    HELP = ("The first half of the registration pipeline, without fitting or resampling: both rasters are "
            "fused to their first principal component, keypoints are detected (fotogeo's SURF, or OpenCV "
            "SIFT) and matched (SSD nearest neighbour, ratio test, mutual check). The output point layer "
            "(layer tie_points) holds each match at its reference map position (reference CRS) with the "
            "fields target_col, target_row, ref_col, ref_row (GDAL corner convention) and inlier (1 when "
            "consistent with a RANSAC homography). Use it to inspect matching, or as GCPs for the orient "
            "algorithm and the Georeferencer (layertopoints).\n\n"
            f"References: {REFERENCES['dihkan']} {REFERENCES['surf']}")

    OPTIONS = (MATCH,)
    REFERENCE, TARGET, OUTPUT, MATCHES, INLIERS = "REFERENCE", "TARGET", "OUTPUT", "MATCHES", "INLIERS"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFileParameter(self.REFERENCE, tr("Reference raster")))
        self.addParameter(RasterFileParameter(self.TARGET, tr("Target raster")))
        self.add_options(MATCH)
        self.addParameter(QgsProcessingParameterVectorDestination(self.OUTPUT, tr("Tie points (GeoPackage)"),
                                                                  QgsProcessing.TypeVectorPoint))
        self.addOutput(QgsProcessingOutputNumber(self.MATCHES, tr("Matches")))
        self.addOutput(QgsProcessingOutputNumber(self.INLIERS, tr("Homography inliers")))

    def processAlgorithm(self, parameters, context, feedback):
        output = self.parameterAsOutputLayer(parameters, self.OUTPUT, context)
        if os.path.splitext(output)[1].lower() != ".gpkg":
            raise QgsProcessingException(f"OUTPUT must be a GeoPackage (.gpkg); got {output!r}")
        info = self.run_tool("match_images", self.raster_path(parameters, self.REFERENCE, context),
                             self.raster_path(parameters, self.TARGET, context), output, feedback=feedback,
                             overwrite=True, **self.option_arguments(parameters, context))
        feedback.pushInfo(f"keypoints {info['keypoints']['target']} / {info['keypoints']['reference']}, "
                          f"matches {info['matches']}, homography inliers {info['inliers']}")
        style_output(context, output, "tie_points")
        return {self.OUTPUT: output, self.MATCHES: info["matches"], self.INLIERS: info["inliers"]}
