"""``fotogeo:pcafusion`` — first principal component of a multi-band raster (PCA band fusion)."""
from __future__ import annotations

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterRasterDestination,
)

from fotogeo.options import FUSE

from .base import FotogeoAlgorithm, RasterFileParameter, tr


class PcaFusionAlgorithm(FotogeoAlgorithm):
    ALG_ID = "pcafusion"
    DISPLAY = "PCA band fusion"
    SUMMARY = "PCA band fusion (first principal component)"
    GROUP = ("images", "Images")
    HELP = ("Fuses all bands of a raster into its first principal component, as in the registration "
            "pipeline of Dihkan (2019): the band covariance is estimated on a sample of valid pixels "
            "and every pixel is projected onto the leading eigenvector.\n\n"
            "<b>Stretch to 8 bit</b> (default) writes a robust 1-99 % contrast stretch to 1..255 "
            "(0 = nodata), which is what helps feature matching most; otherwise float32 component "
            "values (nodata -9999). The georeference is kept; the explained variance is written to the "
            "output's metadata and returned as EXPLAINED.\n\n"
            "Reference: Dihkan (2019).")

    OPTIONS = (FUSE,)
    INPUT, OUTPUT, EXPLAINED = "INPUT", "OUTPUT", "EXPLAINED"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFileParameter(self.INPUT, tr("Multi-band raster")))
        self.add_options(FUSE)
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, tr("First principal component")))
        self.addOutput(QgsProcessingOutputNumber(self.EXPLAINED, tr("Explained variance (fraction)")))

    def processAlgorithm(self, parameters, context, feedback):
        source = self.raster_path(parameters, self.INPUT, context)
        output = self.raster_output(parameters, self.OUTPUT, context)
        result = self.run_tool("fuse_raster", source, output, feedback=feedback, overwrite=True,
                               **self.option_arguments(parameters, context))
        feedback.pushInfo(f"explained variance of the first component: {100 * result['explained']:.2f} %")
        return {self.OUTPUT: output, self.EXPLAINED: float(result["explained"])}
