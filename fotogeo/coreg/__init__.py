"""Area-based co-registration: a grid of windows, phase correlation and LSM on a
radiometry-robust representation, outlier filters, and a smooth displacement field.

Arrays in, arrays out (no file I/O; ``fotogeo.tools.coreg.tool`` reads and writes the files):

- :mod:`~fotogeo.coreg.representation` — gradient-orientation, gradient, rank and intensity representations;
- :mod:`~fotogeo.coreg.phase` — phase correlation of window stacks (Kuglin & Hines 1975);
- :mod:`~fotogeo.coreg.refine` — least-squares matching of whole windows (Ackermann 1984, Gruen 1985);
- :mod:`~fotogeo.coreg.windows` — one pass over the windows of a strip, with statuses and reliabilities;
- :mod:`~fotogeo.coreg.grid` — the window grid over the overlap and its strips;
- :mod:`~fotogeo.coreg.filter` — outliers against the global model (fotogeo's RANSAC) and the neighbours;
- :mod:`~fotogeo.coreg.field` — the global model plus a smoothing thin-plate spline on a coarse grid;
- :mod:`~fotogeo.coreg.pipeline` — the passes (iterative window deformation) on strips from a source;
- :mod:`~fotogeo.coreg.similarity` — a coarse similarity of any rotation and scale (Fourier–Mellin, Reddy &
  Chatterji 1996) for images without a georeference to start from.

Shifts are ``(dx, dy)`` in target pixels with ``target = reference + shift``; the field
``D`` gives ``corrected(p) = target(p + D(p))`` (corner convention, :mod:`fotogeo.pixels`).
Compared with AROSICS (Scheffler et al. 2017): a representation robust to seasonal and
sensor radiometry instead of grey values, LSM after the phase correlation, a smooth field
instead of a piecewise warp through the tie points, and passes on the deformed target.
"""
from .field import DisplacementField, fit_field
from .filter import OUTLIER_GLOBAL, OUTLIER_NEIGHBOURS, Filtered, reject_outliers
from .grid import WindowGrid, window_grid
from .phase import PhasePeaks, hann, phase_correlate
from .pipeline import ArraySource, CoregOptions, Coregistration, coregister_strips, deform, measure
from .refine import Refined, refine_windows
from .representation import REPRESENTATIONS, represent
from .windows import NO_GAIN, WindowShifts, match_windows

__all__ = ["ArraySource", "CoregOptions", "Coregistration", "DisplacementField", "Filtered", "NO_GAIN",
           "OUTLIER_GLOBAL", "OUTLIER_NEIGHBOURS", "PhasePeaks", "REPRESENTATIONS", "Refined", "WindowGrid",
           "WindowShifts", "coregister_strips", "deform", "fit_field", "hann", "match_windows", "measure",
           "phase_correlate", "refine_windows", "reject_outliers", "represent", "window_grid"]
