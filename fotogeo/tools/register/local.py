"""Area-based matching inside the registration (:mod:`fotogeo.coreg`, the windows of ``fotogeo coreg``).

Two uses, both on a grid of windows matched by phase correlation + LSM on gradient-orientation
images (robust to seasonal and sensor radiometry):

- **tie points when feature matching fails** (``area_fallback``, on by default): too few matches
  or RANSAC inliers on a small, cloudy or multi-temporal scene. The windows are measured between
  the reference and the target *on the target's own grid*, so the target must be georeferenced
  within ``max_shift`` (5) of its pixels — the usual case for satellite scenes of one area. An
  unreferenced target is first given one by a coarse similarity (:mod:`.coarse`, Fourier–Mellin:
  any rotation, scale 0.4–2.5), refused when its confidence is low. A weak feature fit (few inliers, or
  an imprecise one: :func:`corner_standard_error`) is followed by the windows started from that fit
  (:func:`.coarse.seed_from_fit`), and the fit closer to the windows' check points is kept. A
  reliable window at target position ``p`` with the composed shift ``d`` (target = reference +
  shift) is the tie point target pixel ``p + d`` ↔ the reference pixel of the map point of ``p``,
  with the window's LSM σ; the model is then fitted as for feature tie points.
- **the local field** (``local``): after the model, the target registered with cubic resampling
  (on the output grid) is co-registered to the reference: a smooth displacement field ``D``
  (global affine + thin-plate spline through the reliable windows;
  :func:`fotogeo.tools.coreg.tool.run_coregistration`) of what a global or terrain model leaves —
  residual relief, lens and scanner distortions. The output is then resampled once, through
  both: output pixel ``p`` takes the target at ``model⁻¹(p + D(p))``.
"""
from __future__ import annotations

import tempfile

import numpy as np

from ...crs import transform_points
from ...errors import MatchingError, ModelError
from ...pixels import map_to_pixel, pixel_to_map
from ..coreg.tool import CoregRun, coreg_options, run_coregistration
from .coarse import pre_align, seed_from_fit
from . import match
from .match import HINT, band_numbers
from .points import TiePoints

#: the fallback's windows: at most the option's size, at least this, and small scenes get at least
#: three windows across their shorter side
MIN_FALLBACK_WINDOW = 32
#: a feature fit with fewer inliers is checked by the windows (:func:`matched_and_fitted`)
WEAK_INLIERS = match.WEAK_INLIERS
#: a planar feature fit whose standard error at the target's corners (reference px) exceeds this is checked by the
#: windows too: 2.45 of it (the 95 % radius of a circular normal error) is then beyond the 1 px a registration
#: must meet
MAX_CORNER_SE_PX = 0.4


def first_band(bands: str | None) -> int:
    """The band area-based matching uses: the first of a ``*_bands`` option, else band 1."""
    numbers = band_numbers(bands, "bands")
    return int(numbers[0]) if numbers else 1


