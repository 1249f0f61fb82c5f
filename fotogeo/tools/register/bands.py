"""The images least-squares matching refines the tie points on, made to correspond across band sets.

Features are matched on each image's own PCA fusion (:func:`.match.fused_for_matching`). For LSM, the
image with more bands fused is re-read and its bands combined to predict the other's fused image
(:mod:`fotogeo.image.band_match`) through the approximate homography of the consistent matches; the
combination replaces its PCA fusion (for the decimated and the full-resolution LSM alike) when it
correlates better with the other image and LSM on a sample of the tie points is more precise with it. An RGB
target against an 8-band reference is then matched on the reference's bands weighted as the target's
brightness is, not on the reference's own first principal component.

The features themselves are matched on the PCA fusions, which correspond when the two images have the same
bands. When they do not — a NIR-only target against an RGB reference, whose vegetation is bright where the
visible bands are dark — the first match may keep only a handful of homography inliers. Their homography,
however rough, aligns the images well enough to fit the same combination on smoothed images
(:func:`combined_for_matching`); the features of that side are then detected again on it and matched once
more (:func:`fotogeo.tools.register.match.find_tie_points`). The re-match is kept only when it is evidence of
the same alignment, not merely a different one: the combination correlates with the other image above
:data:`REMATCH_MIN_CORRELATION` (a least-squares combination always correlates at least as well as the PCA
component, one member of the same linear family, so "better" alone passes even under a wrong homography on
unrelated images, at correlations near 0), the new match keeps at least ``max(2·n0, REMATCH_MIN_INLIERS)``
homography inliers (n0 those of the first match), and its homography H₁ agrees with the rough one H₀ where H₀
is supported, at the first match's inliers ``p_i`` (reference pixels matched): ``median_i ‖H₁(p_i) − H₀(p_i)‖ ≤
REMATCH_AGREE_PX`` (the median: single keypoints of a cross-band match are off by up to ~8 px). At the image
corners H₀ extrapolates: fitted to the 6 inliers of the s2 NIR-only case it is 64 px off there while the
re-match of 682 inliers is right. Otherwise the first match is kept and the report's
``bands_rematched`` says why (``kept: false``, ``refused``).

A handful of inliers among mostly wrong matches need not be the true alignment: with so few, RANSAC may stop at
its trial limit before its confidence is reached, and may keep a consensus of a few true and some wrong matches
(the homography off by tens of pixels), which fits a combination that does not correlate. When the correlation
gate refuses it, the same RANSAC draws on from the same seeded generator, and the consensus it keeps then — when
it is not a consensus tried already — is tried through the same gate, at most :data:`REMATCH_TRIES` hypotheses in
all. A re-match from one of them passes the same inlier count (twice the larger of the first consensus and its
own, at least :data:`REMATCH_MIN_INLIERS`) and agreement (with that hypothesis at its own inliers) checks; the
report's ``hypotheses`` lists each try's inliers and outcome.
"""
from __future__ import annotations

import itertools
from dataclasses import replace

import cv2
import numpy as np

from ...errors import FotogeoError
from ...features.detect import detect
from ...image.band_match import combined_fusion, fit_combination
from ...image.contrast import apply_contrast
from ...io.raster import read_decimated
from ...models import Projective, ransac
from .selection import match_keypoints, select_bands

#: the combined bands must converge on at least this share of the trial points PCA fusion converges on
TRIAL_SHARE = 0.9
#: a first feature match with fewer homography inliers than this is tried again on combined bands
REMATCH_BELOW = 50
#: Gaussian σ (matched pixels) of the smoothing before a combination is fitted through a rough homography:
#: smoothing leaves a linear relation between bands as it is, and makes a misalignment of a few pixels (the
#: RANSAC threshold) small against the structures compared
ROUGH_FIT_SMOOTHING = 3.0
#: the combination fitted through the rough homography must correlate (smoothed) at least this well with the
#: other image: the s2 NIR-only and NIR + G cases of benchmarks/register_bands_bench.py reach 0.90-0.99 (0.90:
#: ref3_tgtN r200_s0.9_p), unrelated scenes under wrong homographies <= 0.09 (tests/test_register_band_sets.py)
REMATCH_MIN_CORRELATION = 0.7
#: the re-match must keep at least this many homography inliers (and twice the first match's)
REMATCH_MIN_INLIERS = 20
#: the re-match's homography must agree with the rough one at the first match's inliers within this (median,
#: pixels of the images matched): both describe the same alignment there when the re-match is right (0.9-2.6 px
#: on the s2 NIR-only and NIR + G cases of benchmarks/register_bands_bench.py and the r45 test case)
REMATCH_AGREE_PX = 5.0
#: hypotheses of the first match tried for the combination: RANSAC's, then those it keeps drawing on
REMATCH_TRIES = 4


