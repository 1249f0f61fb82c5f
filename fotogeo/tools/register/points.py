"""The registration's tie points: matched, refined by least-squares matching, weighted, written.

Features give the approximation, LSM the precision (as in the source papers). With ``refine``
``"lsm"`` (``"auto"``, the default, is lsm for the 2-D and the terrain-aware registration:
:func:`refine_mode`):

1. the matches consistent with a robust homography between the two pixel sets (RANSAC + Tukey,
   the fit's own first step) are the candidates; at most :func:`lsm_budget` of them, spread over
   the target, are refined (time: LSM costs about as much per point as detection per 1000 pixels); with fewer
   than that, windows of strong texture (:func:`fotogeo.tools.register.texture.texture_points`) at the
   homography's prediction top them up (a detector finding few matches across bands leaves parts of the
   image without tie points otherwise). Those windows only refine a fit the matches make on their own:
   ``TiePoints.matched`` keeps the matches alone, from which the caller decides whether the feature fit is
   weak (:func:`fotogeo.tools.register.local.matched_and_fitted`) before the windows take part — windows placed
   at a wrong homography's prediction would agree with it; a window takes part only where its LSM converged
   (one that did not sits at the rough homography's prediction), none does when fewer than
   :data:`MIN_CONVERGED_SHARE` of them converged (changed ground between two dates), and whether the fit takes
   the converged points only (step 3) is the matches' rule;
2. :func:`fotogeo.tools.register.match.lsm_tie_points` refines each on the fused images as matched (affine
   geometry from the homography's Jacobian, bicubic, 15x15 window); on decimated images
   (``max_match_pixels``) each converged point is refined again at full resolution on windows
   read from the files (:func:`full_resolution_lsm`);
3. the fit takes the converged points only (a failed LSM says the keypoint position is doubtful),
   unless too few converged (then every match, as without LSM; the report says which), with the
   robust scale's floor lowered to a tenth of a reference pixel (wrong convergences are rejected)
   and weights ``balance / (σ² + s0²)`` (:func:`fit_points`).

Measured on known warps of real images (benchmarks/register_precision_bench.py): the dense error of
the model 0.003-0.03 reference px against 0.06-0.53 px without LSM and 0.015-0.13 px with SIFT
keypoints, at 1.0-1.25x the time.

The ``tie_points`` layer of ``OUT.gpkg`` carries per point its role, positions, residual and,
with LSM, ``sigma`` / ``sigma_px`` (the radial σ of its refined position, output CRS units and
reference pixels) and ``lsm_status``.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...errors import InputError, MatchingError, ModelError
from ...io.vector import (error_vectors, exaggeration_value, fitting_exaggeration, grid_means, legend_text,
                          nominal_scale, readable_subset, write_layers)
from ...matching import CONVERGED
from ...models import Projective
from ...models.robust import TieFit, balance_weights, select_tie_points, spread_split
from .bands import matched_fusions
from .match import find_tie_points, lsm_image, lsm_tie_points
from .texture import texture_points

#: at least this many converged LSM points (and this share of those tried) for the fit to use
#: converged points only
MIN_CONVERGED = 20
MIN_CONVERGED_SHARE = 0.25
#: LSM refines at most this many consistent tie points per megapixel matched (reference + target),
#: within [MIN_LSM_POINTS, MAX_LSM_POINTS], spread over the target; the others are left out of the
#: fit. Detection and description cost about 0.7 µs per pixel, LSM about 0.6 ms per point: this
#: keeps LSM near a third of the matching time (benchmarks/register_precision_bench.py)
LSM_POINTS_PER_MPX = 330
MIN_LSM_POINTS, MAX_LSM_POINTS = 150, 600
#: LSM window half size (window (2h+1)² pixels), step tolerance (px) and largest move (px)
LSM_HALF_WINDOW = 7
LSM_TOLERANCE = 1e-2
LSM_MAX_SHIFT = 3.0
#: tie points LSM runs on to choose between the PCA fusions and the combined bands (:mod:`.bands`)
TRIAL_POINTS = 60
#: status of consistent tie points beyond the MAX_LSM_POINTS refined
NOT_PICKED = "not refined (enough points refined)"
#: status of matches the approximate homography calls mismatches
INCONSISTENT = "not refined (inconsistent with the approximate homography)"


@dataclass(frozen=True)
class TiePoints:
    """Tie points of a registration (row i = match i), full-resolution pixels, corner convention."""

    src: np.ndarray  # (N, 2) target pixels: refined where LSM converged
    ref_xy: np.ndarray  # (N, 2) reference pixels
    counts: dict  # keypoints, matches, PCA, bands, "lsm" summary: report entries
    sigma_px: np.ndarray | None = None  # (N,) radial σ of the refined position, reference pixels (NaN: none)
    status: np.ndarray | None = None  # (N,) LSM status
    usable: np.ndarray | None = None  # (N,) bool: may take part in the fit (None: all)
    matched: "TiePoints | None" = None  # with texture windows: the keypoint matches alone (their own ``usable``)

    def subset(self, keep) -> "TiePoints":
        """The tie points ``keep`` (a boolean mask), ``usable`` and ``matched`` reset."""
        return replace(self, usable=None, matched=None,
                       **{k: None if getattr(self, k) is None else getattr(self, k)[keep]
                                             for k in ("src", "ref_xy", "sigma_px", "status")})


def refine_mode(refine: str) -> str:
    """The refinement a registration uses: ``refine`` itself, ``"lsm"`` for ``"auto"`` — for the 2-D and the
    terrain-aware registration alike (the 3-D model is chosen by blocked cross-validation, which precise tie
    points do not mislead: ``fotogeo.orientation.terrain``).

    >>> refine_mode("auto"), refine_mode("none"), refine_mode("lsm")
    ('lsm', 'none', 'lsm')
    """
    return "lsm" if refine == "auto" else refine


def tie_points(opts, ref, tgt, prog, given=None, refine: str | None = None) -> TiePoints:
    """Matched (and with ``refine`` (:func:`refine_mode`) ``"lsm"`` refined) tie points, or the
    ``given`` ones ``(target_xy, reference_xy)`` as they are."""
    if given is not None:
        src, ref_xy = (np.asarray(a, float).reshape(-1, 2) for a in given)
        if len(src) != len(ref_xy):
            raise InputError("tie_points must be two (N, 2) arrays of equal length: target and reference pixels")
        counts = {"keypoints": {"reference": None, "target": None}, "matches": len(src),
                  "pca_explained_variance": None, "tie_points_given": True}
        return TiePoints(src, ref_xy, counts)
    lsm = (refine or refine_mode(opts.refine)) == "lsm"
    found = find_tie_points(ref, tgt, opts, prog.stage(0.0, 0.5 if lsm else 0.55, "matching"), images=lsm)
    if not lsm:
        return TiePoints(*found)
    src, ref_xy, counts, (fu_ref, fu_tgt, f_ref, f_tgt) = found
    prog(0.5, "least-squares matching of the tie points")
    with prog.timed("refine_lsm"):
        return _refine(src, ref_xy, counts, (ref, tgt), fu_ref, fu_tgt, np.asarray(f_ref, float),
                       np.asarray(f_tgt, float), opts)


def lsm_budget(pixels: int) -> int:
    """How many tie points LSM refines when ``pixels`` (reference + target) were matched.

    >>> lsm_budget(300 * 300 * 2), lsm_budget(640 * 600 + 791 * 718), lsm_budget(16_000_000)
    (150, 314, 600)
    """
    return int(np.clip(round(LSM_POINTS_PER_MPX * pixels / 1e6), MIN_LSM_POINTS, MAX_LSM_POINTS))


def _refine(src, ref_xy, counts, infos, fu_ref, fu_tgt, f_ref, f_tgt, opts) -> TiePoints:
    """LSM of the consistent matches (module docstring), at most :data:`MAX_LSM_POINTS` of them, topped up by
    texture windows; on decimated images a second LSM at full resolution from the first one's result."""
    t_m, r_m = src / f_tgt, ref_xy / f_ref  # in the pixels of the images matched
    n_matches = len(src)
    status = np.full(n_matches, INCONSISTENT, dtype=object)
    try:  # the consistent matches: RANSAC homography + Tukey refit, as the fit's own first step
        sel = select_tie_points(Projective, r_m, t_m, threshold=opts.ransac_threshold, min_sigma=1.0,
                                check_fraction=0.0, rng=opts.seed)
    except (MatchingError, ModelError):
        counts["lsm"] = {"refined": 0, "of": n_matches, "note": "too few consistent matches to start LSM from",
                         "fit_uses": "every match"}
        return TiePoints(src, ref_xy, counts)
    cand, H = sel.inliers, sel.ransac.model
    again = counts.get("bands_rematched")
    again = again if again and again.get("kept") else None
    fu_ref, fu_tgt, bands = matched_fusions(infos, opts, fu_ref, fu_tgt, H,
                                            _lsm_trial(r_m[cand], t_m[cand], H, opts.seed),
                                            f"the {again['combined']}'s bands combined as matched" if again else
                                            "PCA fusions")
    pick = cand.copy()
    budget = lsm_budget(fu_ref.image.size + fu_tgt.image.size)
    if cand.sum() > budget:
        idx = np.flatnonzero(cand)
        pick[idx] = spread_split(t_m[idx], budget / len(idx), opts.seed)
    status[cand & ~pick] = NOT_PICKED
    extra = texture_points(lsm_image(fu_ref), r_m[pick], budget - int(pick.sum()), LSM_HALF_WINDOW)
    if len(extra):  # fewer matches than the budget: windows of strong texture at the homography's prediction
        t_x = H.forward(extra)
        src, ref_xy = np.vstack([src, t_x * f_tgt]), np.vstack([ref_xy, extra * f_ref])
        t_m, r_m = np.vstack([t_m, t_x]), np.vstack([r_m, extra])
        status = np.concatenate([status, np.full(len(extra), "", dtype=object)])  # LSM sets every one
        cand, pick = (np.concatenate([a, np.ones(len(extra), bool)]) for a in (cand, pick))
    pts = lsm_tie_points(fu_ref, fu_tgt, r_m[pick], t_m[pick], homography=H, prefilter=np.inf,
                         half_window=LSM_HALF_WINDOW, max_shift=LSM_MAX_SHIFT, tolerance=LSM_TOLERANCE)
    status[pick] = pts.status
    xy, sigma_px = t_m.copy(), np.full(len(src), np.nan)
    xy[pick] = pts.xy
    sigma_px[pick] = pts.sigma / pts.scale * float(np.mean(f_ref))  # target px matched -> reference px
    ok = status == CONVERGED
    full = _full_resolution_pass(infos, opts, (fu_ref, fu_tgt), pts.jacobian[ok[pick]], ok, ref_xy, xy, sigma_px,
                                 f_ref, f_tgt)
    m = np.arange(len(src)) < n_matches  # the keypoint matches; the rest are texture windows
    enough = _enough(ok[m], pick[m])  # the matches' own rule; a window takes part only where LSM converged
    counts["lsm"] = _lsm_summary(status, ok, pick, cand, m, enough, budget, xy - t_m, sigma_px, bands, f_ref,
                                 f_tgt, full)
    return _tie_points(xy * f_tgt, ref_xy, counts, sigma_px, status.astype(str), ok, m, enough)


