"""Orientation models fitted to GCPs: statistics, blunder detection and model comparison (array layer).

Every model of :mod:`fotogeo.models` is fitted ground to image: ``src`` = ``(X, Y)`` for 2-D models
or ``(X, Y, Z)`` for 3-D ones (``src_dims``), ``dst`` = ``(col, row)`` pixels — except the image → ground
models (``direction == "image-to-ground"``, the ``*-i2g`` RFMs), fitted ``src = (col, row, Z)``,
``dst = (X, Y)`` (:func:`fit_data`) and evaluated through their inverse at each point's height, so that
every residual is an image error. Residuals are ``v = model(ground) − measured pixel`` (``dx``, ``dy`` in
pixels); for each role
``RMS_x = sqrt(mean dx²)``, ``RMS_y = sqrt(mean dy²)``, ``RMS_xy = sqrt(mean (dx² + dy²))``.

Blunder detection (:func:`snoop`) is Baarda's (1968) data snooping. For control point ``i``,
``ℓ_i`` is its residual under the model fitted without it, and ``v_i = r_i ℓ_i`` per axis
defines its redundancy number ``r_i``; the standardised residual is
``w_i = v_i / (σ₀ √r_i)`` with ``σ₀² = Σ v² / (2n − u)``. As σ₀ comes from the same residuals,
``w_i`` follows Pope's (1976) τ distribution with ``f = 2n − u`` degrees of freedom (never above
``√f``): a blunder is flagged when ``|w_i|`` exceeds its α = 0.1 % two-sided quantile
(:func:`critical_w`; 3.29, the normal quantile, for large ``f``). The test needs redundancy:
with ``f`` below :data:`MIN_TEST_REDUNDANCY` nothing is testable, and a point whose own
redundancy number is below :data:`MIN_POINT_REDUNDANCY` (its error hardly shows in its residual)
gets no ``w`` ("not testable") — at low redundancy the plain 3.29 rule flagged well-fitting points.
With ``remove`` the worst one is dropped, the model refitted and the test repeated.

The leave-one-out residuals come in closed form from one factorisation: with ``J`` the
``(2n, u)`` design of the fit (for nonlinear models the Jacobian of ``forward`` with respect
to the free parameters at the solution, by central differences) and its thin SVD
``J = U S Vᵀ`` (rank-truncated), the hat matrix is ``H = U Uᵀ``; dropping point ``i``
changes its residual to ``ℓ_i = (I − H_ii)⁻¹ v_i`` with ``H_ii`` the point's 2x2 block —
exact for linear least squares, first order for nonlinear ones — so the redundancy numbers
are the diagonal of ``I − H`` (Förstner 1987). Models regularised by Tikhonov (the RFMs,
whose λ is chosen anew per fit) are refitted without each point instead.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import FotogeoError, ModelError
from ..models import get_model
from ..models.stats import residual_stats
from .design import free_directions, jacobian  # noqa: F401 (also this module's API)

CRITICAL_W = 3.29  # the large-redundancy limit of critical_w
ALPHA = 0.001
#: total redundancy 2n − u below which the blunder test is not made
MIN_TEST_REDUNDANCY = 6
#: a point's redundancy number below which its standardised residual is not testable
MIN_POINT_REDUNDANCY = 0.1


def critical_w(f: int, alpha: float = ALPHA) -> float | None:
    """Critical standardised residual for ``f = 2n − u`` (Pope's τ, σ₀ estimated from the same residuals);
    None when ``f`` is below :data:`MIN_TEST_REDUNDANCY` (not testable).

    >>> round(critical_w(13), 2), round(critical_w(10_000), 2), critical_w(5)
    (2.81, 3.29, None)
    """
    if f < MIN_TEST_REDUNDANCY:
        return None
    from scipy.stats import t
    q = float(t.ppf(1.0 - alpha / 2.0, f - 1))
    return float(np.sqrt(f) * q / np.sqrt(f - 1 + q * q))


@dataclass(frozen=True)
class OrientFit:
    model: object
    residual: np.ndarray  # (N, 2) model(ground) - pixel, all points
    role: np.ndarray  # (N,) control / check / blunder
    stats: dict  # {"control": {...}, "check": {...}}
    snooping: list = field(default_factory=list)  # [{id, w, redundancy, flag, removed, reason}]
    warnings: list = field(default_factory=list)
    #: per point (N,): the blunder test's w, redundancy number and flag (:mod:`.blunders`; NaN / "" untested)
    w: np.ndarray | None = None
    redundancy: np.ndarray | None = None
    flag: np.ndarray | None = None
    blunder_test: str = "blunder test off"
    #: per point (N,): the minimal detectable blunder in pixels (:mod:`.blunders`; NaN untested)
    mdb: np.ndarray | None = None


def model_src(model_cls, ground: np.ndarray) -> np.ndarray:
    """The source coordinates a model class takes: (X, Y) or (X, Y, Z); heights must be known."""
    if model_cls.src_dims == 3:
        if not np.isfinite(ground[:, 2]).all():
            raise ModelError(f"model {model_cls.name!r} is 3-D and needs a height for every GCP: give a "
                             f"height field, a DEM or a constant height")
        return ground
    return ground[:, :2]


def image_to_ground(model_cls) -> bool:
    """Whether ``model_cls`` is fitted image → ground (the ``*-i2g`` RFMs)."""
    return getattr(model_cls, "direction", "ground-to-image") == "image-to-ground"


def fit_data(model_cls, ground: np.ndarray, pixel: np.ndarray):
    """``(src, dst)`` the model class is fitted on: ``(model_src, pixel)``, or for an image → ground
    model ``((col, row, Z), (X, Y))``."""
    src = model_src(model_cls, ground)
    if image_to_ground(model_cls):
        return np.column_stack([pixel, src[:, 2]]), src[:, :2]
    return src, pixel


def image_residuals(model, ground: np.ndarray, pixel: np.ndarray) -> np.ndarray:
    """``(N, 2)`` image errors (pixels, model − measured) of a fitted model at GCPs ``ground`` (X, Y[, Z]):
    ``forward(ground) − pixel``, or for an image → ground model ``inverse(X, Y at Z) − pixel``."""
    if image_to_ground(model):
        return model.inverse(ground[:, :2], ground[:, 2])[:, :2] - pixel
    return model.forward(model_src(model, ground)) - pixel


def role_stats(res: np.ndarray, scale_mm: float | None = None) -> dict:
    """n, RMS x/y/xy, min, max, median of residual vectors ``res`` (pixels; optionally mm)."""
    r = residual_stats(res)
    if r["n"] == 0:
        return r
    s = {"n": r["n"], "rms_x_px": r["rms_x"], "rms_y_px": r["rms_y"], "rms_xy_px": r["rms_xy"],
         "min_px": r["min"], "max_px": r["max"], "median_px": r["median"]}
    if scale_mm:
        s.update({k.replace("_px", "_mm"): v * scale_mm for k, v in list(s.items()) if k.endswith("_px")})
    return s


def _fit(model_cls, src, pix, mask, fit_options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = model_cls.estimate(src[mask], pix[mask], **fit_options)
    return m, [str(w.message) for w in caught]


def _redundancy_blocks(model, src: np.ndarray):
    """The 2x2 diagonal blocks ``I − H_ii`` (n, 2, 2) of the fit (module docstring), or None when the
    model needs refits (:func:`free_directions`)."""
    dirs = free_directions(model)
    if dirs is None:
        return None
    J = jacobian(model, src, dirs)
    U, sv, _ = np.linalg.svd(J, full_matrices=False)
    U = U[:, sv > sv[0] * 1e-10] if sv.size and sv[0] > 0 else U[:, :0]
    Ui = U.reshape(len(src), 2, -1)
    return np.eye(2) - np.einsum("nak,nbk->nab", Ui, Ui)  # H = U Uᵀ


def leave_one_out(model, src: np.ndarray, pix: np.ndarray) -> np.ndarray:
    """Closed-form leave-one-out residuals ``ℓ_i = (I − H_ii)⁻¹ v_i`` (module docstring); NaN for a
    point without redundancy. None when the model needs refits (:func:`free_directions`)."""
    M = _redundancy_blocks(model, src)
    if M is None:
        return None
    v = model.forward(src) - pix
    det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
    ok = det > 1e-9
    loo = np.full_like(v, np.nan)
    loo[ok] = np.linalg.solve(M[ok], v[ok][..., None])[..., 0]
    return loo


def _refit_leave_one_out(model_cls, src, pix, control, idx, fit_options, prog):
    """Leave-one-out residuals by refitting without each point (the fallback of :func:`leave_one_out`)."""
    loo = np.full((len(idx), 2), np.nan)
    for k, i in enumerate(idx):
        prog(k / len(idx), f"data snooping: leaving out point {k + 1}/{len(idx)}")
        keep = control.copy()
        keep[i] = False
        try:
            mk, _ = _fit(model_cls, src, pix, keep, fit_options)
            loo[k] = mk.forward(src[i:i + 1])[0] - pix[i]
        except FotogeoError:
            continue
    return loo


def standardised_residuals(model_cls, src, pix, control, *, fit_options: dict | None = None, progress=None):
    """Residuals ``v`` ``(n, 2)`` of the control points (``control`` mask, in its order) under the model
    fitted to them, and Baarda's standardised residual of each, ``max(|w_x|, |w_y|)`` ``(n,)``
    (module docstring; NaN without redundancy or where the point's redundancy number is below
    :data:`MIN_POINT_REDUNDANCY`: not testable). Needs ``2n − u ≥ 1``."""
    idx = np.flatnonzero(control)
    n, u = len(idx), model_cls.n_params
    m, _ = _fit(model_cls, src, pix, control, fit_options or {})
    v = m.forward(src[idx]) - pix[idx]
    s0 = np.sqrt(np.sum(v ** 2) / (2 * n - u))
    blocks = _redundancy_blocks(m, src[idx])
    with np.errstate(divide="ignore", invalid="ignore"):
        if blocks is not None:  # the redundancy numbers themselves, not v / ℓ (unstable where v is small)
            r = np.stack([blocks[:, 0, 0], blocks[:, 1, 1]], axis=1)
        else:
            loo = _refit_leave_one_out(model_cls, src, pix, control, idx, fit_options or {},
                                       progress or (lambda *a: True))
            r = np.where(np.abs(loo) > 1e-12, v / loo, 1.0)
        r = np.where(r >= MIN_POINT_REDUNDANCY, np.minimum(r, 1.0), np.nan)
        w = np.abs(v) / (s0 * np.sqrt(r)) if s0 > 0 else np.where(np.isnan(r), np.nan, 0.0)
        wmax = np.where(np.isnan(w).any(axis=1), np.nan, np.nanmax(np.nan_to_num(w, nan=0.0), axis=1))
    return v, wmax


def snoop(model_cls, src, pix, control, ids, *, remove: bool = False, max_fraction: float = 0.2,
          fit_options: dict | None = None, progress=None, unit: str = "px"):
    """Data snooping on the control points (module docstring); returns (control mask, findings).

    ``pix`` are the fit's destination points, in ``unit`` (the ground of an image → ground model).
    ``fit_options`` go to every ``estimate`` (e.g. the camera of the collinearity model);
    ``progress(fraction, message) -> bool`` reports each test and may cancel (:class:`Cancelled`)."""
    from ..progress import as_progress
    prog = as_progress(progress)
    fit_options = fit_options or {}
    control = control.copy()
    findings = []
    budget = int(max_fraction * control.sum())
    while True:
        idx = np.flatnonzero(control)
        n, u = len(idx), model_cls.n_params
        critical = critical_w(2 * n - u)
        if critical is None or n - 1 < model_cls.min_points:
            break
        prog(min(0.99, len(findings) / max(1, budget + 1)), f"data snooping: test {len(findings) + 1}")
        v, wmax = standardised_residuals(model_cls, src, pix, control, fit_options=fit_options,
                                         progress=prog.stage(0.0, 0.99, "data snooping"))
        k = int(np.nanargmax(wmax)) if np.isfinite(wmax).any() else -1
        flagged = [(ids[idx[j]], float(wmax[j])) for j in np.flatnonzero(wmax > critical)]
        if k < 0 or wmax[k] <= critical:
            break
        can_remove = remove and sum(f["removed"] for f in findings) < budget
        findings.append({"id": str(ids[idx[k]]), "w": float(wmax[k]), "removed": bool(can_remove),
                         "reason": f"standardised residual |w| = {wmax[k]:.2f} > {critical:.2f} "
                                   f"(residual {np.hypot(*v[k]):.3f} {unit})",
                         "also_flagged": [(str(i), round(x, 2)) for i, x in flagged if i != ids[idx[k]]]})
        if not can_remove:
            break
        control[idx[k]] = False
    prog(1.0, "data snooping done")
    return control, findings


def fit_orientation(model_name: str, ground, pixel, role, ids, *, snooping: bool = True,
                    remove_blunders: bool = False, scale_mm: float | None = None, camera=None,
                    image_sigma: float | None = None, progress=None) -> OrientFit:
    """Fit ``model_name`` on the control points, evaluate it on control and check points.

    With ``snooping`` every control point is tested for a blunder (:func:`.blunders.detect_blunders`,
    with the a priori ``image_sigma`` in pixels when given); ``remove_blunders`` leaves the points
    flagged "blunder" (not the mere suspects) out of the fit, their role then ``blunder``.
    ``camera`` (a :class:`~fotogeo.geometry.camera.FrameCamera`) is passed to the models that
    take it as a fit option (collinearity, see :meth:`~fotogeo.models.base.Model.options_from`).
    """
    from ..progress import as_progress
    cls = get_model(model_name)
    fit_options = cls.options_from(camera=camera)
    ground, pixel = np.asarray(ground, float), np.asarray(pixel, float)
    src, dst = fit_data(cls, ground, pixel)
    role = np.asarray(role).astype(object)
    control = role == "control"
    if control.sum() < cls.min_points:
        raise ModelError(f"model {cls.name!r} needs at least {cls.min_points} control points; got {int(control.sum())}")
    n = len(role)
    w, red, flag, mdb = np.full(n, np.nan), np.full(n, np.nan), np.full(n, "", object), np.full(n, np.nan)
    findings, note = [], "blunder test off"
    if snooping:
        test, findings = _blunder_test(cls, src, dst, control, np.asarray(ids), image_sigma, fit_options,
                                       "ground units" if image_to_ground(cls) else "px", as_progress(progress))
        idx = np.flatnonzero(control)
        w[idx], red[idx], flag[idx], note = test.w, test.redundancy, test.flag, test.note()
        if test.mdb is not None and not image_to_ground(cls):
            mdb[idx] = test.mdb
        if remove_blunders:
            for f in findings:
                f["removed"] = f["flag"] == "blunder"
            control[idx[test.flag == "blunder"]] = False
    model, warns = _fit(cls, src, dst, control, fit_options)
    res = image_residuals(model, ground, pixel)
    role = role.copy()
    role[(role == "control") & ~control] = "blunder"
    stats = {r: role_stats(res[role == r], scale_mm) for r in ("control", "check")}
    if (role == "blunder").any():
        stats["blunder"] = role_stats(res[role == "blunder"], scale_mm)
    return OrientFit(model, res, role.astype(str), stats, findings, warns, w, red, flag.astype(str), note, mdb)


def _blunder_test(cls, src, dst, control, ids, image_sigma, fit_options, unit, progress):
    """:func:`.blunders.detect_blunders` on the control points and its findings (the flagged points)."""
    from .blunders import detect_blunders
    idx = np.flatnonzero(control)
    sigma = None if image_to_ground(cls) else image_sigma  # an image → ground fit's residuals are on the ground
    test = detect_blunders(cls, src[idx], dst[idx], sigma=sigma, fit_options=fit_options, progress=progress)
    findings = []
    for j in np.argsort(-np.nan_to_num(test.w, nan=-1.0)):
        if test.flag[j] not in ("blunder", "suspect"):
            continue
        why = "" if test.flag[j] == "blunder" else " — too little redundancy to call it a blunder"
        findings.append({"id": str(ids[idx[j]]), "w": float(test.w[j]), "flag": str(test.flag[j]),
                         "redundancy": None if not np.isfinite(test.redundancy[j]) else float(test.redundancy[j]),
                         "removed": False,
                         "reason": f"|w| = {test.w[j]:.2f} > {test.critical:.2f} (residual "
                                   f"{np.hypot(*test.residual[j]):.3f} {unit}){why}"})
    return test, findings


#: candidates of ``orient --model auto``: 2-D, then 3-D (heights needed), each fitted if the GCPs allow it
AUTO_CANDIDATES = ("similarity", "affine", "collinearity", "projective", "bilinear", "affine-height", "dlt", "poly2",
                   "poly3", "rfm-poly", "rfm-common", "rfm")


def auto_candidates(n_control: int, has_heights: bool, camera=None) -> list[str]:
    """The models of :data:`AUTO_CANDIDATES` that ``n_control`` control points allow, simplest
    (fewest parameters) first: at least ``min_points`` and, unless regularised (the RFMs), two
    more observations than parameters (2n ≥ u + 2); 3-D models need heights, collinearity the camera."""
    names = []
    for name in AUTO_CANDIDATES:
        cls = get_model(name)
        if cls.src_dims == 3 and not has_heights:
            continue
        try:
            cls.options_from(camera=camera)
        except ModelError:
            continue
        if n_control >= cls.min_points and (name.startswith("rfm") or 2 * n_control >= cls.n_params + 2):
            names.append(name)
    return sorted(names, key=lambda n: get_model(n).n_params)  # stable: the listed order breaks ties


def select_model(ground, pixel, role, ids, *, camera=None, tolerance: float = 0.05, progress=None):
    """``orient --model auto``: fit every :func:`auto_candidates` model on the control points and
    keep the simplest whose RMSE is within ``tolerance`` of the best (the parsimony rule of the
    terrain-aware registration, :func:`fotogeo.orientation.terrain.choose_parsimonious`).

    The error compared is the check points' RMSE when there are at least 3, else the median of the
    control points' leave-one-out errors (each point predicted by the model fitted without it: closed
    form for the linear models, refits for the RFMs). The median, not the RMS: at low redundancy one
    point of high leverage, left out, leaves the model extrapolating — with 8 GCPs and DEM heights on
    an NGI frame one corner point's 78 px made the DLT's leave-one-out RMSE 28 px although it fits
    every point to 0.4 px, and affine (4.9 px) won; the median (DLT 0.6–2.3 px, the 2-D and
    height-affine models 4.5–9 px over four draws) still punishes a model that fits by overfitting. Returns ``(name, selection)`` with ``selection`` =
    ``{"candidates": [...], "chosen": name, "because": text, "compared": key}``; progress is
    reported per candidate and a cancel takes effect between two.
    """
    from ..progress import as_progress
    from .terrain import choose_parsimonious
    prog = as_progress(progress)
    ground, pixel, role = np.asarray(ground, float), np.asarray(pixel, float), np.asarray(role).astype(object)
    control = role == "control"
    names = auto_candidates(int(control.sum()), bool(np.isfinite(ground[:, 2]).all()), camera)
    if not names:
        raise ModelError(f"{int(control.sum())} control points are too few for any orientation model (the "
                         f"similarity needs 3)")
    key = "check_rmse_px" if (role == "check").sum() >= 3 else "loo_median_px"
    cand = []
    for i, name in enumerate(names):
        prog(i / len(names), f"fitting candidate model {name} ({i + 1}/{len(names)})")
        cand.append(_candidate(name, ground, pixel, role, ids, camera, key))
    prog(1.0, "candidate models fitted")
    chosen, because = choose_parsimonious(cand, key, tolerance)
    return chosen, {"candidates": cand, "chosen": chosen, "because": because, "compared": key}


def _candidate(name, ground, pixel, role, ids, camera, key) -> dict:
    """One candidate of :func:`select_model`: its control, check (or leave-one-out RMSE and median) errors in
    pixels."""
    try:
        f = fit_orientation(name, ground, pixel, role, ids, snooping=False, camera=camera)
    except FotogeoError as e:
        return {"model": name, "note": str(e)}
    row = {"model": name, "n_params": get_model(name).n_params, "control_rmse_px": f.stats["control"].get("rms_xy_px"),
           "check_rmse_px": f.stats["check"].get("rms_xy_px"),
           "ill_posed": bool(getattr(f.model, "info", {}).get("ill_posed")), "warnings": f.warnings}
    if key == "loo_median_px":
        cls = get_model(name)
        src, control = model_src(cls, ground), role == "control"
        idx = np.flatnonzero(control)
        loo = leave_one_out(f.model, src[idx], pixel[idx])
        if loo is None:
            loo = _refit_leave_one_out(cls, src, pixel, control, idx, cls.options_from(camera=camera),
                                       lambda *a: True)
        ok = np.isfinite(loo).all(axis=1)
        row["loo_rmse_px"] = float(np.sqrt(np.mean(np.sum(loo[ok] ** 2, axis=1)))) if ok.any() else None
        row["loo_median_px"] = float(np.median(np.hypot(*loo[ok].T))) if ok.any() else None
    return row
