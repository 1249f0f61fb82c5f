"""The images least-squares matching refines the tie points on, made to correspond across band sets.

Features are matched on each image's own PCA fusion (:func:`.match.fused_for_matching`). For LSM, the
image with more bands fused is re-read and its bands combined to predict the other's fused image
(:mod:`fotogeo.image.band_match`) through the approximate homography of the consistent matches; the
combination replaces its PCA fusion (for the decimated and the full-resolution LSM alike) when it
correlates better with the other image and LSM on a sample of the tie points is more precise with it. An RGB target against an 8-band reference is then matched on
the reference's bands weighted as the target's brightness is, not on the reference's own first
principal component.
"""
from __future__ import annotations

import numpy as np

from ...image.band_match import combined_fusion, fit_combination
from ...io.raster import read_decimated
from .match import select_bands

#: the combined bands must converge on at least this share of the trial points PCA fusion converges on
TRIAL_SHARE = 0.9


def _bands(info, role: str, opts) -> np.ndarray:
    """The bands of ``role`` as :func:`.match.fused_for_matching` read them (same grid)."""
    numbers = select_bands(getattr(opts, f"{role}_bands", None), info.count, role)
    bands, _, _ = read_decimated(info, opts.max_match_pixels, role)
    return bands[np.asarray(numbers) - 1] if numbers != tuple(range(1, info.count + 1)) else bands


def matched_fusions(infos, opts, fu_ref, fu_tgt, homography, trial=None):
    """``(reference fusion, target fusion, report)`` for LSM; ``homography`` maps reference pixels to
    target pixels of the fused images (module docstring). ``trial(fu_ref, fu_tgt) -> (converged, median
    σ)`` runs LSM on a sample of the tie points: the combination is kept only when it converges on at
    least :data:`TRIAL_SHARE` as many and with a lower median σ (a combination fitted to a non-linear
    radiometric change can amplify noise or texture the other image lacks)."""
    n_ref, n_tgt = len(fu_ref.bands), len(fu_tgt.bands)
    if max(n_ref, n_tgt) < 2:
        return fu_ref, fu_tgt, {"lsm_on": "PCA fusions (one band each)"}
    side = "reference" if n_ref >= n_tgt else "target"
    own, other = (fu_ref, fu_tgt) if side == "reference" else (fu_tgt, fu_ref)
    to_other = homography.forward if side == "reference" else homography.inverse
    bands = _bands(infos[0] if side == "reference" else infos[1], side, opts)
    comb = fit_combination(bands, np.asarray(own.mask, bool), own, to_other, other)
    if comb is None:
        return fu_ref, fu_tgt, {"lsm_on": "PCA fusions (too little overlap to combine bands)"}
    report = {"combined": side, "weights": [round(float(w), 4) for w in comb.weights],
              "offset": round(comb.offset, 3), "correlation_pca": round(comb.correlation_pca, 4),
              "correlation_combined": round(comb.correlation, 4), "pixels": comb.n}
    if not comb.better:
        return fu_ref, fu_tgt, {"lsm_on": "PCA fusions (combining the bands did not correlate better)", **report}
    new = combined_fusion(bands, np.asarray(own.mask, bool), own, comb)
    pair = (new, fu_tgt) if side == "reference" else (fu_ref, new)
    if trial is not None:
        (pca_n, pca_s), (new_n, new_s) = trial(fu_ref, fu_tgt), trial(*pair)
        report["trial"] = {"pca": {"converged": pca_n, "median_sigma_px": pca_s},
                           "combined": {"converged": new_n, "median_sigma_px": new_s}}
        if not (new_n >= TRIAL_SHARE * pca_n and (pca_s is None or (new_s is not None and new_s < pca_s))):
            return fu_ref, fu_tgt, {"lsm_on": "PCA fusions (LSM on the combined bands was less precise on a "
                                              "trial)", **report}
    report["lsm_on"] = f"the {side}'s bands combined to match the other's fusion"
    return (*pair, report)