def _full_resolution_pass(infos, opts, fused, jacobian, ok, ref_xy, xy, sigma_px, f_ref, f_tgt) -> dict | None:
    """On decimated images, LSM of the ``ok`` points again at full resolution (:func:`full_resolution_lsm`)
    from the first LSM's ``jacobian`` (one per ``ok`` point); ``xy`` (pixels matched) and ``sigma_px`` take the
    result where it converged. Returns the report's ``full_resolution`` entry, None when nothing was decimated."""
    if max(f_ref.max(), f_tgt.max()) <= 1.0 + 1e-6 or not ok.any():
        return None
    idx = np.flatnonzero(ok)
    J = jacobian * f_tgt[None, :, None] / f_ref[None, None, :]
    fr = full_resolution_lsm(infos, opts, fused, ref_xy[idx], xy[idx] * f_tgt, J)
    better = fr.converged
    xy[idx[better]] = fr.xy[better] / f_tgt
    sigma_px[idx[better]] = fr.sigma[better] / fr.scale[better]
    return {"refined": int(better.sum()), "of": int(len(idx)),
            "median_sigma_px": float(np.median(sigma_px[idx[better]])) if better.any() else None,
            "note": "the others keep the position and σ of the LSM on the decimated images"}


def _lsm_summary(status, ok, pick, cand, m, enough, budget, moved_m, sigma_px, bands, f_ref, f_tgt, full) -> dict:
    """The report's ``lsm`` entry: counts per status, median σ and shift, what the fit uses (``m``: the keypoint
    matches, the rest texture windows; ``moved_m``: LSM's shifts in target pixels matched)."""
    words, k = np.unique(status.astype(str), return_counts=True)
    moved = np.hypot(*moved_m[ok].T) * float(np.mean(f_tgt))
    n, n_matches = len(status), int(m.sum())
    return {
        "refined": int(ok.sum()), "of": int(n), "tried": int(pick.sum()), "consistent": int(cand.sum()),
        "budget": budget, "texture_windows": int(n - n_matches),
        "status": dict(zip(words.tolist(), k.tolist())),
        "median_sigma_px": float(np.median(sigma_px[ok])) if ok.any() else None,
        "median_shift_target_px": float(np.median(moved)) if ok.any() else None,
        "half_window": LSM_HALF_WINDOW, "bands": bands, "matched_at_factor": {"reference": float(np.mean(f_ref)),
                                                              "target": float(np.mean(f_tgt))},
        **({"full_resolution": full} if full else {}),
        "fit_uses": "the converged points" if enough else
                    f"every match: only {int(ok[m].sum())} of {int(pick[m].sum())} LSM runs converged"
                    + (" (texture windows: the converged ones)" if n > n_matches else "")}


