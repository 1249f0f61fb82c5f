"""Outlier rejection of window shifts: against one global model, then against the neighbours.

1. **Global model.** The window centres ``p`` and their matches ``q = p + d`` are fitted by
   an affine or projective model ``q ≈ M(p)`` with fotogeo's one RANSAC
   (:func:`fotogeo.models.ransac.ransac`, Fischler & Bolles 1981, MSAC tie-break) and a
   ``threshold`` in pixels; windows farther from the consensus model than
   ``max(threshold, 3 · 1.4826 · median residual of its inliers)`` are ``"outlier: global
   model"`` — the second term keeps a local distortion larger than the threshold (a 2-px
   ripple) for the field, the first rejects blunders on an otherwise rigid shift.
2. **Neighbours.** The residuals ``e = q − M(p)`` of the windows kept are compared with the
   median of their kept neighbours within ``radius`` grid cells (a vector median filter of
   the shift field, as AROSICS' outlier detection compares with the neighbourhood,
   Scheffler et al. 2017): a window whose residual differs from that median by more than
   ``max(tolerance, 3 · 1.4826 · MAD)`` px (MAD of the neighbours' residuals about their
   median) is ``"outlier: neighbours"``. A window with fewer than 3 kept neighbours is
   judged by the global model alone. The filter is repeated until nothing changes (at most
   3 rounds), so a cluster of outliers cannot shield one another.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import FotogeoError
from ..models import get_model
from ..models.ransac import ransac

OUTLIER_GLOBAL = "outlier: global model"
OUTLIER_NEIGHBOURS = "outlier: neighbours"
#: the fewest kept neighbours a window is compared with
MIN_NEIGHBOURS = 3


@dataclass(frozen=True)
class Filtered:
    """``model`` (target = M(reference pixel)); ``status`` (N,) updated; ``residual`` (N, 2)
    ``q − M(p)`` px (NaN where not measured)."""

    model: object
    status: np.ndarray
    residual: np.ndarray


def global_model(xy, shift, ok, *, model: str = "affine", threshold: float = 3.0, seed: int = 0):
    """RANSAC fit of ``model`` to ``xy → xy + shift`` over the ``ok`` windows:
    ``(model, inliers (N,) bool)``; raises :class:`fotogeo.errors.MatchingError` with too few."""
    cls = get_model(model)
    idx = np.nonzero(ok)[0]
    src, dst = xy[idx], xy[idx] + shift[idx]
    res = ransac(cls, src, dst, float(threshold), rng=seed, min_inliers=max(cls.min_points + 2, 6))
    r = res.model.residuals(src, dst)
    limit = max(float(threshold), 3.0 * 1.4826 * float(np.median(r[res.inliers])))
    inl = np.zeros(len(xy), bool)
    inl[idx[r <= limit]] = True
    return res.model, inl


def _neighbour_outliers(index, shape, resid, keep, radius: int, tolerance: float) -> np.ndarray:
    grid = np.full(shape + (2,), np.nan)
    k = np.nonzero(keep)[0]
    grid[index[k, 0], index[k, 1]] = resid[k]
    bad = np.zeros(len(keep), bool)
    for i in k:
        r, c = index[i]
        r0, c0 = max(r - radius, 0), max(c - radius, 0)
        block = grid[r0:r + radius + 1, c0:c + radius + 1].copy()
        block[r - r0, c - c0] = np.nan  # not the window itself
        nb = block.reshape(-1, 2)
        nb = nb[np.isfinite(nb[:, 0])]
        if len(nb) < MIN_NEIGHBOURS:
            continue
        med = np.median(nb, axis=0)
        mad = 1.4826 * np.median(np.hypot(*(nb - med).T))
        bad[i] = np.hypot(*(resid[i] - med)) > max(tolerance, 3.0 * mad)
    return bad


def reject_outliers(xy, shift, status, index, shape, *, model: str = "affine", threshold: float = 3.0,
                    radius: int = 1, tolerance: float = 1.0, seed: int = 0, ok_word: str = "ok") -> Filtered:
    """Both filters of the module docstring on the windows whose ``status`` is ``ok_word``.

    ``index`` (N, 2) grid ``(row, col)`` of each window, ``shape`` the grid's shape.
    """
    status = np.asarray(status).astype("<U40").copy()
    ok = status == ok_word
    m, inl = global_model(xy, shift, ok, model=model, threshold=threshold, seed=seed)
    status[ok & ~inl] = OUTLIER_GLOBAL
    resid = np.full(xy.shape, np.nan)
    measured = np.isfinite(shift).all(axis=1)
    resid[measured] = xy[measured] + shift[measured] - m.forward(xy[measured])
    for _ in range(3):
        keep = status == ok_word
        bad = _neighbour_outliers(np.asarray(index), tuple(shape), resid, keep, int(radius), float(tolerance))
        if not bad.any():
            break
        status[bad] = OUTLIER_NEIGHBOURS
    keep = status == ok_word
    if keep.sum() >= get_model(model).min_points + 2:
        try:
            m = get_model(model).estimate(xy[keep], xy[keep] + shift[keep])
            resid[measured] = xy[measured] + shift[measured] - m.forward(xy[measured])
        except FotogeoError:
            pass
    return Filtered(m, status, resid)
