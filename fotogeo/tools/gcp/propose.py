"""Automatic GCP candidates for the GCP picker (issue 14): an image against a georeferenced reference.

:func:`propose_gcps` uses the registration's own steps, not a copy of them:

1. tie points by :func:`fotogeo.tools.register.match.find_tie_points` (PCA fusion, SURF, ratio and mutual
   tests; Dihkan 2019) at their keypoint positions;
2. the registration's robust selection: without a DEM the planar one
   (:func:`fotogeo.models.robust.fit_tie_points`, image → map projective: RANSAC, Tukey IRLS);
   with a DEM the terrain-aware one (:func:`fotogeo.orientation.terrain.fit_terrain` with the
   DLT: the same prefilter, then a robust 3-D fit on DEM heights, so relief displacement is
   not mistaken for a mismatch);
3. a spread over the image: the image is cut into about ``count`` cells and each cell gives
   its best consistent pair first (:func:`fotogeo.tools.triangulate.match.thin_to_budget`),
   so the candidates cover the frame rather than its most textured part;
4. the chosen image positions refined by least-squares matching (Gruen 1985;
   :func:`fotogeo.tools.register.match.refine_lsm`, ``refine="lsm"`` by default), then scored anew.

``score`` = ``1 / (1 + (r / σ)²)`` in (0, 1], with ``r`` the pair's residual under the robust
fit and ``σ`` its robust standard deviation: 1 for a pair on the model, 0.5 at one σ.
Candidates: ``col``, ``row`` (image, corner convention), ``x``, ``y`` (the reference's map
coordinates, CRS given as WKT), ``score``, ``residual`` (``r``: image pixels with a DEM,
reference map units without). The user accepts or rejects them in the dock; nothing is written.
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import InputError
from ...io.raster import open_raster
from ...models import Projective
from ...models.robust import fit_tie_points
from ...options import RegisterOptions
from ...pixels import pixel_to_map
from ...progress import as_progress
from ..common.boundary import tool
from ..register.match import find_tie_points
from ..triangulate.match import thin_to_budget


def grid_shape(width: int, height: int, count: int) -> tuple[int, int]:
    """``(nx, ny)``: about ``count`` cells of about square shape over a ``width x height`` image."""
    nx = max(1, round(math.sqrt(count * width / max(height, 1))))
    return nx, max(1, math.ceil(count / nx))


def image_cells(xy, width: int, height: int, count: int) -> np.ndarray:
    """Index ``iy * nx + ix`` of the cell (:func:`grid_shape`) of each point."""
    nx, ny = grid_shape(width, height, count)
    ix = np.clip((np.asarray(xy)[:, 0] / width * nx).astype(int), 0, nx - 1)
    iy = np.clip((np.asarray(xy)[:, 1] / height * ny).astype(int), 0, ny - 1)
    return iy * nx + ix


def spread_best(xy, score, width: int, height: int, count: int) -> np.ndarray:
    """Indices of up to ``count`` points: one per cell first (best score), then a second per cell, …"""
    cell = image_cells(xy, width, height, count)
    ids = np.arange(len(xy))
    chosen = np.zeros(0, int)
    budget = 1
    while len(chosen) < min(count, len(xy)):
        kept = thin_to_budget(ids, np.zeros(len(ids), int), cell, -np.asarray(score, float), budget)
        new = np.setdiff1d(kept, chosen)
        new = new[np.argsort(-np.asarray(score)[new], kind="stable")][:count - len(chosen)]
        chosen = np.concatenate([chosen, new])
        budget += 1
    return chosen


def _robust(image_xy, XY, ref_px, opts, img, dem, crs, prog):
    """The registration's robust fit of the matched pairs: ``(consistent mask, residual(image_xy, idx),
    sigma, model name, heights or None)``; ``residual`` gives the length of the pairs' residuals."""
    from ..register.tool import _unfolded
    threshold = opts.ransac_threshold * ref_px
    if dem is None:
        fit = fit_tie_points(Projective, image_xy, XY, threshold=threshold, min_sigma=ref_px, check_fraction=0.0,
                             rng=opts.seed, is_valid=_unfolded(img.width, img.height))
        return (fit.inliers, lambda px, idx: np.hypot(*(fit.model.forward(px) - XY[idx]).T), fit.sigma,
                "projective", None)
    from ...orientation.terrain import fit_terrain
    from ..orient.rectify import dem_heights
    ground = np.column_stack([XY, np.asarray(dem_heights(dem, crs).heights(XY), float)])
    fit = fit_terrain(image_xy, ground, model="dlt", threshold_m=threshold, min_sigma_m=ref_px,
                      check_fraction=0.0, rng=opts.seed, is_valid=_unfolded(img.width, img.height), progress=prog)
    return (fit.inliers, lambda px, idx: np.hypot(*(fit.model.forward(ground[idx]) - px).T), fit.sigma_px, "dlt",
            ground[:, 2])