def _tie_points(src, ref_xy, counts, sigma_px, status, ok, m, enough) -> TiePoints:
    """The refined tie points: ``usable`` the converged ones (``enough``) or every match and the converged
    windows; texture windows are left out when fewer than :data:`MIN_CONVERGED_SHARE` of them converged
    (changed ground between two dates), and ``matched`` keeps the keypoint matches ``m`` alone."""
    if m.all():
        return TiePoints(src, ref_xy, counts, sigma_px, status, ok if enough else None)
    counts["lsm"]["texture_windows_converged"] = int(ok[~m].sum())
    if ok[~m].mean() < MIN_CONVERGED_SHARE:  # most windows on changed ground (two dates): none of them is used
        counts["lsm"]["texture_windows_used"] = False
        ok = ok & m
    pts = TiePoints(src, ref_xy, counts, sigma_px, status, ok if enough else ok | m)
    if not ok[~m].any():
        return pts
    return replace(pts, matched=replace(pts.subset(m), usable=ok[m] if enough else None))


def _enough(ok, pick) -> bool:
    """Whether the fit takes the converged points only: :data:`MIN_CONVERGED` of them and
    :data:`MIN_CONVERGED_SHARE` of the ``pick`` tried."""
    return bool(ok.sum() >= max(MIN_CONVERGED, MIN_CONVERGED_SHARE * pick.sum()))