def fallback_windows(width: int, height: int, window: int, spacing: int) -> tuple[int, int]:
    """``(window, spacing)`` for a target of ``width`` x ``height`` px: the window at most a third of the
    shorter side (even, ≥ :data:`MIN_FALLBACK_WINDOW`), the spacing at most half the window.

    >>> fallback_windows(300, 300, 128, 64), fallback_windows(5000, 4000, 128, 64)
    ((100, 50), (128, 64))
    """
    w = max(MIN_FALLBACK_WINDOW, min(window, min(width, height) // 3) // 2 * 2)
    return w, max(4, min(spacing, w // 2))


def corner_standard_error(gf, pts, ref_px: float, width: int, height: int) -> float | None:
    """The standard error (reference px, per coordinate) of a planar fit's positions at the target's worst
    corner from its control points: ``σ · sqrt(max h)``, with ``h = 1/n + (c − x̄)ᵀ S⁻¹ (c − x̄)`` the leverage
    of an affine fit at a corner ``c`` (``S`` the scatter matrix of the control points' target positions;
    Draper & Smith 1998, ch. 3) and ``σ`` the tie points' own scatter, estimated from the residual differences
    of nearest neighbours, ``σ² = mean|rᵢ − r_nn(i)|² / 4`` (von Neumann 1941): a smooth misfit the model
    cannot follow (relief under a 2-D model) cancels between neighbours, so it does not count — more points
    cannot mend it. A projective fit has two parameters more, so this is a lower bound: few points, clustered
    points or a large scatter all raise it. None for a terrain fit or fewer than 4 points."""
    from scipy.spatial import cKDTree
    c = gf.role == "control"
    n = int(c.sum())
    if gf.z is not None or n < 4:
        return None
    x, r = pts.src[c], gf.residual_m[c] / ref_px
    nn = cKDTree(x).query(x, k=2)[1][:, 1]
    s = float(np.sqrt(np.mean(np.sum((r - r[nn]) ** 2, axis=1)) / 4))
    xc = x - x.mean(axis=0)
    S = xc.T @ xc
    if np.linalg.cond(S) > 1e12:
        return float("inf")
    d = np.array([[0, 0], [width, 0], [0, height], [width, height]], float) - x.mean(axis=0)
    h = 1.0 / n + np.einsum("ij,jk,ik->i", d, np.linalg.inv(S), d)
    return s * float(np.sqrt(h.max()))


def matched_and_fitted(reference, target, ref, tgt, opts, prog, find, fit, given, refine, ref_px):
    """``(tie points, their output positions, fit, refine note)``: feature matching (``find()``) and the
    model (``fit(pts)``). A feature fit is weak when it keeps fewer than :data:`WEAK_INLIERS` inliers (a
    homography through so few points may be wrong) or when its standard error at the target's corners
    (:func:`corner_standard_error`) exceeds :data:`MAX_CORNER_SE_PX`; a weak fit is followed by the windows of
    :func:`area_tie_points` — seeded from the fit when it has enough inliers, else as when matching fails —
    and of the two fits the one closer to the windows' check points (held out of the windows' fit, never used
    by the feature fit) is kept. When the windows fail too, the weak fit is refused: nothing confirms it
    (``--no-area-fallback`` keeps it, as it skips the windows). The decision is the keypoint matches' alone
    (``TiePoints.matched``): LSM windows of strong texture added at the approximate homography's prediction
    agree with that homography, right or wrong, so they refine a feature fit only once it is accepted."""
    try:
        found = find()
        pts, dst, gf = fit(found if found.matched is None else found.matched)
    except MatchingError as e:
        if given is not None or not opts.area_fallback:
            raise MatchingError(f"{e} — registering {str(target)!r} to {str(reference)!r}; {HINT}") from None
        pts = area_tie_points(reference, target, ref, tgt, opts, str(e),
                              prog.stage(0.0, 0.55, "feature matching failed: matching windows"))
        return (*fit(pts), "area-based windows (feature matching failed)")
    n = int(gf.inliers.sum())
    se = corner_standard_error(gf, pts, ref_px, tgt.width, tgt.height) if given is None else None
    weak = n < WEAK_INLIERS or (se is not None and se > MAX_CORNER_SE_PX)
    if se is not None and opts.area_fallback:
        pts.counts["corner_standard_error_px"] = se
    if given is not None or not opts.area_fallback or not weak:
        return (*_with_texture_windows(found, (pts, dst, gf), fit, weak), refine)
    if found.matched is not None:
        pts.counts["lsm"]["texture_windows_used"] = False
    why = (f"feature matching kept only {n} inliers (fewer than {WEAK_INLIERS})" if n < WEAK_INLIERS else
           f"the feature fit of {n} inliers is imprecise: standard error {se:.2f} reference px at the target's "
           f"corners (more than {MAX_CORNER_SE_PX})")
    seed = _fit_to_reference_px(gf, ref) if n >= WEAK_INLIERS and gf.z is None else None
    try:
        area = area_tie_points(reference, target, ref, tgt, opts, why, prog.stage(0.0, 0.55, "weak feature fit: "
                                                                                             "matching windows"),
                               seed=seed)
        won = fit(area)
    except (MatchingError, ModelError) as e:
        raise MatchingError(f"the feature fit of {n} inliers of {str(target)!r} is not confirmed, so none is "
                            f"written: {e} — {HINT}, or keep that fit with --no-area-fallback") from None
    return _better_supported((pts, dst, gf, refine), (*won, "area-based windows (weak feature fit)"), ref_px, se)


def _with_texture_windows(found, first, fit, weak: bool):
    """``first`` (the fit of the keypoint matches alone: tie points, output positions, fit) or, when the
    ``found`` tie points carry texture windows and that fit is not ``weak``, the fit with the windows (their
    converged LSM positions) included (:func:`matched_and_fitted`); the report's ``lsm.texture_windows_used``
    says which."""
    if found.matched is None:
        return first
    used = not weak
    if used:
        try:
            won = fit(found)
        except (MatchingError, ModelError):
            used = False
    first[0].counts["lsm"]["texture_windows_used"] = used
    return won if used else first


def _fit_to_reference_px(gf, ref):
    """The planar fit's map target pixel -> reference pixel."""
    geo = gf.georeference
    return lambda xy: map_to_pixel(ref.transform, transform_points(geo.crs, ref.crs, geo.pixel_to_map(xy)))


def _better_supported(feature, windows, ref_px: float, se):
    """Of a weak feature fit and the windows' fit, the one with the smaller RMSE at the windows' check points
    (reference px); the comparison goes into the report (``area_based.compared`` or ``windows_check``)."""
    pts, _, gf_w, _ = windows
    chk = gf_w.role == "check"
    f_gf = feature[2]
    if not chk.any() or f_gf.z is not None or gf_w.z is not None:
        return windows
    rms = lambda r: float(np.sqrt(np.mean(np.sum((r / ref_px) ** 2, axis=1))))  # noqa: E731
    w_rmse = rms(gf_w.residual_m[chk])
    f_rmse = rms(f_gf.model.forward(pts.src[chk]) - windows[1][chk])
    compared = {"at": f"{int(chk.sum())} check points of the windows' fit", "feature_fit_rmse_px": f_rmse,
                "windows_fit_rmse_px": w_rmse, "feature_fit_corner_se_px": se,
                "kept": "feature fit" if f_rmse <= w_rmse else "windows"}
    if f_rmse <= w_rmse:
        feature[0].counts["windows_check"] = {**compared, "windows": pts.counts["area_based"]}
        return feature
    pts.counts["area_based"]["compared"] = compared
    return windows


def area_tie_points(reference, target, ref, tgt, opts, why: str, progress=None, seed=None) -> TiePoints:
    """Tie points from a grid of windows (module docstring); ``why`` is the feature matching's failure.
    The windows start from the target's georeference, or from ``seed`` (a map target pixel -> reference
    pixel, :func:`.coarse.seed_from_fit`), or for an unreferenced target from a Fourier–Mellin pre-alignment
    (:mod:`.coarse`)."""
    bands = (first_band(opts.reference_bands), first_band(opts.target_bands))
    if tgt.georeferenced and seed is None:
        return _window_tie_points(reference, target, ref, tgt, opts, why, bands, None, progress)
    with tempfile.TemporaryDirectory(prefix="fotogeo_pre_aligned_") as folder:
        try:
            vrt, aligned, coarse = (seed_from_fit(target, ref, tgt, opts, folder, seed) if seed is not None else
                                    pre_align(reference, target, ref, tgt, opts, folder, bands))
        except MatchingError as e:
            raise MatchingError(f"{why}; area-based matching could not step in: the target has no georeference "
                                f"and {e} (georeference the target approximately, e.g. gdal_translate -a_srs CRS "
                                f"-a_ullr ULX ULY LRX LRY if it is north-up, or, rotated, gdal_edit.py -a_srs CRS "
                                f"-a_ulurll ULX ULY URX URY LLX LLY on a copy (its three corners), so the windows "
                                f"start from its place)") from None
        return _window_tie_points(reference, vrt, ref, aligned, opts, why, bands, coarse, progress)


def _window_tie_points(reference, target, ref, tgt, opts, why, bands, coarse, progress) -> TiePoints:
    window, spacing = fallback_windows(tgt.width, tgt.height, opts.local_window, opts.local_grid_spacing)
    copts = coreg_options(grid_spacing=spacing, window=window, seed=opts.seed)
    try:
        run = run_coregistration(reference, target, copts, reference_band=bands[0], target_band=bands[1],
                                 reference_nodata=opts.reference_nodata, target_nodata=opts.target_nodata,
                                 progress=progress)
    except MatchingError as e:  # coreg's advice names coreg's flags: register's own instead
        what = str(e).split(" — try ")[0]
        raise MatchingError(f"{why}; area-based matching did not help either: {what} ({window} px windows every "
                            f"{spacing} px, reference band {bands[0]}, target band {bands[1]}: try other bands "
                            f"first in --reference-bands/--target-bands, or --local-window/--local-grid-spacing)"
                            ) from None
    res = run.result
    ok = res.reliable
    p, d = res.windows.position[ok], res.windows.shift[ok]
    XY = pixel_to_map(tgt.transform, p)
    if tgt.crs != ref.crs:
        XY = transform_points(tgt.crs, ref.crs, XY)
    ref_xy = map_to_pixel(ref.transform, XY)
    scale = np.sqrt(abs(tgt.transform.determinant) / abs(ref.transform.determinant))
    sigma = np.hypot(*res.windows.sigma[ok].T) * scale
    windows = run.report["windows"]
    area = {"why": why, "window": window, "grid_spacing": spacing, "windows": windows,
            "representation": copts.representation,
            "note": "feature matching failed: the tie points are the reliable windows of an "
                    "area-based matching on the target's grid (fotogeo coreg)"}
    if coarse is not None:
        area["pre_alignment"] = coarse
    counts = {"keypoints": {"reference": None, "target": None}, "matches": int(ok.sum()),
              "pca_explained_variance": None, "area_based": area}
    return TiePoints(p + d, ref_xy, counts, sigma_px=np.where(np.isfinite(sigma), sigma, np.nan))


def local_correction(reference, raster, corrected, field, opts, progress=None) -> CoregRun:
    """Co-register the registered ``raster`` (output grid) to ``reference``; write the corrected
    raster to ``corrected`` (None: not written) and the displacement field to ``field`` (paths the
    caller commits)."""
    copts = coreg_options(grid_spacing=opts.local_grid_spacing, window=opts.local_window,
                          smoothing=opts.local_smoothing, seed=opts.seed)
    try:
        return run_coregistration(reference, raster, copts, output=corrected, field=field,
                                  resampling=opts.resampling,
                                  reference_band=first_band(opts.reference_bands),
                                  target_band=first_band(opts.target_bands), reference_nodata=opts.reference_nodata,
                                  progress=progress, window_option="local_window")
    except MatchingError as e:
        raise MatchingError(f"local co-registration (--local) refused: {e}; register without --local, or try a "
                            f"larger --local-window / --local-grid-spacing") from None
