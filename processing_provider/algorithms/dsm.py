"""``fotogeo:dsm`` — a surface model (DSM) and a point cloud from oriented images."""
from __future__ import annotations

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterDestination,
)

from fotogeo.options.dsm import DSM

from ..postprocess import dsm_look, file_layer_name, keep_users_style, style_output
from .base import FotogeoAlgorithm, RasterFilesParameter, tr


class DsmAlgorithm(FotogeoAlgorithm):
    ALG_ID = "dsm"
    DISPLAY = "Surface model (DSM) from oriented images"
    GROUP = ("orientation", "Orientation")
    HELP = ("Matches overlapping images whose orientation is known pair by pair and fuses the heights into a "
            "digital surface model: frame cameras with their interior orientation (YAML, pinhole or brown) and "
            "exterior orientation (the formats of 'Orthorectify oriented images', or triangulate's output "
            "folder), or satellite images carrying an RPC ('Images carry an RPC').\n\n"
            "Pairs are chosen from the footprints, their overlap and base-to-height ratio (or given as a text file "
            "of two image names per line). Each pair is rectified to epipolar geometry with the lens distortion "
            "removed, checked by sparse matches (epipolar residuals, rays' miss distances), matched by semi-global "
            "matching with sub-pixel disparities and left-right, uniqueness and speckle filters, and triangulated; "
            "a coarse DEM bounds the heights searched (else sparse matches do).\n\n"
            "Output: a Cloud-Optimised GeoTIFF, band 1 the median height of the pairs, band 2 how many pairs gave "
            "it, band 3 the spread of the points' heights; holes stay nodata unless filled (then band 4 marks the "
            "filled cells); QGIS shows band 1, the height, in colour over its 2 … 98 % range. Optional: a LAS 1.4 "
            "point cloud coloured from the images, and a JSON report (pairs kept "
            "and left out and why, match density, completeness, timings; written also when the run is refused: "
            "status refused, the error, the pairs tried and why).\n\n"
            "References: Hirschmüller (2008): stereo processing by semiglobal matching and mutual information. "
            "Fusiello, Trucco & Verri (2000): a compact algorithm for rectification of stereo pairs.")

    OPTIONS = (DSM,)
    IMAGES, OUTPUT, CLOUD, REPORT, COMPLETENESS = "IMAGES", "OUTPUT", "POINT_CLOUD", "REPORT", "COMPLETENESS"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFilesParameter(self.IMAGES, tr("Images"), QgsProcessing.TypeRaster))
        self.add_options(DSM)
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, tr("Surface model (DSM)")))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.CLOUD, tr("Point cloud (LAS 1.4)"), "LAS (*.las);;LAZ (*.laz)", optional=True,
            createByDefault=False))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.REPORT, tr("Report (JSON)"), "JSON (*.json)", optional=True, createByDefault=False))
        self.addOutput(QgsProcessingOutputNumber(self.COMPLETENESS, tr("Share of the overlap with a height")))

    def processAlgorithm(self, parameters, context, feedback):
        images = self.layer_paths(parameters, self.IMAGES, context)
        if len(images) < 2:
            raise QgsProcessingException("IMAGES: give at least two overlapping oriented images")
        output = self.raster_output(parameters, self.OUTPUT, context)
        report = self.parameterAsFileOutput(parameters, self.REPORT, context) or None  # as the CLI: only if asked
        cloud = self.parameterAsFileOutput(parameters, self.CLOUD, context) or None
        arguments = self.option_arguments(parameters, context)
        keep_users_style(arguments, output, feedback, self.OPTIONS[0]["qgis_style"].label)
        rep = self.run_tool("dsm", images, output, point_cloud=cloud, report=report, feedback=feedback,
                            overwrite=True, **arguments)
        for p in rep["pairs"]:
            state = (f"{100 * p.get('match_density', 0):.0f} % matched" if p["kept"] else f"left out: {p['reason']}")
            feedback.pushInfo(f"pair {p['images'][0]}-{p['images'][1]}: rays meet at {p['convergence_deg']:.0f} "
                              f"degrees (B/H {p['base_to_height']:.2f}), {state}")
        feedback.pushInfo(f"{100 * rep['completeness']:.1f} % of the overlap has a height")
        if context.willLoadLayerOnCompletion(output):  # band 1 (height) in pseudocolour, named after its file
            style_output(context, output, dsm_look(output), name=file_layer_name(output))
        return {self.OUTPUT: output, self.CLOUD: cloud, self.REPORT: report, self.COMPLETENESS: rep["completeness"]}