def _bands(info, role: str, opts) -> np.ndarray:
    """The bands of ``role`` as :func:`.match.fused_for_matching` read them (same grid)."""
    numbers = select_bands(getattr(opts, f"{role}_bands", None), info.count, role)
    bands, _, _ = read_decimated(info, opts.max_match_pixels, role)
    return bands[np.asarray(numbers) - 1] if numbers != tuple(range(1, info.count + 1)) else bands


def matched_fusions(infos, opts, fu_ref, fu_tgt, homography, trial=None, matched="PCA fusions"):
    """``(reference fusion, target fusion, report)`` for LSM; ``homography`` maps reference pixels to
    target pixels of the fused images (module docstring), ``matched`` names them (the features' own: PCA
    fusions, or one side's bands combined by :func:`combined_for_matching`). ``trial(fu_ref, fu_tgt) ->
    (converged, median σ)`` runs LSM on a sample of the tie points: the combination is kept only when it
    converges on at least :data:`TRIAL_SHARE` as many and with a lower median σ (a combination fitted to a
    non-linear radiometric change can amplify noise or texture the other image lacks)."""
    n_ref, n_tgt = len(fu_ref.bands), len(fu_tgt.bands)
    if max(n_ref, n_tgt) < 2:
        return fu_ref, fu_tgt, {"lsm_on": f"{matched} (one band each)"}
    side = "reference" if n_ref >= n_tgt else "target"
    own, other = (fu_ref, fu_tgt) if side == "reference" else (fu_tgt, fu_ref)
    to_other = homography.forward if side == "reference" else homography.inverse
    bands = _bands(infos[0] if side == "reference" else infos[1], side, opts)
    comb = fit_combination(bands, np.asarray(own.mask, bool), own, to_other, other)
    if comb is None:
        return fu_ref, fu_tgt, {"lsm_on": f"{matched} (too little overlap to combine bands)"}
    report = {"combined": side, "weights": [round(float(w), 4) for w in comb.weights],
              "offset": round(comb.offset, 3), "correlation_pca": round(comb.correlation_pca, 4),
              "correlation_combined": round(comb.correlation, 4), "pixels": comb.n}
    if not comb.better:
        return fu_ref, fu_tgt, {"lsm_on": f"{matched} (combining the bands did not correlate better)", **report}
    new = combined_fusion(bands, np.asarray(own.mask, bool), own, comb)
    pair = (new, fu_tgt) if side == "reference" else (fu_ref, new)
    if trial is not None:
        (pca_n, pca_s), (new_n, new_s) = trial(fu_ref, fu_tgt), trial(*pair)
        report["trial"] = {"pca": {"converged": pca_n, "median_sigma_px": pca_s},
                           "combined": {"converged": new_n, "median_sigma_px": new_s}}
        if not (new_n >= TRIAL_SHARE * pca_n and (pca_s is None or (new_s is not None and new_s < pca_s))):
            return fu_ref, fu_tgt, {"lsm_on": f"{matched} (LSM on the combined bands was less precise on a "
                                              "trial)", **report}
    report["lsm_on"] = f"the {side}'s bands combined to match the other's fusion"
    return (*pair, report)


