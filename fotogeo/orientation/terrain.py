"""Terrain-aware registration (array layer): tie points + DEM heights → a 3-D model → orthorectification.

Over relief a plane-to-plane model cannot be right (relief displacement ``Δr = r·Δh / H``).
Here every tie point gets the DEM height at its reference map position, and a 3-D
ground→image model of the orientation work (``dlt``, ``rfm``, ``rfm-common``, ``rfm-poly``,
``collinearity`` with a known camera) is fitted:

1. gross mismatches go first, with the 2-D machinery of :func:`fotogeo.models.robust.fit_tie_points`'s
   first steps (RANSAC on a homography + Tukey refit with a wide cut-off, which keeps every
   correct match however large its relief displacement);
2. a DLT is fitted to those matches by Tukey IRLS on its image residuals (``min_sigma`` = 0.5
   target pixel) — the relief is now modelled, so residuals shrink to the matching noise and
   the remaining false matches stand out;
3. check points are held out spatially spread; each candidate model is fitted once by least
   squares on the control points;
4. ``model="auto"`` keeps the simplest candidate (collinearity, DLT, then the RFMs) whose check
   RMSE is within 5 % of the best, ranking fits with ill-posedness warnings last (the report
   lists every candidate and says why). Measured on the NGI frames, dense truth RMSE:
   collinearity 1.5/1.9 m, DLT 2.1/2.6 m, RFM 3.2/4.1 m — the RFM's extra terms fit the
   matching noise, which is why parsimony decides between near-equal check RMSEs.

Residuals are given in target pixels and, through the model's inverse at each tie point's
height, in metres on the ground.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import FotogeoError, InputError, MatchingError, ModelError
from ..models import Projective, ransac, robust_refit
from ..models.robust import spread_split
from .adjustment import resolve_model

TERRAIN_MODELS = ("auto", "dlt", "rfm", "rfm-common", "rfm-poly", "collinearity")
#: candidates of ``auto``, simplest first
PARSIMONY = ("collinearity", "dlt", "rfm-poly", "rfm-common", "rfm")


@dataclass(frozen=True)
class TerrainFit:
    model: object
    role: np.ndarray  # (N,) control / check / outlier / no_height
    residual_px: np.ndarray  # (N, 2) model(ground) - target pixel
    residual_m: np.ndarray  # (N, 2) ground position of the target pixel under the model - reference XY
    ground: np.ndarray  # (N, 3)
    candidates: list
    chosen_because: str
    sigma_px: float
    prefilter_inliers: int

    @property
    def inliers(self) -> np.ndarray:
        return np.isin(self.role, ("control", "check"))


def fit_terrain(target_px, ground, *, model: str = "auto", camera=None, threshold_m: float,
                min_sigma_m: float, check_fraction: float = 0.3, rng=0) -> TerrainFit:
    """Fit a 3-D model from ``ground`` (N, 3: X, Y, Z; Z NaN = no height) to ``target_px`` (N, 2)."""
    if model not in TERRAIN_MODELS:
        raise InputError(f"model {model!r} is not a terrain model; choose one of {', '.join(TERRAIN_MODELS)}")
    src, ground = np.asarray(target_px, float), np.asarray(ground, float)
    has_h = np.isfinite(ground[:, 2])
    rng = np.random.default_rng(rng)
    # 1. gross mismatches out, relief kept (the 2-D pre-filter)
    rs = ransac(Projective, src, ground[:, :2], threshold_m, rng=rng, min_inliers=6)
    pre = robust_refit(Projective, src, ground[:, :2], rs.model, min_sigma=min_sigma_m, c=6.0).inliers & has_h
    if pre.sum() < 12:
        raise MatchingError(f"only {int(pre.sum())} consistent tie points with DEM heights (12 needed)")
    # 2. robust 3-D fit with the DLT (linear, fast): the relief is modelled now, so the
    #    residuals shrink to the matching noise and the remaining false matches stand out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dlt = resolve_model("dlt")
        rob = robust_refit(dlt, ground[pre], src[pre], dlt.estimate(ground[pre], src[pre]), min_sigma=0.5)
    inl = np.zeros(len(src), bool)
    inl[np.flatnonzero(pre)[rob.inliers]] = True
    # 3. spatially spread check points
    idx = np.flatnonzero(inl)
    frac = check_fraction if len(idx) * (1 - check_fraction) >= 20 else 0.0
    is_check = np.zeros(len(src), bool)
    is_check[idx] = spread_split(src[idx], frac, rng)
    control = inl & ~is_check
    # 4. every candidate fitted once on the control points; the simplest one within 5 % of the
    #    best check RMSE wins (more parameters must earn their place), ill-posed fits last
    names = [m for m in PARSIMONY if m != "collinearity" or camera is not None] if model == "auto" else [model]
    cand, fitted = [], {}
    for name in names:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                m = resolve_model(name, camera).estimate(ground[control], src[control])
        except FotogeoError as e:
            cand.append({"model": name, "note": str(e)})
            continue
        r = m.residuals(ground, src)
        rms = lambda sel: float(np.sqrt(np.mean(r[sel] ** 2))) if sel.any() else float("nan")  # noqa: E731
        info = getattr(m, "info", {})
        entry = {"model": name, "control_rmse_px": rms(control), "check_rmse_px": rms(is_check),
                 "warnings": [str(w.message) for w in caught], "ill_posed": bool(info.get("ill_posed"))}
        cand.append(entry)
        fitted[name] = m
    if not fitted:
        raise MatchingError("no terrain model could be fitted: " + "; ".join(c.get("note", "") for c in cand))
    key = "check_rmse_px" if frac else "control_rmse_px"
    ok = [c for c in cand if c["model"] in fitted and not c["ill_posed"]] or [c for c in cand if c["model"] in fitted]
    best = min(c[key] for c in ok)
    chosen = next(c for c in ok if c[key] <= 1.05 * best)
    m = fitted[chosen["model"]]
    because = ("the model asked for" if model != "auto" else
               f"simplest of {', '.join(c['model'] for c in ok)} within 5 % of the best {key.split('_')[0]} "
               f"RMSE ({best:.3f} px)")
    sigma = rob.sigma
    role = np.full(len(src), "outlier", dtype=object)
    role[~has_h] = "no_height"
    role[control], role[is_check] = "control", "check"
    res_px = m.forward(ground) - src
    with np.errstate(invalid="ignore"):
        on_ground = np.full((len(src), 2), np.nan)
        ok = has_h
        on_ground[ok] = m.inverse(src[ok], z=ground[ok, 2])[:, :2]
    return TerrainFit(m, role.astype(str), res_px, on_ground - ground[:, :2], ground, cand, because, sigma,
                      int(pre.sum()))


def ground_footprint(model, width: int, height: int, sampler) -> np.ndarray:
    """Ground XY of the target image's outline, each edge point intersected with the DEM."""
    t = np.linspace(0, 1, 33)
    edge = np.concatenate([np.column_stack([t * width, 0 * t]), np.column_stack([width + 0 * t, t * height]),
                           np.column_stack([(1 - t) * width, height + 0 * t]), np.column_stack([0 * t, (1 - t) * height])])
    XY = model.inverse(edge, dem=sampler)[:, :2]
    if not np.isfinite(XY).any():
        raise ModelError("the target footprint does not meet the DEM under the fitted model; does the DEM cover it?")
    return XY[np.isfinite(XY).all(axis=1)]
