"""The co-registration tool's options (``fotogeo coreg``, QGIS ``fotogeo:coreg``), declared as every
tool's are in :mod:`fotogeo.options` (standard library only, like it)."""
from __future__ import annotations

from .shared import COREG_REPRESENTATIONS, RESAMPLINGS, SEED
from .table import Option, Table

#: area-based co-registration (``fotogeo.tools.coreg.tool.coregister``): the grid of windows, the
#: matching, the outlier filters and the field (see :mod:`fotogeo.coreg`)
COREG = Table(
    Option("grid_spacing", "int", 64, "Window grid spacing (target pixels)",
           "Spacing of the window grid (target pixels).", minimum=4),
    Option("window", "int", 128, "Matching window size (target pixels, even)",
           "Side of the matching windows (target pixels, even).", minimum=16, maximum=4096),
    Option("representation", "choice", "orientation", "Image representation for matching",
           "orientation (gradient orientation, robust to seasonal/sensor radiometry and contrast inversion), "
           "gradient, rank, intensity.", choices=COREG_REPRESENTATIONS),
    Option("lsm_representation", "choice", None, "Representation for the least-squares refinement",
           "Representation LSM refines on [the same]; intensity (grey values, signed gain) was less biased on a "
           "red/blue Landsat pair and keeps fewer windows on s2_pair.", choices=COREG_REPRESENTATIONS,
           none_choice="same", advanced=True),
    Option("smoothing", "float", 1.0, "Field smoothing (0 = through every window; larger = stiffer)",
           "Smoothing of the displacement field (0 = through every reliable window; larger = stiffer).",
           minimum=0.0),
    Option("iterations", "int", 2, "Passes (each on the target deformed by the previous field)",
           "Passes, each measuring on the target deformed by the previous field.", minimum=1, maximum=5,
           advanced=True),
    Option("model", "choice", "affine", "Global model", "Global model under the field.",
           choices=("affine", "projective")),
    Option("ransac_threshold", "float", 3.0, "RANSAC threshold of the global model (target pixels)",
           "RANSAC threshold of the global model (target pixels).", minimum=0.01, advanced=True),
    Option("max_shift", "float", 5.0, "Largest window shift (target pixels)",
           "Largest shift a window may measure (target pixels): the georeferences must agree this well.",
           minimum=0.5, advanced=True),
    Option("min_peak_ratio", "float", 1.5, "Smallest phase-correlation peak ratio",
           "Smallest ratio of the phase-correlation peak to the second peak.", minimum=1.0, advanced=True),
    Option("min_correlation", "float", 0.2, "Smallest correlation of the matched windows",
           "Smallest correlation of a matched window (on the representation).", minimum=-1.0, maximum=1.0,
           advanced=True),
    Option("min_windows", "int", 10, "Fewest reliable windows (else refused)",
           "Fewest reliable windows; fewer are refused, never a wild field.", minimum=3, advanced=True),
    Option("reference_band", "int", 1, "Reference band (1-based)", "Band of the reference matched (1-based).",
           minimum=1, flag="--reference-bands"),  # spelt as register's (one band here)
    Option("target_band", "int", 1, "Target band (1-based)", "Band of the target matched (1-based).", minimum=1,
           flag="--target-bands"),
    Option("reference_nodata", "float", None, "Reference nodata value (empty = the file's)",
           "Nodata value of the reference (overrides the file's).", advanced=True),
    Option("target_nodata", "float", None, "Target nodata value (empty = the file's)",
           "Nodata value of the target (overrides the file's).", advanced=True),
    Option("resampling", "choice", "cubic", "Resampling of the corrected target",
           "Resampling of the corrected target.", choices=RESAMPLINGS),
    Option("field_step", "int", 16, "Node spacing of the displacement field (target pixels)",
           "Node spacing of the written displacement field (target pixels).", minimum=1, advanced=True),
    SEED,
    Option("threads", "int", 1, "Threads (strips of windows matched in parallel)",
           "Threads matching strips of windows in parallel.", minimum=1, advanced=True),
)