def combined_for_matching(infos, opts, fu_ref, fu_tgt, homography):
    """``(side, fusion, report)``: the bands of one image (the one with more bands fused; the reference when
    alike) combined to look like the other's PCA fusion through ``homography`` (reference -> target pixels of
    the images matched, from a weak first match), fitted on images smoothed by :data:`ROUGH_FIT_SMOOTHING`;
    ``(None, None, report)`` with ``report["refused"]`` when the overlap is too small, or the combination does
    not correlate better than the PCA fusion or not above :data:`REMATCH_MIN_CORRELATION` (the module docstring);
    None when both have one band."""
    n_ref, n_tgt = len(fu_ref.bands), len(fu_tgt.bands)
    if max(n_ref, n_tgt) < 2:
        return None
    side = "reference" if n_ref >= n_tgt else "target"
    own, other = (fu_ref, fu_tgt) if side == "reference" else (fu_tgt, fu_ref)
    to_other = homography.forward if side == "reference" else homography.inverse
    bands = _bands(infos[0] if side == "reference" else infos[1], side, opts).astype(np.float32)
    valid = np.asarray(own.mask, bool)
    blur = lambda a: cv2.GaussianBlur(np.asarray(a, np.float32), (0, 0), ROUGH_FIT_SMOOTHING)  # noqa: E731
    inner = cv2.erode(valid.astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool)  # no blurred border
    comb = fit_combination(np.stack([blur(b) for b in bands]), inner, replace(own, image=blur(own.image)),
                           to_other, replace(other, image=blur(other.image)))
    if comb is None:
        return None, None, {"combined": side, "refused": "too little overlap to combine bands"}
    report = {"combined": side, "weights": [round(float(w), 4) for w in comb.weights],
              "correlation_pca": round(comb.correlation_pca, 4), "correlation_combined": round(comb.correlation, 4)}
    if not comb.better or comb.correlation < REMATCH_MIN_CORRELATION:
        return None, None, {**report, "refused": f"the combined bands correlate {comb.correlation:.2f} with the "
                                                 f"other image (at least {REMATCH_MIN_CORRELATION} and more than "
                                                 "the PCA fusion needed)"}
    return side, combined_fusion(bands, valid, own, comb), report


def _hypotheses(kp_ref, kp_tgt, m, opts):
    """``(homography reference -> target pixels matched, inliers, their reference pixels)`` of the matches ``m``:
    RANSAC's, then RANSAC's again drawing on from the same generator (``opts.seed``) — each consensus once, at most
    :data:`REMATCH_TRIES` runs (module docstring); nothing when RANSAC finds no consensus."""
    src, dst = kp_ref.xy[m.pairs[:, 1]], kp_tgt.xy[m.pairs[:, 0]]
    rng, seen = np.random.default_rng(opts.seed), []
    for _ in range(REMATCH_TRIES):
        try:
            r = ransac(Projective, src, dst, opts.ransac_threshold, rng=rng)
        except FotogeoError:
            return
        if not any(np.array_equal(r.inliers, s) for s in seen):
            seen.append(r.inliers)
            yield r.model, int(r.inliers.sum()), src[r.inliers]


def _inliers(kp_ref, kp_tgt, m, opts):
    """The first of :func:`_hypotheses`, or ``(None, 0, None)``."""
    return next(_hypotheses(kp_ref, kp_tgt, m, opts), (None, 0, None))


def _combined_from_hypotheses(infos, opts, fused, hyps):
    """``(side, fusion, report, (H, n, at))`` of the first hypothesis of ``hyps`` (:func:`_hypotheses`) whose
    combination :func:`combined_for_matching` accepts; ``side`` and ``fusion`` None, with the first refusal's
    report and every try's outcome, when none is; None when both sides have one band."""
    tries, first = [], None
    for H, n, at in hyps:
        found = combined_for_matching(infos, opts, *fused, H)
        if found is None:
            return None
        side, new, report = found
        first = first or report
        tries.append({"inliers": n, "correlation_combined": report.get("correlation_combined"),
                      **({"refused": report["refused"]} if new is None else {"kept": True})})
        if new is not None:
            break
    if new is None:
        report = first
        if len(tries) > 1:
            report["refused"] += (f"; so did the {len(tries) - 1} next RANSAC hypotheses of the first match ("
                                  + ", ".join(f"{t['inliers']} inliers: {t['correlation_combined']}"
                                              for t in tries[1:]) + ")")
    if len(tries) > 1:
        report["hypotheses"] = tries
    return side, new, report, (H, n, at)


