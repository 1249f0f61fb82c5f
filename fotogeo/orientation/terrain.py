"""Terrain-aware registration (array layer): tie points + DEM heights → a 3-D model → orthorectification.

Over relief a plane-to-plane model cannot be right (relief displacement ``Δr = r·Δh / H``).
Here every tie point gets the DEM height at its reference map position, and a 3-D
ground→image model of the orientation work (``dlt``, ``rfm``, ``rfm-common``, ``rfm-poly``,
``collinearity`` with a known camera) is fitted:

1. gross mismatches go first, with the one robust tie-point selection of the 2-D registration,
   :func:`fotogeo.models.robust.select_tie_points` (RANSAC on a homography + Tukey refit with a
   wide cut-off, which keeps every correct match however large its relief displacement);
2. as its ``refine`` step a DLT is fitted to those matches by Tukey IRLS on its image
   residuals (``min_sigma`` = 0.5 target pixel) — the relief is now modelled, so residuals
   shrink to the matching noise and the remaining false matches stand out;
3. check points are held out spatially spread (at least 20 control points kept); each
   candidate model is fitted once by least squares on the control points;
4. ``model="auto"`` compares the candidates by **spatially blocked cross-validation** on the
   control points (:func:`blocked_cv_rmse`): their bounding box in the target image is cut into
   3 x 3 regions, each region is predicted by the candidate fitted to the other eight, and the
   pooled RMSE of those predictions (target pixels) is the criterion. It keeps the simplest
   candidate (collinearity, DLT, then the RFMs) within 5 % of the best, ranking fits with
   ill-posedness warnings last (:func:`choose_parsimonious`, shared with ``orient --model
   auto``); the report lists every candidate with its control, check and blocked RMSE and says
   why. Why blocks and not the check points: tie-point errors are spatially correlated (the
   reference's own geometric errors, DEM errors, matching biases of similar texture), and a check
   point lies a few pixels from control points that share its error, so a flexible model that
   follows that error field is rewarded at the check points although it is wrong away from the
   tie points and outside their hull (Roberts et al. 2017, cross-validation strategies for data
   with spatial structure). Most of a region held out whole lies farther from the fitted points
   than the error's correlation length, and the edge regions make a model extrapolate, as it must
   between and beyond the tie points. With fewer than
   :data:`MIN_BLOCKED` control points the check RMSE decides, and the reason says so. Each
   candidate reports progress and a cancel takes effect between two.

Residuals are given in target pixels and, through the model's inverse at each tie point's
height, in metres on the ground. A candidate whose fit options are missing (``collinearity``
without a camera, see :meth:`~fotogeo.models.base.Model.options_from`) is left out of ``auto``.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import FotogeoError, InputError, MatchingError, ModelError
from ..models import DLT, Projective, get_model, robust_refit
from ..models.robust import cell_ids, select_tie_points
from ..models.stats import rmse
from ..options import TERRAIN_MODELS

#: candidates of ``auto``, simplest first
PARSIMONY = ("collinearity", "dlt", "rfm-poly", "rfm-common", "rfm")
#: regions per axis of the blocked cross-validation of ``auto``
BLOCKS = 3
#: fewest control points for the blocked cross-validation (else the check RMSE decides)
MIN_BLOCKED = 60


@dataclass(frozen=True)
class TerrainFit:
    model: object
    role: np.ndarray  # (N,) control / check / outlier / no_height
    residual_px: np.ndarray  # (N, 2) model(ground) - target pixel
    residual_m: np.ndarray  # (N, 2) ground position of the target pixel under the model - reference XY
    ground: np.ndarray  # (N, 3)
    candidates: list
    chosen_because: str
    compared: str  # the candidates' key the choice compared
    sigma_px: float
    prefilter_inliers: int

    @property
    def inliers(self) -> np.ndarray:
        return np.isin(self.role, ("control", "check"))


def fit_terrain(target_px, ground, *, model: str = "auto", camera=None, threshold_m: float,
                min_sigma_m: float, check_fraction: float = 0.3, rng=0, is_valid=None, progress=None) -> TerrainFit:
    """Fit a 3-D model from ``ground`` (N, 3: X, Y, Z; Z NaN = no height) to ``target_px`` (N, 2).

    ``is_valid`` rejects RANSAC samples of the homography prefilter (e.g. one folding the image).
    ``progress(fraction, message) -> bool`` hears of the tie-point selection and of each
    candidate model; False cancels (:class:`~fotogeo.errors.Cancelled`) between two steps.
    """
    from ..progress import as_progress
    prog = as_progress(progress)
    if model not in TERRAIN_MODELS:
        raise InputError(f"model {model!r} is not a terrain model; choose one of {', '.join(TERRAIN_MODELS)}")
    src, ground = np.asarray(target_px, float), np.asarray(ground, float)
    has_h = np.isfinite(ground[:, 2])

    def relief_filter(pre):
        """Step 2: robust 3-D fit with the DLT (linear, fast) on the prefiltered matches."""
        prog(0.25, "relief filter: robust DLT on the prefiltered tie points")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rob = robust_refit(DLT, ground[pre], src[pre], DLT.estimate(ground[pre], src[pre]), min_sigma=0.5)
        inl = np.zeros(len(src), bool)
        inl[np.flatnonzero(pre)[rob.inliers]] = True
        return inl, rob.sigma

    prog(0.0, "selecting tie points (RANSAC, relief filter)")
    sel = select_tie_points(Projective, src, ground[:, :2], threshold=threshold_m, min_sigma=min_sigma_m,
                            check_fraction=check_fraction, rng=rng, usable=has_h, refine=relief_filter,
                            min_consistent=12, min_control=20, is_valid=is_valid,
                            what="tie points with DEM heights")
    control, is_check = sel.control, sel.is_check
    names = [n for n in PARSIMONY if _has_fit_options(n, camera)] if model == "auto" else [model]
    blocked = model == "auto" and len(names) > 1 and control.sum() >= MIN_BLOCKED
    cand, fitted = _fit_candidates(names, ground, src, control, is_check, camera, prog.stage(0.4, 1.0, "candidates"),
                                   blocked)
    key = "blocked_cv_rmse_px" if blocked else "check_rmse_px" if is_check.any() else "control_rmse_px"
    name, because = choose_parsimonious(cand, key, label=_LABELS[key][0])
    because = f"{because}; {_LABELS[key][1]}"
    m = fitted[name]
    because = "the model asked for" if model != "auto" else because
    role = sel.role
    role[~has_h] = "no_height"
    res_px = m.forward(ground) - src
    with np.errstate(invalid="ignore"):
        on_ground = np.full((len(src), 2), np.nan)
        on_ground[has_h] = m.inverse(src[has_h], ground[has_h, 2])[:, :2]
    return TerrainFit(m, role.astype(str), res_px, on_ground - ground[:, :2], ground, cand, because, key, sel.sigma,
                      sel.prefilter_inliers)


def _has_fit_options(name: str, camera) -> bool:
    """Whether the model ``name`` has every fit option it needs (the camera, for collinearity)."""
    try:
        get_model(name).options_from(camera=camera)
    except ModelError:
        return False
    return True


#: how the reason names each criterion of ``auto``, and why it is the one compared
_LABELS = {"blocked_cv_rmse_px": ("blocked cross-validation RMSE",
                                  f"{BLOCKS} x {BLOCKS} regions of the control points, each predicted from the others: "
                                  f"check points interleave with control points and share their errors, which favours "
                                  f"flexible models"),
           "check_rmse_px": ("check RMSE", f"fewer than {MIN_BLOCKED} control points for a blocked cross-validation"),
           "control_rmse_px": ("control RMSE", "no check points")}


def choose_parsimonious(candidates: list, key: str, tolerance: float = 0.05,
                        label: str | None = None) -> tuple[str, str]:
    """The simplest candidate whose ``key`` RMSE is within ``tolerance`` of the best, and why.

    ``candidates`` are dicts in order of simplicity (``model``, ``key``, ``ill_posed``); those
    without a finite ``key`` (not fitted, or predicting infinity) are skipped; fits with
    ill-posedness warnings are chosen only if every fit has them. ``label`` names the criterion in
    the reason (default: derived from ``key``).

    >>> choose_parsimonious([{"model": "dlt", "rmse": 1.02, "ill_posed": False},
    ...                      {"model": "rfm", "rmse": 1.00, "ill_posed": False}], "rmse")
    ('dlt', 'simplest of dlt, rfm within 5 % of the best rmse RMSE (1.000 px)')
    """
    fitted = [c for c in candidates if c.get(key) is not None and np.isfinite(c[key])]
    if not fitted:
        raise MatchingError("no candidate model could be fitted: " + "; ".join(c.get("note", "") for c in candidates))
    ok = [c for c in fitted if not c.get("ill_posed")] or fitted
    best = min(c[key] for c in ok)
    chosen = next(c for c in ok if c[key] <= (1 + tolerance) * best)
    label = label or key.replace("_rmse_px", "").replace("_px", "") + " RMSE"
    return chosen["model"], (f"simplest of {', '.join(c['model'] for c in ok)} within {tolerance:.0%} of the best "
                             f"{label} ({best:.3f} px)").replace("%", " %")


def _fit_candidates(names, ground, src, control, is_check, camera, prog, blocked=False):
    """Step 4: each candidate fitted once on the control points; its control and check RMSE (px) and,
    if ``blocked``, its blocked cross-validation RMSE (:func:`blocked_cv_rmse`)."""
    cand, fitted = [], {}
    for i, name in enumerate(names):
        prog(i / len(names), f"fitting candidate model {name} ({i + 1}/{len(names)})")
        try:
            cls = get_model(name)
            opts = cls.options_from(camera=camera)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                m = cls.estimate(ground[control], src[control], **opts)
        except FotogeoError as e:
            cand.append({"model": name, "note": str(e)})
            continue
        res = m.forward(ground) - src
        info = getattr(m, "info", {})
        cand.append({"model": name, "control_rmse_px": rmse(res[control]), "check_rmse_px": rmse(res[is_check]),
                     "warnings": [str(w.message) for w in caught], "ill_posed": bool(info.get("ill_posed"))})
        if blocked:
            cand[-1]["blocked_cv_rmse_px"] = blocked_cv_rmse(cls, ground[control], src[control], opts)
        fitted[name] = m
    if not fitted:
        raise MatchingError("no terrain model could be fitted: " + "; ".join(c.get("note", "") for c in cand))
    return cand, fitted


def blocked_cv_rmse(cls, ground, src, options=None, blocks: int = BLOCKS) -> float:
    """Spatially blocked cross-validation RMSE (target pixels) of the model class ``cls`` on ``ground -> src``.

    The points' bounding box in ``src`` (target pixels) is cut into ``blocks x blocks`` regions
    (:func:`~fotogeo.models.robust.cell_ids`); each region's points are predicted by ``cls`` fitted to all
    the others, and ``sqrt(1/n Σ |predicted − src|²)`` is pooled over every point. A fold that cannot be
    fitted, or a prediction that is not finite (a denominator vanishing outside the fitted points), makes
    the result infinite: such a model is not trusted away from its points.
    """
    ground, src = np.asarray(ground, float), np.asarray(src, float)
    cell = cell_ids(src, blocks)
    sq = np.empty(len(src))
    for c in np.unique(cell):
        held = cell == c
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                m = cls.estimate(ground[~held], src[~held], **(options or {}))
        except FotogeoError:
            return float("inf")
        with np.errstate(all="ignore"):
            sq[held] = np.sum((m.forward(ground[held]) - src[held]) ** 2, axis=1)
    return float(np.sqrt(np.mean(sq))) if np.isfinite(sq).all() else float("inf")
