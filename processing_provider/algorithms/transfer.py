"""``fotogeo:transferpoints`` — points transferred by pyramid NCC + least-squares matching."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
)

from fotogeo.options import TRANSFER

from .base import FotogeoAlgorithm, RasterFileParameter, tr

TABLE_FILTER = "Point tables (*.csv *.gpkg *.geojson *.shp);;All files (*.*)"
OUTPUT_FILTER = "CSV (*.csv);;GeoPackage (*.gpkg)"
REFERENCE_MATCHING = ("Area-based matching after Büyüksalih and the Turkish 'Görüntü Eşleme' study: normalised cross-correlation "
                 "(a correlation below 0.5 is a weak match) and least-squares matching with an affine geometric "
                 "and a linear radiometric model, iterated until the corrections vanish, precision from "
                 "σ0² = vᵀPv / (n − u) (Ackermann: 0.1-0.3 px).")


def table_output(alg, parameters, name, context) -> str:
    """Path of a point-table destination: fotogeo writes CSV or GeoPackage, chosen by suffix."""
    path = alg.parameterAsFileOutput(parameters, name, context)
    if os.path.splitext(path)[1].lower() not in (".csv", ".gpkg"):
        raise QgsProcessingException(f"{name} must be a .csv or .gpkg file; got {path!r}")
    return path


class TransferPointsAlgorithm(FotogeoAlgorithm):
    ALG_ID = "transferpoints"
    DISPLAY = "Transfer points (LSM)"
    SUMMARY = "Transfer points by least-squares matching"
    GROUP = ("matching", "Area-based matching")
    HELP = ("Finds points of a reference image (GCPs measured there, or an orthophoto's map positions) in a "
            "search image to sub-pixel, with their precision: coarse-to-fine normalised cross-correlation on "
            "image pyramids from the approximate positions, then least-squares matching. Both images must have "
            "about the same orientation and scale (within ~10° and ~10 %).\n\n"
            "Point table (CSV or vector layer file): reference pixel positions in ref_col, ref_row (or point "
            "geometries, when the reference is georeferenced) and approximate search positions in col, row "
            "(GDAL corner convention). Output (CSV or GeoPackage, by suffix): per point col, row (refined), "
            "sigma_x, sigma_y (px), ncc, status, and the approximation.\n\nReference: " + REFERENCE_MATCHING)

    OPTIONS = (TRANSFER,)
    REFERENCE, SEARCH, POINTS, OUTPUT = "REFERENCE", "SEARCH", "POINTS", "OUTPUT"
    COUNT, CONVERGED, MEDIAN_SIGMA = "COUNT", "CONVERGED", "MEDIAN_SIGMA_PX"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFileParameter(self.REFERENCE, tr("Reference image")))
        self.addParameter(RasterFileParameter(self.SEARCH, tr("Search image")))
        self.addParameter(QgsProcessingParameterFile(self.POINTS, tr("Point table"), fileFilter=TABLE_FILTER))
        self.add_options(TRANSFER)
        self.addParameter(QgsProcessingParameterFileDestination(self.OUTPUT, tr("Transferred points"), OUTPUT_FILTER))
        self.addOutput(QgsProcessingOutputNumber(self.COUNT, tr("Points")))
        self.addOutput(QgsProcessingOutputNumber(self.CONVERGED, tr("Converged points")))
        self.addOutput(QgsProcessingOutputNumber(self.MEDIAN_SIGMA, tr("Median σ of the converged points (px)")))

    def processAlgorithm(self, parameters, context, feedback):
        output = table_output(self, parameters, self.OUTPUT, context)
        r = self.run_tool(
            "transfer_gcps", self.raster_path(parameters, self.REFERENCE, context),
            self.raster_path(parameters, self.SEARCH, context), self.parameterAsFile(parameters, self.POINTS, context),
            output, overwrite=True, feedback=feedback, **self.option_arguments(parameters, context))
        sigma = r["median_sigma_px"]
        said = f"median σ {sigma:.3f} px" if sigma is not None else "no σ"
        feedback.pushInfo(f"{r['converged']} of {r['points']} points converged ({said}); statuses {r['statuses']}")
        return {self.OUTPUT: output, self.COUNT: r["points"], self.CONVERGED: r["converged"],
                self.MEDIAN_SIGMA: float("nan") if sigma is None else float(sigma)}
