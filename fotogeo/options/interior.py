"""The film-scan tool's options (``fotogeo interior``, QGIS ``fotogeo:interior``), declared as every tool's are in
:mod:`fotogeo.options` (standard library only, like it)."""
from __future__ import annotations

from .table import Option, Table

#: interior orientation of scanned film frames (``fotogeo interior``, fotogeo.tools.interior.tool)
INTERIOR = Table(
    Option("model", "choice", "affine", "Pixel -> photo transform", "Pixel -> photo-coordinate transform: affine (>= 3 "
           "marks) or projective (>= 4).", choices=("affine", "projective")),
    Option("scan_pixel_um", "float", None, "Scan pixel size in µm (empty = the TIFF's resolution tags)",
           "Scan pixel size (µm) [from the TIFF's resolution tags].", minimum=0.0, exclusive_minimum=True),
    Option("rotation", "choice", "auto", "Scan rotation (auto = tried in 90° steps)",
           "Rotation of the scan against the photo, clockwise, in 90° steps: auto tries all four (a layout "
           "symmetric under the rotation cannot tell them apart: give it; one the marks contradict is refused).",
           choices=("auto", "0", "90", "180", "270")),
    Option("search_mm", "float", 10.0, "Search radius around each predicted mark (mm on the photo)",
           "Marks are looked for within this radius (mm) of where the report's layout puts them.", minimum=0.0,
           exclusive_minimum=True, advanced=True),
    Option("max_residual_px", "float", 1.0, "Largest mark residual accepted (scan px)",
           "A mark whose residual exceeds this (scan pixels) refuses the scan: damaged mark or wrong report.",
           minimum=0.0, exclusive_minimum=True),
    Option("min_fiducials", "int", 4, "Fewest marks found", "Fewest fiducial marks that must be found.", minimum=3),
    Option("resample", "bool", False, "Resample to the standard frame (with its camera YAML)",
           "Write <output>_frame.tif resampled to the standard frame (square pixels, principal point at the "
           "centre) and <output>_camera.yaml for orient and triangulate."),
    Option("resample_pixel_um", "float", None, "Standard-frame pixel size in µm (empty = the scan's)",
           "Pixel size (µm) of the standard frame [the scan's].", minimum=0.0, exclusive_minimum=True, advanced=True),
)