def _lsm_trial(r_m, t_m, homography, seed):
    """``trial(fu_ref, fu_tgt) -> (converged, median σ px)``: LSM of at most :data:`TRIAL_POINTS` of the
    consistent matches ``r_m -> t_m`` (spread over the target) on the fused images given."""
    idx = np.flatnonzero(spread_split(t_m, min(1.0, TRIAL_POINTS / max(len(t_m), 1)), seed))

    def trial(fu_ref, fu_tgt):
        pts = lsm_tie_points(fu_ref, fu_tgt, r_m[idx], t_m[idx], homography=homography, prefilter=np.inf,
                             half_window=LSM_HALF_WINDOW, max_shift=LSM_MAX_SHIFT, tolerance=LSM_TOLERANCE)
        ok = pts.status == CONVERGED
        return int(ok.sum()), (float(np.median(pts.sigma[ok])) if ok.any() else None)
    return trial


def full_resolution_lsm(infos, opts, fused, ref_xy, tgt_xy, jacobian):
    """LSM of ``ref_xy`` -> ``tgt_xy`` (N, 2, full-resolution pixels, ``tgt_xy`` already within a
    fraction of a pixel) on full-resolution windows of the two files, fused as the decimated images
    were (:func:`fotogeo.tools.register.match.fused_windows`), laid out side by side in one image per file
    (NaN gutters) so that :func:`fotogeo.matching.lsm_many` refines them all at once."""
    from ...matching import lsm_many
    from .match import LsmPoints, fused_windows
    h = LSM_HALF_WINDOW
    stretch = float(np.clip(np.nanmax(np.linalg.norm(jacobian, ord=2, axis=(1, 2))), 1.0, 8.0))
    rr, rt = h + 4, int(np.ceil((h + 4) * stretch + LSM_MAX_SHIFT + 3))
    o_ref, o_tgt = np.floor(ref_xy).astype(int) - rr, np.floor(tgt_xy).astype(int) - rt
    a_ref, off_ref = _side_by_side(fused_windows(infos[0], "reference", opts, fused[0], o_ref, 2 * rr + 1))
    a_tgt, off_tgt = _side_by_side(fused_windows(infos[1], "target", opts, fused[1], o_tgt, 2 * rt + 1))
    res = lsm_many(a_ref, a_tgt, ref_xy - o_ref + off_ref, tgt_xy - o_tgt + off_tgt, half_window=h,
                   approx_jacobian=np.nan_to_num(jacobian, nan=1.0), max_shift=LSM_MAX_SHIFT, tolerance=LSM_TOLERANCE)
    A = res.affine[:, :, :2]
    return LsmPoints(res.xy - off_tgt + o_tgt, np.hypot(*res.sigma.T),
                     np.sqrt(np.abs(A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0])), res.status, A)


