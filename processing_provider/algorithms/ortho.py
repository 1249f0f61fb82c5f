"""``fotogeo:ortho`` — orthophotos of images whose orientation is known (frame camera + EO, or RPC), issue 21."""
from __future__ import annotations

import os

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterFolderDestination,
)

from fotogeo.options.products import ORTHO

from ..postprocess import LoadedRun, load_on_completion
from .base import FotogeoAlgorithm, RasterFilesParameter, tr


class OrthoAlgorithm(FotogeoAlgorithm):
    ALG_ID = "ortho"
    DISPLAY = "Orthorectify oriented images (frame camera or RPC)"
    GROUP = ("orientation", "Orientation")
    HELP = ("Orthorectifies images whose orientation is already known onto a DEM: frame cameras with their "
            "interior orientation (YAML: pinhole, or brown with distortion — triangulate's camera.yaml) and "
            "exterior orientation ('name X Y Z omega phi kappa' lines such as triangulate's "
            "exterior_orientation.txt, OpenSfM/ODM reconstruction.json, a COLMAP model's images.txt or images.bin, "
            "orthority .geojson/.csv), "
            "or satellite images carrying an RPC (vendor, or rpc-bias's corrected copy).\n\n"
            "Each output cell's centre takes its height from the DEM (bilinear), is projected into the image and "
            "resampled; the grid is north-up in the DEM's CRS (when projected) at each image's ground sample "
            "distance, its edges multiples of the resolution. A DEM that covers only part of an image clips the "
            "orthophoto (the coverage is reported); an RPC needs ellipsoidal heights, so a DEM of geoid heights "
            "is refused unless geoid undulations are given or its heights declared.\n\n"
            "<b>Occlusion masking</b> (with a DSM as the DEM): every cell's line of sight is traced through the "
            "surface and ground hidden from the camera becomes nodata instead of a double image of what hides "
            "it.\n\n<b>Uncertainty</b> (frames adjusted by triangulate: its exterior_orientation.txt with "
            "report.json beside it): &lt;name&gt;_ortho_sigma.tif, the predicted planimetric σ (m) of every cell, "
            "propagated from the adjustment's covariance of the frame's orientation and the DEM's height σ (default "
            "half its cell); loaded with a legend in metres. <b>View bands</b>: &lt;name&gt;_ortho_view.tif, the "
            "off-nadir angle (°) and the distance to the projection centre (m) of every cell.\n\n"
            "References: Amhar, Jansa & Ries (1998): the generation of true orthophotos using a 3D "
            "building model in conjunction with a conventional DTM. Grodecki & Dial (2003): RPC block adjustment.")

    OPTIONS = (ORTHO,)
    IMAGES, OUTDIR, COUNT = "IMAGES", "OUTDIR", "ORTHOPHOTOS"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFilesParameter(self.IMAGES, tr("Images"), QgsProcessing.TypeRaster))
        self.add_options(ORTHO)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTDIR, tr("Output folder "
                                                                                  "(<name>_ortho.tif per image)")))
        self.addOutput(QgsProcessingOutputNumber(self.COUNT, tr("Orthophotos written")))

    def processAlgorithm(self, parameters, context, feedback):
        images = self.layer_paths(parameters, self.IMAGES, context)
        if not images:
            raise QgsProcessingException("IMAGES: give the images to orthorectify")
        outdir = self.parameterAsString(parameters, self.OUTDIR, context)
        os.makedirs(outdir, exist_ok=True)
        rep = self.run_tool("ortho", images, outdir, feedback=feedback, overwrite=True,
                            **self.option_arguments(parameters, context))
        feedback.pushInfo(f"map CRS {rep['crs']}: {rep['crs_rule']}; heights: {'; '.join(rep['notes'])}")
        run = LoadedRun() if context.project() is not None else None
        for name, r in rep["images"].items():
            feedback.pushInfo(f"{name}: {r['width']}x{r['height']} px at {r['resolution']:.4g}, "
                              f"DEM coverage {100 * r['dem_coverage']:.0f} %")
            if run is not None:
                load_on_completion(context, r["path"], f"{name} {tr('ortho')}", self.OUTDIR, None, raster=True,
                                   run=run)
            if "sigma" in r:
                feedback.pushInfo(f"{name}: predicted planimetric σ {r['sigma']['min_m']:.3g} … "
                                  f"{r['sigma']['max_m']:.3g} m (DEM σ {rep['dem_sigma_m']:.3g} m, "
                                  f"{rep['dem_sigma_rule']})")
            for key, label, style in (("sigma", tr("σ (m)"), "uncertainty"),
                                      ("view", tr("view angle, distance"), None)):
                if key in r and run is not None:
                    load_on_completion(context, r[key]["path"], f"{name} {label}", self.OUTDIR, style, raster=True,
                                       run=run)
        return {self.OUTDIR: outdir, self.COUNT: len(rep["images"])}
