"""The status vocabulary of area-based matching, shared by NCC, LSM, pyramids and targets.

Every matching result carries a ``status``: the success word of its method, or the reason
it failed (failures are reported, never raised). One outcome has one word whichever method
reports it, so a table of statuses from :func:`fotogeo.matching.transfer_points` or
:func:`fotogeo.matching.measure_target` can be counted by value. A failure of one stage of
a composite method is prefixed by the stage (:func:`at_stage`), e.g.
``"ncc level 3: ambiguous"``, ``"lsm: diverged"``, ``"edge method: arms are parallel"``.
"""
from __future__ import annotations

#: NCC succeeded: a correlation peak passed every check (NCC does not iterate, hence not "converged").
OK = "ok"
#: LSM succeeded (and pyramids and targets, which end in LSM): the iteration converged and passed every check.
CONVERGED = "converged"

#: The template, or the (deformed) search window, does not lie wholly inside its image.
WINDOW_OUTSIDE = "window outside image"
#: Nodata (NaN or masked) pixels under the template or the search window.
NODATA = "nodata in window"
#: The template or the search window has no grey-value variation: there is nothing to match.
FLAT = "flat patch"
#: The correlation of the match is below ``min_correlation``.
LOW_CORRELATION = "low correlation"
#: NCC: a second correlation peak nearly as high as the first (repetitive texture).
AMBIGUOUS = "ambiguous"
#: NCC: the best peak lies on the border of the search area (the approximation is too far off).
PEAK_AT_BORDER = "peak at search border"
#: LSM: σx or σy above ``max_sigma`` (too little texture for the required precision).
LOW_SIGNAL = "low signal"
#: LSM: the normal matrix is (numerically) singular, e.g. texture in one direction only.
SINGULAR = "singular normal matrix"
#: LSM: affine determinant outside [0.5, 2] of the approximation's, gain <= 0, or non-finite parameters.
DIVERGED = "diverged"
#: LSM: the match moved farther than ``max_shift`` from the approximation.
SHIFT_BEYOND_WINDOW = "shift beyond window"
#: LSM: not converged after ``max_iterations``.
MAX_ITERATIONS = "max iterations"

#: Stage prefixes of composite methods (:func:`at_stage`).
STAGE_LSM = "lsm"
STAGE_EDGE_METHOD = "edge method"


def ncc_level(level: int) -> str:
    """Stage name of the NCC step at pyramid ``level``: ``"ncc level 3"``."""
    return f"ncc level {level}"


def at_stage(stage: str, status: str) -> str:
    """``status`` of the failed ``stage`` of a composite method: ``"lsm: diverged"``."""
    return f"{stage}: {status}"