def _disagreement(H0, H1, xy) -> float:
    """``median_i ‖H₁(p_i) − H₀(p_i)‖`` over the points ``xy`` (pixels; a point mapped to infinity counts as
    infinitely far)."""
    d = np.hypot(*(np.asarray(H1.forward(xy), float) - np.asarray(H0.forward(xy), float)).T)
    return float(np.median(np.where(np.isfinite(d), d, np.inf)))


def _band_counts(infos, opts, fused) -> list:
    """The number of bands each side's fusion has (``fused`` a pair of fusions), or will have (``fused`` a callable
    not called yet: the bands :func:`.selection.select_bands` picks)."""
    if not callable(fused):
        return [len(f.bands) for f in fused]
    return [len(select_bands(getattr(opts, f"{role}_bands", None), info.count, role))
            for info, role in zip(infos, ("reference", "target"))]


def rematch(infos, opts, fused, kps, m):
    """``(fu_ref, fu_tgt, kp_ref, kp_tgt, matches, report)``: with one side's keypoints detected again on its
    bands combined to look like the other's fusion (:func:`combined_for_matching`) when a match with fewer
    than :data:`REMATCH_BELOW` homography inliers tried so passes the module docstring's checks (report with
    ``kept: true``); else the fusions, keypoints and matches given, with the report of the refusal
    (``kept: false``, ``refused``), or None when no re-match was tried. ``fused``: the two PCA fusions the
    keypoints were detected on, or a callable returning them, called only when a re-match is tried (keypoints
    from :class:`.match.FeatureCache`, which keeps no images; the fusions returned are None when not read).
    Cached keypoints are a block's frames (triangulate): a pair with as many bands on both sides is taken as one
    camera's and is not re-read (a weak match there is the overlap's or the viewpoint's, not the bands')."""
    lazy = callable(fused)
    given = ((None, None) if lazy else fused) + (*kps, m, None)
    counts = _band_counts(infos, opts, fused)
    if max(counts) < 2 or (lazy and counts[0] == counts[1]):
        return given
    hyps = _hypotheses(*kps, m, opts)
    H, n0, at = next(hyps, (None, 0, None))
    if H is None or n0 >= REMATCH_BELOW:
        return given
    if lazy:
        fused = tuple(fused())
        given = (*fused, *given[2:])
    found = _combined_from_hypotheses(infos, opts, fused, itertools.chain([(H, n0, at)], hyps))
    if found is None:
        return given
    side, new, report, (H, n, at) = found
    if new is None:
        return (*given[:-1], {**report, "inliers_before": n0, "kept": False})
    kp = detect(apply_contrast(new.image, new.mask, opts.contrast), new.mask, opts.detector,
                max_keypoints=opts.max_keypoints, hessian_threshold=opts.hessian_threshold)
    fu_ref, fu_tgt = (new, fused[1]) if side == "reference" else (fused[0], new)
    kp_ref, kp_tgt = (kp, kps[1]) if side == "reference" else (kps[0], kp)
    m2 = match_keypoints(kp_tgt, kp_ref, opts)
    H1, n1, _ = _inliers(kp_ref, kp_tgt, m2, opts) if len(m2) >= 6 else (None, 0, None)
    report.update(inliers_before=n0, inliers_after=n1)
    need = max(2 * max(n0, n), REMATCH_MIN_INLIERS)
    if n1 < need:
        return (*given[:-1], {**report, "kept": False, "refused": f"{n1} inliers after the re-match, {need} needed"})
    shift = _disagreement(H, H1, at)
    report["disagreement_px"] = round(shift, 2)
    if not shift <= REMATCH_AGREE_PX:
        return (*given[:-1], {**report, "kept": False,
                              "refused": f"the re-match's homography differs from the first match's by {shift:.1f} "
                                         f"px (median) at its {len(at)} inliers (at most {REMATCH_AGREE_PX} px)"})
    return fu_ref, fu_tgt, kp_ref, kp_tgt, m2, {**report, "kept": True}
