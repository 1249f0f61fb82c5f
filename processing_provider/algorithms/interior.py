"""``fotogeo:interior`` — interior orientation of scanned film frames from their fiducial marks."""
from __future__ import annotations

from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterFile,
    QgsProcessingParameterFolderDestination,
)

from fotogeo.options.interior import INTERIOR

from .base import FotogeoAlgorithm, RasterFilesParameter, tr

YAML = "YAML (*.yaml *.yml)"


class InteriorAlgorithm(FotogeoAlgorithm):
    ALG_ID = "interior"
    DISPLAY = "Interior orientation of scanned film frames"
    GROUP = ("orientation", "Orientation")
    HELP = ("Finds the fiducial marks of each scanned film frame without approximate positions and fits the pixel → "
            "photo-coordinate transform (affine or projective) from the calibration report's fiducial coordinates. "
            "The report (YAML) holds focal_mm, principal_point_mm [x, y], fiducials_mm {id: [x, y]} (mm, x right, "
            "y up) and the mark: x, cross, dot or corner, its size and arm width. Marks are looked for where the "
            "report's layout puts them (for each scan rotation in 90° steps, or the one given), by normalised "
            "cross-correlation with a template of the mark, then measured to sub-pixel by least-squares matching "
            "(after Büyüksalih). A scan with too few marks, or a mark whose residual exceeds the threshold, is "
            "refused with the marks named; scans of different pixel sizes are refused together.\n\nWrites one JSON "
            "per scan (<scan>.json: pixel_to_photo, residuals per mark) into the output folder and, with "
            "Resample, <scan>_frame.tif on the standard frame with <scan>_camera.yaml: a pinhole camera that "
            "orient and triangulate read.")

    OPTIONS = (INTERIOR,)
    SCANS, REPORT, OUTDIR, SCANS_DONE, WORST = "SCANS", "CAMERA_REPORT", "OUTDIR", "SCANS_DONE", "MAX_RESIDUAL_PX"

    def initAlgorithm(self, config=None):
        self.addParameter(RasterFilesParameter(self.SCANS, tr("Scanned frames"),
                                               QgsProcessing.TypeRaster))
        self.addParameter(QgsProcessingParameterFile(self.REPORT, tr("Camera calibration report (YAML)"),
                                                     fileFilter=YAML))
        self.add_options(INTERIOR)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTDIR, tr("Output folder")))
        self.addOutput(QgsProcessingOutputNumber(self.SCANS_DONE, tr("Scans oriented")))
        self.addOutput(QgsProcessingOutputNumber(self.WORST, tr("Largest mark residual (px)")))

    def processAlgorithm(self, parameters, context, feedback):
        scans = self.layer_paths(parameters, self.SCANS, context)
        if not scans:
            raise QgsProcessingException("SCANS: give the scanned frames")
        outdir = self.parameterAsString(parameters, self.OUTDIR, context)
        records = self.run_tool("interior", scans, self.parameterAsFile(parameters, self.REPORT, context), outdir,
                                overwrite=True, feedback=feedback, **self.option_arguments(parameters, context))
        for r in records:
            feedback.pushInfo(f"{r['scan']}: {len(r['fiducials'])} marks, RMS {r['rms_px']:.3f} px, max "
                              f"{r['max_residual_px']:.3f} px")
            for w in r["warnings"]:
                feedback.reportError(w, fatalError=False)
        return {self.OUTDIR: outdir, self.SCANS_DONE: len(records),
                self.WORST: max(r["max_residual_px"] for r in records)}