def _side_by_side(chips: np.ndarray):
    """``(image, offsets)``: the (N, s, s) ``chips`` on a grid with one NaN pixel between them; chip k's
    pixel (col, row) is the image's ``(col, row) + offsets[k]``."""
    n, s = chips.shape[0], chips.shape[1]
    cols = max(1, int(np.ceil(np.sqrt(n))))
    rows = int(np.ceil(n / cols))
    img = np.full((rows * (s + 1) + 1, cols * (s + 1) + 1), np.nan, np.float32)
    k = np.arange(n)
    off = np.column_stack([1 + (k % cols) * (s + 1), 1 + (k // cols) * (s + 1)])
    for (x, y), chip in zip(off, chips):
        img[y:y + s, x:x + s] = chip
    return img, off.astype(float)


#: floor of the model's own scatter s0 in the σ weights (reference pixels)
MIN_S0_PX = 0.01


#: with LSM-refined tie points, the robust scale's floor is this share of ``min_sigma`` (1 reference px)
PRECISE_MIN_SIGMA = 0.1


def fit_points(model_cls, src, dst, sigma, *, threshold, min_sigma, check_fraction, rng, is_valid, precise=False,
               unit=""):
    """The 2-D registration's fit: :func:`fotogeo.models.robust.select_tie_points` (RANSAC, Tukey,
    spread check points), then least squares on the control points with the spatial balance
    weights — divided, when LSM gave each point its σ (``sigma`` (N,), output CRS units), by
    ``σᵢ² + s0²``: s0² is the scatter the σ do not explain (residual scale of the balanced fit
    squared minus the median σᵢ², at least (:data:`MIN_S0_PX` reference px)²), so a precise point
    counts more than a doubtful one, and where the model's misfit dominates (relief) the weights
    stay the balance weights. Returns ``(TieFit, weights entry of the report or None)``."""
    floor = min_sigma * (PRECISE_MIN_SIGMA if precise else 1.0)
    sel = select_tie_points(model_cls, src, dst, threshold=threshold, min_sigma=floor,
                            check_fraction=check_fraction, rng=rng, is_valid=is_valid, unit=unit)
    c = sel.control
    w = balance_weights(src[c])
    model = model_cls.estimate(src[c], dst[c], w)
    info = None
    if sigma is not None and np.isfinite(sigma[c]).all():
        r = np.hypot(*(model.forward(src[c]) - dst[c]).T)
        s2 = sigma[c] ** 2
        floor = MIN_S0_PX * min_sigma
        s0 = float(np.sqrt(max((1.4826 * np.median(r)) ** 2 - np.median(s2), floor ** 2)))
        w = w / (s2 + s0 ** 2)
        model = model_cls.estimate(src[c], dst[c], w)
        info = {"by": "spatial balance / (σ² + s0²)", "s0_px": s0 / min_sigma,
                "max_over_median": float(np.max(w) / np.median(w))}
    resid = model.forward(src) - dst
    return TieFit(model, sel.inliers, sel.role.astype(str), resid, int(sel.ransac.inliers.sum()), sel.ransac.trials,
                  sel.sigma), info


def write_vectors(path, fit, pts: TiePoints, dst, ref_px, crs, exaggeration) -> dict:
    """The GeoPackage of tie points, error vectors and the mean-residual grid; returns the
    exaggeration entry of the report (k, how it was chosen, the legend sentence)."""
    import shapely
    src, ref_xy = pts.src, pts.ref_xy
    keep = fit.inliers
    idx = np.flatnonzero(keep)
    d = fit.residual_m[keep]
    xy = dst[keep]
    length = np.hypot(d[:, 0], d[:, 1])
    k, how = exaggeration_value(exaggeration, float(np.median(length)) if len(length) else 0.0, xy)
    shown = np.zeros(len(xy), bool)  # per role, one arrow per cell drawn at full extent; the grid: the mean field
    for r in np.unique(fit.role[keep]):
        shown[fit.role[keep] == r] = readable_subset(xy[fit.role[keep] == r])
    if how == "auto":
        k = fitting_exaggeration(k, length[shown], xy)
    scale = nominal_scale(xy)
    legend = legend_text(k, scale)
    common = {"id": idx.astype(np.int64), "role": fit.role[keep],
              "ref_x": xy[:, 0], "ref_y": xy[:, 1], "ref_col": ref_xy[keep, 0], "ref_row": ref_xy[keep, 1],
              "target_col": src[keep, 0], "target_row": src[keep, 1]}
    if fit.z is not None:
        common["z"] = fit.z[keep]
    lsm = {}
    if pts.status is not None:
        lsm = {"sigma": pts.sigma_px[keep] * ref_px, "sigma_px": pts.sigma_px[keep],
               "lsm_status": pts.status[keep].astype(str)}
    g = grid_means(xy, d)
    layers = {
        "tie_points": {**common, "dx": d[:, 0], "dy": d[:, 1], "residual": length,
                       "residual_px": length / ref_px, **lsm, "geometry": shapely.points(xy)},
        "error_vectors": {"id": common["id"], "role": common["role"], "dx": d[:, 0], "dy": d[:, 1],
                          "length": length, "shown": shown.astype(np.int64), "exaggeration": np.full(len(idx), k),
                          "legend": [legend] * len(idx),
                          "geometry": error_vectors(xy, xy + d, k)},
        "error_grid": {**{c: g[c] for c in ("cell_col", "cell_row", "n", "mean_dx", "mean_dy", "length", "rms")},
                       "exaggeration": np.full(len(g["n"]), k), "legend": [legend] * len(g["n"]),
                       "geometry": error_vectors(np.column_stack([g["x"], g["y"]]).reshape(-1, 2),
                                                 np.column_stack([g["x"] + g["mean_dx"], g["y"] + g["mean_dy"]])
                                                 .reshape(-1, 2), k)},
    }
    what = f"Error vectors drawn {legend}"
    write_layers(path, layers, crs.to_wkt(), {"error_vectors": what + ".",
                                              "error_grid": f"Mean residual per grid cell, {what}."})
    return {"factor": k, "chosen": how, "map_scale": scale, "legend": legend, "grid_cells": int(len(g["n"])),
            "arrows_drawn": int(shown.sum())}
