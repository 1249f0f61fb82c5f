"""Area-based matching inside the registration (:mod:`fotogeo.coreg`, the windows of ``fotogeo coreg``).

Two uses, both on a grid of windows matched by phase correlation + LSM on gradient-orientation
images (robust to seasonal and sensor radiometry):

- **tie points when feature matching fails** (``area_fallback``, on by default): too few matches
  or RANSAC inliers on a small, cloudy or multi-temporal scene. The windows are measured between
  the reference and the target *on the target's own grid*, so the target must be georeferenced
  within ``max_shift`` (5) of its pixels — the usual case for satellite scenes of one area. An
  unreferenced target is first given one by a coarse similarity (:mod:`.coarse`, Fourier–Mellin:
  any rotation, scale 0.4–2.5), refused when its confidence is low. A
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
from .coarse import pre_align
from . import match
from .match import HINT, band_numbers
from .points import TiePoints

#: the fallback's windows: at most the option's size, at least this, and small scenes get at least
#: three windows across their shorter side
MIN_FALLBACK_WINDOW = 32
#: a feature fit with fewer inliers is checked by the windows (:func:`matched_and_fitted`)
WEAK_INLIERS = match.WEAK_INLIERS


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


def matched_and_fitted(reference, target, ref, tgt, opts, prog, find, fit, given, refine):
    """``(tie points, their output positions, fit, refine note)``: feature matching (``find()``) and the
    model (``fit(pts)``); when matching fails, or its fit keeps fewer than :data:`WEAK_INLIERS` inliers
    (a homography through so few points may be wrong), the windows of :func:`area_tie_points` instead.
    When they fail too, the weak fit is refused, not kept: nothing confirms it, and such a fit can be many
    pixels off while its few points agree (``--no-area-fallback`` keeps it, as it skips the windows)."""
    try:
        pts = find()
        pts, dst, gf = fit(pts)
    except MatchingError as e:
        if given is not None or not opts.area_fallback:
            raise MatchingError(f"{e} — registering {str(target)!r} to {str(reference)!r}; {HINT}") from None
        pts = area_tie_points(reference, target, ref, tgt, opts, str(e),
                              prog.stage(0.0, 0.55, "feature matching failed: matching windows"))
        return (*fit(pts), "area-based windows (feature matching failed)")
    n = int(gf.inliers.sum())
    if given is not None or not opts.area_fallback or n >= WEAK_INLIERS:
        return pts, dst, gf, refine
    why = f"feature matching kept only {n} inliers (fewer than {WEAK_INLIERS})"
    try:
        area = area_tie_points(reference, target, ref, tgt, opts, why, prog.stage(0.0, 0.55, f"{why}: matching "
                                                                                             f"windows"))
        return (*fit(area), "area-based windows (feature matching too weak)")
    except (MatchingError, ModelError) as e:
        raise MatchingError(f"the feature fit of {n} inliers of {str(target)!r} is not confirmed, so none is "
                            f"written: {e} — {HINT}, or keep that fit with --no-area-fallback") from None


def area_tie_points(reference, target, ref, tgt, opts, why: str, progress=None) -> TiePoints:
    """Tie points from a grid of windows (module docstring); ``why`` is the feature matching's failure.
    An unreferenced target is first pre-aligned (:mod:`.coarse`: Fourier–Mellin similarity)."""
    bands = (first_band(opts.reference_bands), first_band(opts.target_bands))
    if tgt.georeferenced:
        return _window_tie_points(reference, target, ref, tgt, opts, why, bands, None, progress)
    with tempfile.TemporaryDirectory(prefix="fotogeo_pre_aligned_") as folder:
        try:
            vrt, aligned, coarse = pre_align(reference, target, ref, tgt, opts, folder, bands)
        except MatchingError as e:
            raise MatchingError(f"{why}; area-based matching could not step in: the target has no georeference "
                                f"and {e} (georeference it approximately, or give tie points)") from None
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
