"""``fotogeo:mosaic`` — one orthophoto mosaic with seamlines, feathering and balancing (issue 21)."""
from __future__ import annotations

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterDestination,
)

from fotogeo.options.products import MOSAIC

from ..postprocess import load_on_completion
from .base import FotogeoAlgorithm, RasterFilesParameter, tr


class MosaicAlgorithm(FotogeoAlgorithm):
    ALG_ID = "mosaic"
    DISPLAY = "Mosaic orthophotos (seamlines, feathering, balancing)"
    GROUP = ("orientation", "Orientation")
    HELP = ("Mosaics orthophotos of one CRS into one raster (on the finest pixel grid among them; the others are "
            "resampled onto it on the fly). "
            "Seamlines start as the Voronoi cells of each orthophoto's nadir point (the most vertical view of every "
            "cell) and follow, between two orthophotos, the least-cost path through their grey difference, so they "
            "go around what leans differently in the two images (buildings, trees). Each orthophoto gets a gain and "
            "an offset per band from the overlaps (radiometric balancing) and is feathered across its seams.\n\n"
            "The mosaic is blended in tiles (threads, or a Dask cluster: Advanced) assembled into one Cloud-Optimised "
            "GeoTIFF; memory stays bounded whatever the number of orthophotos.\n\n"
            "Outputs: the mosaic (COG) and a GeoPackage with the layers seamlines (image_a, image_b) and regions (each "
            "image's part, gains, offsets).\n\nReferences: Kerschner (2001): seamline detection in colour "
            "ortho-image mosaicking by twin snakes. Pan et al. (2009): seamline network generation.")

    OPTIONS = (MOSAIC,)
    ORTHOS, OUTPUT, SEAMLINES, SEAMS_LAYER = "ORTHOS", "OUTPUT", "SEAMLINES", "SEAMLINES_LAYER"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFilesParameter(self.ORTHOS, tr("Orthophotos"),
                                               QgsProcessing.TypeRaster))
        self.add_options(MOSAIC)
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, tr("Mosaic")))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.SEAMLINES, tr("Seamlines (GeoPackage) [beside the mosaic]"), "GeoPackage (*.gpkg)", optional=True,
            createByDefault=False))
        self.addOutput(QgsProcessingOutputVectorLayer(self.SEAMS_LAYER, tr("Seamlines")))

    def processAlgorithm(self, parameters, context, feedback):
        orthos = self.layer_paths(parameters, self.ORTHOS, context)
        if len(orthos) < 2:
            raise QgsProcessingException("ORTHOS: give at least two orthophotos")
        output = self.raster_output(parameters, self.OUTPUT, context)
        seams = self.file_output_or_beside(parameters, self.SEAMLINES, context, output, ".gpkg")
        rep = self.run_tool("mosaic", orthos, output, seamlines=seams, feedback=feedback, overwrite=True,
                            **self.option_arguments(parameters, context))
        for name, g, o in zip(rep["images"], rep["gains"], rep["offsets"]):
            feedback.pushInfo(f"{name}: gain {' '.join(f'{v:.3f}' for v in g)}, offset "
                              f"{' '.join(f'{v:+.1f}' for v in o)}")
        layer = f"{seams}|layername=seamlines"
        if context.project() is not None:
            load_on_completion(context, layer, tr("Seamlines"), self.SEAMS_LAYER, None)
        return {self.OUTPUT: output, self.SEAMLINES: seams, self.SEAMS_LAYER: layer}
