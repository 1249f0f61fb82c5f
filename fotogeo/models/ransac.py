"""The one RANSAC of fotogeo, and the robust refit that follows it.

:func:`ransac` serves every model of the protocol in :mod:`fotogeo.models.base`: it draws
minimal samples (``model_cls.min_points``), fits, counts pairs whose residual is below
``threshold`` and keeps the largest consensus, stopping adaptively once the probability
of having missed a better sample falls below ``1 - confidence``:
``trials = log(1 - confidence) / log(1 - inlier_ratio ** min_points)``. A sample whose model
fails ``is_valid(model)`` (e.g. a homography that folds the image,
:meth:`~fotogeo.models.base.Model.folds`) is rejected before its consensus is counted.
``fit_options`` (e.g. the camera of the collinearity model) go to every ``estimate``.
Equal counts are broken by the MSAC score ``Σ min(r, threshold)`` (Torr & Zisserman 2000), but only
when the scores differ by more than ``1e-6 · n · threshold``: two consensus sets of exact data (two
structures of equal size) differ by rounding alone, and a choice between them must not follow the
last bits of the BLAS at hand, so the first such sample drawn (the seeded generator's order) is kept.

:func:`robust_refit` then re-estimates on *all* pairs by iteratively reweighted least
squares with Tukey's biweight ``w = (1 - (r / (c σ))²)²`` for ``|r| < c σ`` (0 beyond),
``c = 4.685`` and ``σ = 1.4826 · median(|r|)`` of the current inliers, never below
``min_sigma``. Over relief a homography is only approximate: RANSAC with a tight threshold
fits the plane of one part of the scene, while the robust refit lets every correct match
take part and still rejects the false ones, whose residuals are far larger.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import FotogeoError, MatchingError
from .base import Model

#: MSAC scores of equal counts closer than this fraction of ``n * threshold`` are a tie (the first sample kept)
_TIE = 1e-6


@dataclass(frozen=True)
class RansacResult:
    model: Model
    inliers: np.ndarray  # bool (N,)
    trials: int
    threshold: float


def ransac(model_cls, src, dst, threshold: float, *, max_trials: int = 5000,
           confidence: float = 0.999, rng=None, min_inliers: int | None = None,
           is_valid: Callable[[Model], bool] | None = None, fit_options: dict | None = None,
           unit: str = "") -> RansacResult:
    """Robustly fit ``model_cls`` to ``src -> dst`` pairs; the final model is refitted on the inliers.
    ``unit`` names the unit of ``threshold`` (the units of ``dst``) in messages."""
    opts = fit_options or {}
    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    n, k = len(src), model_cls.min_points
    need = max(min_inliers or k + 1, k)
    if n < need:
        raise MatchingError(f"RANSAC for a {model_cls.name} model needs at least {need} matches; got {n}")
    rng = np.random.default_rng(rng)
    best_count, best_mask, best_err, trials = 0, None, np.inf, 0
    tie = _TIE * n * threshold
    limit = max_trials
    while trials < limit:
        trials += 1
        idx = rng.choice(n, k, replace=False)
        try:
            m = model_cls.estimate(src[idx], dst[idx], **opts)
            if is_valid is not None and not is_valid(m):
                continue
            r = m.residuals(src, dst)
        except (FotogeoError, np.linalg.LinAlgError, FloatingPointError):
            continue
        r = np.where(np.isfinite(r), r, np.inf)
        mask = r < threshold
        count = int(mask.sum())
        err = float(np.sum(np.minimum(r, threshold)))  # MSAC-style tie break
        if count > best_count or (count == best_count and err < best_err - tie):
            best_count, best_mask, best_err = count, mask, err
            ratio = count / n
            if ratio >= 1.0:
                break
            denom = np.log1p(-min(ratio ** k, 1.0 - 1e-12)) or -1e-12
            limit = min(max_trials, int(np.ceil(np.log(1.0 - confidence) / denom)))
    if best_mask is None or best_count < need:
        raise MatchingError(
            f"RANSAC found only {best_count} inliers for a {model_cls.name} model among {n} matches "
            f"(at least {need} needed, threshold {threshold:.3g}{' ' + unit if unit else ''})")
    model = model_cls.estimate(src[best_mask], dst[best_mask], **opts)
    mask = model.residuals(src, dst) < threshold
    if mask.sum() >= need:
        model = model_cls.estimate(src[mask], dst[mask], **opts)
    else:
        mask = best_mask
    return RansacResult(model, mask, trials, threshold)


@dataclass(frozen=True)
class RobustFit:
    model: Model
    weights: np.ndarray  # (N,) Tukey weights, 0 for rejected pairs
    sigma: float
    iterations: int

    @property
    def inliers(self) -> np.ndarray:
        return self.weights > 0


def robust_refit(model_cls, src, dst, initial: Model, *, min_sigma: float, c: float = 4.685,
                 iterations: int = 30, fit_options: dict | None = None) -> RobustFit:
    """IRLS with Tukey's biweight, starting from ``initial``, over all pairs (see module doc)."""
    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    model = initial
    r = model.residuals(src, dst)
    inl = r < c * min_sigma
    sigma = min_sigma
    w = np.zeros(len(src))
    it = 0
    for it in range(1, iterations + 1):
        sigma = max(min_sigma, 1.4826 * float(np.median(r[inl]))) if inl.any() else min_sigma
        u = r / (c * sigma)
        w_new = np.where(u < 1.0, (1.0 - u ** 2) ** 2, 0.0)
        if np.count_nonzero(w_new) < model_cls.min_points:
            break
        try:
            model = model_cls.estimate(src, dst, w_new, **(fit_options or {}))
        except FotogeoError:
            break
        r = model.residuals(src, dst)
        new_inl = r < c * sigma
        converged = np.array_equal(new_inl, inl) and np.allclose(w_new, w, atol=1e-6)
        w, inl = w_new, new_inl
        if converged:
            break
    u = r / (c * sigma)
    w = np.where(u < 1.0, (1.0 - u ** 2) ** 2, 0.0)
    return RobustFit(model, w, sigma, it)
