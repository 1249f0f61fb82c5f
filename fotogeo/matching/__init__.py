"""Area-based matching: NCC, least-squares matching, pyramids, GCP transfer, X targets.

All coordinates are ``(x, y)`` in the GDAL corner convention of :mod:`fotogeo.pixels`
(centre of the top-left pixel = (0.5, 0.5)). Images are 2-D arrays of any real dtype with
NaN (or an optional boolean mask, True = valid) marking nodata. Bad arguments raise
:class:`fotogeo.errors.InputError`; matching failures are reported in each result's
``status`` and never raised.

- :func:`ncc` — normalised cross-correlation with a sub-pixel peak fit (the Turkish 'Görüntü Eşleme' study of NCC and LSM; no author in our copy).
- :func:`lsm`, :func:`lsm_many` — least-squares matching, 6 affine + 2 radiometric
  parameters, σ from the Gauss-Markov covariance (Büyüksalih; the 'Görüntü Eşleme' study).
- :func:`build_pyramid`, :func:`pyramid_match`, :func:`transfer_points` — coarse-to-fine
  NCC on ``cv2.pyrDown`` pyramids followed by LSM (Büyüksalih; Yastıklı).
- :func:`measure_target`, :func:`synthetic_x_target` — X-shaped fiducial / calibration
  targets: edge method, then LSM against a synthetic template (Büyüksalih).
- :mod:`fotogeo.matching.status` — the status words all of them report (``OK``,
  ``CONVERGED``, ``WINDOW_OUTSIDE``, …), one word per outcome.
"""
from . import status
from .lsm import LSMBatch, LSMResult, lsm, lsm_many
from .lsm_steps import PARAMETERS
from .ncc import NCCResult, ncc
from .pyramid import (
    PyramidMatch,
    TransferResult,
    build_pyramid,
    from_level,
    levels_for,
    pyramid_match,
    to_level,
    transfer_points,
)
from .status import (
    AMBIGUOUS,
    CONVERGED,
    DIVERGED,
    FLAT,
    LOW_CORRELATION,
    LOW_SIGNAL,
    MAX_ITERATIONS,
    NODATA,
    OK,
    PEAK_AT_BORDER,
    SHIFT_BEYOND_WINDOW,
    SINGULAR,
    WINDOW_OUTSIDE,
)
from .targets import TargetResult, measure_target, synthetic_x_target

__all__ = [
    "AMBIGUOUS", "CONVERGED", "DIVERGED", "FLAT", "LOW_CORRELATION", "LOW_SIGNAL", "MAX_ITERATIONS", "NODATA",
    "OK", "PEAK_AT_BORDER", "SHIFT_BEYOND_WINDOW", "SINGULAR", "WINDOW_OUTSIDE", "status",
    "PARAMETERS", "LSMBatch", "LSMResult", "NCCResult", "PyramidMatch", "TargetResult",
    "TransferResult", "build_pyramid", "from_level", "levels_for", "lsm", "lsm_many", "measure_target",
    "ncc", "pyramid_match", "synthetic_x_target", "to_level", "transfer_points",
]