def refine_candidates(ref, img, opts, ref_xy, image_xy):
    """LSM-refined image positions of the chosen pairs (:func:`fotogeo.tools.register.match.refine_lsm`, on the
    images as matched) and its summary; refining only the candidates, not every match, saves most of the time."""
    from ..register.match import fused_for_matching, refine_lsm
    fu_ref, f_ref = fused_for_matching(ref, "reference", opts)
    fu_img, f_img = fused_for_matching(img, "target", opts)
    xy, summary = refine_lsm(fu_ref, fu_img, ref_xy / f_ref, image_xy / f_img)
    return xy * f_img, summary


@tool("REGISTER", rasters={"image": "target_nodata", "reference": "reference_nodata", "dem": None})
def propose_gcps(image, reference, *, count: int = 30, dem=None, progress=None, **options) -> dict:
    """GCP candidates for ``image`` from the georeferenced ``reference`` (module docstring).

    ``options`` are the registration's (:class:`~fotogeo.options.RegisterOptions`: detector,
    ratio, ransac_threshold, …; ``refine`` defaults to ``"lsm"`` here). Returns
    ``{"candidates": [...], "crs": WKT, "model", "matches", "consistent", "sigma", "lsm"}``.
    """
    from dataclasses import replace
    if not isinstance(count, int) or isinstance(count, bool) or count < 1:
        raise InputError(f"count {count!r} must be a whole number of at least 1")
    prog = as_progress(progress)
    opts = RegisterOptions(**{"refine": "lsm", **options})
    opts.validate()
    ref, img = open_raster(reference, "reference"), open_raster(image, "image")
    if not ref.georeferenced or ref.crs is None:
        raise InputError(f"reference {str(reference)!r} has no georeference (CRS and geotransform): GCP proposals "
                         f"need its map positions; choose a georeferenced raster such as an orthophoto")
    image_xy, ref_xy, counts = find_tie_points(ref, img, replace(opts, refine="none"), prog.stage(0.0, 0.7, "matching"))
    XY = pixel_to_map(ref.transform, ref_xy)
    ref_px = math.sqrt(abs(ref.transform.a * ref.transform.e - ref.transform.b * ref.transform.d))
    inl, residual, sigma, name, z = _robust(image_xy, XY, ref_px, opts, img, dem, ref.crs,
                                            prog.stage(0.7, 0.85, "robust fit"))
    idx = np.flatnonzero(inl)
    sigma = max(float(sigma), 1e-12)
    pick = idx[spread_best(image_xy[idx], 1.0 / (1.0 + (residual(image_xy[idx], idx) / sigma) ** 2), img.width,
                           img.height, count)]
    px, lsm = image_xy[pick], None
    if opts.refine == "lsm" and len(pick):
        prog(0.85, "least-squares matching of the candidates")
        px, lsm = refine_candidates(ref, img, opts, ref_xy[pick], px)
    r = residual(px, pick)
    candidates = [{"col": float(c), "row": float(w), "x": float(XY[i, 0]), "y": float(XY[i, 1]),
                   "score": float(1.0 / (1.0 + (ri / sigma) ** 2)), "residual": float(ri),
                   **({"z": float(z[i]) if np.isfinite(z[i]) else None} if z is not None else {})}
                  for (c, w), i, ri in zip(px, pick, r)]
    prog(1.0, f"{len(candidates)} GCP candidates")
    return {"candidates": candidates, "crs": ref.crs.to_wkt(), "model": name, "matches": int(counts["matches"]),
            "consistent": int(len(idx)), "sigma": sigma, "lsm": lsm}
