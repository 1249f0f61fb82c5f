"""Robust model fit on tie points with a spatially spread check-point hold-out (array layer).

:func:`select_tie_points` is the one robust selection of tie points, shared by the 2-D
registration (:func:`fit_tie_points`) and the terrain-aware one
(:func:`fotogeo.orientation.terrain.fit_terrain`, which then fits its 3-D candidates on the
selection):

1. :func:`~fotogeo.models.ransac` with ``threshold`` (destination units) gives a first model
   and rejects gross mismatches; samples whose model fails ``is_valid`` (a homography that
   folds the image) are rejected per sample;
2. :func:`~fotogeo.models.robust_refit` (Tukey IRLS over all pairs, cut-off ``c`` robust
   standard deviations) lets every correct match take part — over relief the correct matches
   deviate from a plane-to-plane model by far more than a tight RANSAC threshold; pairs not
   ``usable`` (e.g. without a DEM height) are dropped, and an optional ``refine`` step (the
   terrain path's 3-D robust fit) narrows the consistent pairs further;
3. a seeded, spatially spread ``check_fraction`` of the consistent pairs is held out
   (:func:`spread_split`), provided at least ``min_control`` control points remain.

:func:`fit_tie_points` then fits the final model by least squares on the control points
only, each weighted by ``1 / (control points in its grid cell)`` (:func:`balance_weights`)
so that every part of the image counts alike, however unevenly texture spread the matches.
Over relief, where no plane-to-plane model is exact, this is what brings the fit close to
the best model over the whole image rather than the best one for its most textured part
(measured on the NGI frames: 1.05–1.12x the best homography, against 1.3–1.45x for the
Tukey-weighted fit). Residuals ``d = model(src) − dst`` and ``RMSE = sqrt(1/n Σ (dx² + dy²))``
(:func:`~fotogeo.models.stats.rmse`) are given for the control and the check points separately.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MatchingError, ModelError
from .ransac import RansacResult, ransac, robust_refit
from .stats import rmse


@dataclass(frozen=True)
class TieFit:
    model: object
    inliers: np.ndarray  # (N,) bool over all input pairs
    role: np.ndarray  # (N,) str: 'control', 'check' or 'outlier'
    residual_xy: np.ndarray  # (N, 2) model(src) - dst
    ransac_inliers: int
    ransac_trials: int
    sigma: float

    def rmse(self, role: str) -> float:
        return rmse(self.residual_xy[self.role == role])

    def count(self, role: str) -> int:
        return int(np.count_nonzero(self.role == role))


def cell_ids(xy: np.ndarray, cells: int) -> np.ndarray:
    """Index of the ``cells x cells`` grid cell (over the points' bounding box) of each point."""
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    ij = np.minimum((cells * (xy - lo) / span).astype(int), cells - 1)
    return ij[:, 1] * cells + ij[:, 0]


def spread_split(xy: np.ndarray, fraction: float, rng, cells: int | None = None) -> np.ndarray:
    """Boolean mask choosing about ``fraction`` of the points, spread over a grid of cells.

    Points are binned into a ``cells x cells`` grid over their bounding box; each cell gives
    up ``round(fraction * count)`` of its points (randomly, seeded), with the rounding
    remainder distributed so the total is ``round(fraction * N)``.
    """
    n = len(xy)
    chosen = np.zeros(n, bool)
    total = int(round(fraction * n))
    if total <= 0 or n == 0:
        return chosen
    rng = np.random.default_rng(rng)
    cell = cell_ids(xy, cells or max(1, int(np.sqrt(n / 4))))
    order = rng.permutation(n)
    rank = np.empty(n)
    for c in np.unique(cell):  # rank of each point within its cell, in random order
        members = order[cell[order] == c]
        rank[members] = (np.arange(len(members)) + rng.random()) / len(members)
    chosen[np.argsort(rank, kind="stable")[:total]] = True
    return chosen


def balance_weights(xy: np.ndarray, cells: int = 8) -> np.ndarray:
    """Weights ``1 / n_cell`` for points binned into a ``cells x cells`` grid over their extent."""
    cell = cell_ids(xy, cells)
    return 1.0 / np.bincount(cell, minlength=cells * cells)[cell]


@dataclass(frozen=True)
class TieSelection:
    """The consistent tie points and, among them, the held-out check points (module doc)."""

    inliers: np.ndarray  # (N,) bool: consistent pairs
    is_check: np.ndarray  # (N,) bool: held out as check points
    ransac: RansacResult
    prefilter_inliers: int  # consistent (and usable) pairs after step 2, before ``refine``
    sigma: float  # robust standard deviation of the last robust step

    @property
    def control(self) -> np.ndarray:
        return self.inliers & ~self.is_check

    @property
    def role(self) -> np.ndarray:
        """(N,) object array: 'control', 'check' or 'outlier'."""
        role = np.full(len(self.inliers), "outlier", dtype=object)
        role[self.control] = "control"
        role[self.is_check] = "check"
        return role


#: a robust fit keeping at least this fraction of the pairs ...
SWALLOWED_FRACTION = 0.95
#: ... with an RMSE above this many RANSAC thresholds has fitted nothing: refused
SWALLOWED_RMSE = 10.0


def refuse_swallowed_fit(model_cls, residuals, inliers, threshold: float):
    """Refuse a fit that calls (nearly) every pair an inlier while its RMSE over them is far
    above the RANSAC ``threshold``: the robust scale has grown to swallow every residual, so
    the inliers mean nothing (a model that cannot describe the geometry, e.g. a similarity
    without the mirror of pixel → map, returned kilometres of error with every match kept).
    """
    r = np.asarray(residuals, float)[np.asarray(inliers, bool)]
    frac = len(r) / max(1, len(inliers))
    if len(r) < 3 or frac < SWALLOWED_FRACTION:
        return
    err = float(np.sqrt(np.mean(r ** 2)))
    if err > SWALLOWED_RMSE * threshold:
        raise ModelError(f"the {model_cls.name} model does not describe these tie points: {frac:.0%} of them are "
                         f"kept as inliers but their RMSE is {err:.4g}, {err / threshold:.0f}x the RANSAC threshold "
                         f"{threshold:.4g}; use a model that fits the geometry (e.g. projective, or a DEM and a 3-D "
                         f"model) or check the tie points")


def select_tie_points(model_cls, src, dst, *, threshold: float, min_sigma: float, check_fraction: float = 0.3,
                      rng=0, max_trials: int = 5000, c: float = 6.0, usable=None, refine=None,
                      min_consistent: int | None = None, min_control: int | None = None, is_valid=None,
                      what: str | None = None, unit: str = "") -> TieSelection:
    """Steps 1-3 of the module docstring on pairs ``src -> dst`` with a ``model_cls`` prefilter.

    ``usable`` (N,) bool marks pairs that may be kept at all; ``refine(inliers) -> (inliers,
    sigma)`` narrows the consistent pairs; at least ``min_consistent`` (default
    ``min_points + 2``) must remain (else :class:`MatchingError` naming ``what``), and check
    points are held out only if ``min_control`` (default the same) control points remain.
    """
    src, dst = np.asarray(src, float), np.asarray(dst, float)
    rng = np.random.default_rng(rng)
    need = min_consistent or model_cls.min_points + 2
    rs = ransac(model_cls, src, dst, threshold, rng=rng, max_trials=max_trials,
                min_inliers=model_cls.min_points + 2, is_valid=is_valid, unit=unit)
    rob = robust_refit(model_cls, src, dst, rs.model, min_sigma=min_sigma, c=c)
    refuse_swallowed_fit(model_cls, rob.model.residuals(src, dst), rob.inliers, threshold)
    inl = rob.inliers if usable is None else rob.inliers & usable
    n_pre = int(inl.sum())
    if n_pre < need:
        raise MatchingError(f"only {n_pre} consistent {what or f'tie points for a {model_cls.name} model'} "
                            f"(at least {need} needed)")
    sigma = rob.sigma
    if refine is not None:
        inl, sigma = refine(inl)
    idx = np.flatnonzero(inl)
    n_inl = len(idx)
    frac = check_fraction if n_inl - int(round(check_fraction * n_inl)) >= (min_control or need) else 0.0
    is_check = np.zeros(len(src), bool)
    is_check[idx] = spread_split(src[idx], frac, rng)
    return TieSelection(inl, is_check, rs, n_pre, sigma)


def fit_tie_points(model_cls, src, dst, *, threshold: float, min_sigma: float,
                   check_fraction: float = 0.3, rng=0, max_trials: int = 5000, c: float = 6.0,
                   balance: bool = True, is_valid=None) -> TieFit:
    """Fit ``model_cls`` to tie points ``src -> dst`` (see the module docstring).

    ``c`` is the Tukey cut-off in robust standard deviations separating correct matches from
    false ones; ``balance`` turns the spatial balancing of the final fit on or off;
    ``is_valid(model) -> bool`` rejects RANSAC samples (e.g. ``lambda m: not m.folds(outline)``).
    """
    src = np.asarray(src, float)
    dst = np.asarray(dst, float)
    sel = select_tie_points(model_cls, src, dst, threshold=threshold, min_sigma=min_sigma,
                            check_fraction=check_fraction, rng=rng, max_trials=max_trials, c=c, is_valid=is_valid)
    control = sel.control
    w = balance_weights(src[control]) if balance else None
    model = model_cls.estimate(src[control], dst[control], w)
    resid = model.forward(src) - dst
    return TieFit(model, sel.inliers, sel.role.astype(str), resid, int(sel.ransac.inliers.sum()),
                  sel.ransac.trials, sel.sigma)
