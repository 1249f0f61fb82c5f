"""Orientation models fitted to GCPs: statistics, blunder detection and model comparison (array layer).

Every model of :mod:`fotogeo.models` maps ground to image: ``src`` = ``(X, Y)`` for 2-D models
or ``(X, Y, Z)`` for 3-D ones (``src_dims``), ``dst`` = ``(col, row)`` pixels. Residuals are
``v = model(ground) − measured pixel`` (``dx``, ``dy`` in pixels); for each role
``RMS_x = sqrt(mean dx²)``, ``RMS_y = sqrt(mean dy²)``, ``RMS_xy = sqrt(mean (dx² + dy²))``.

Blunder detection (:func:`snoop`) is Baarda's data snooping with leave-one-out residuals:
for control point ``i``, ``ℓ_i`` is its residual under the model fitted without it. For a
least-squares fit ``v_i = r_i ℓ_i`` with ``r_i`` the point's redundancy number, so
``r_i = v_i / ℓ_i`` per axis, and the standardised residual is
``w_i = v_i / (σ₀ √r_i)`` with ``σ₀² = Σ v² / (2n − u)``. ``|w_i| > 3.29`` (α = 0.1 %,
two-sided) flags a blunder; with ``remove`` the worst one is dropped, the model refitted and
the test repeated.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import FotogeoError, ModelError
from ..models import get_model
from ..models.stats import residual_stats

CRITICAL_W = 3.29


@dataclass(frozen=True)
class OrientFit:
    model: object
    residual: np.ndarray  # (N, 2) model(ground) - pixel, all points
    role: np.ndarray  # (N,) control / check / blunder
    stats: dict  # {"control": {...}, "check": {...}}
    snooping: list = field(default_factory=list)  # [{id, w, removed}]
    warnings: list = field(default_factory=list)


def model_src(model_cls, ground: np.ndarray) -> np.ndarray:
    """The source coordinates a model class takes: (X, Y) or (X, Y, Z); heights must be known."""
    if model_cls.src_dims == 3:
        if not np.isfinite(ground[:, 2]).all():
            raise ModelError(f"model {model_cls.name!r} is 3-D and needs a height for every GCP: give a "
                             f"height field, a DEM or a constant height")
        return ground
    return ground[:, :2]


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


def snoop(model_cls, src, pix, control, ids, *, remove: bool = False, max_fraction: float = 0.2,
          fit_options: dict | None = None):
    """Data snooping on the control points (module docstring); returns (control mask, findings).

    ``fit_options`` go to every ``estimate`` (e.g. the camera of the collinearity model)."""
    fit_options = fit_options or {}
    control = control.copy()
    findings = []
    budget = int(max_fraction * control.sum())
    while True:
        idx = np.flatnonzero(control)
        n, u = len(idx), model_cls.n_params
        if 2 * n - u < 2 or n - 1 < model_cls.min_points:
            break
        m, _ = _fit(model_cls, src, pix, control, fit_options)
        v = m.forward(src[idx]) - pix[idx]
        s0 = np.sqrt(np.sum(v ** 2) / (2 * n - u))
        loo = np.full_like(v, np.nan)
        for k, i in enumerate(idx):
            keep = control.copy()
            keep[i] = False
            try:
                mk, _ = _fit(model_cls, src, pix, keep, fit_options)
                loo[k] = mk.forward(src[i:i + 1])[0] - pix[i]
            except FotogeoError:
                continue
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.clip(np.where(np.abs(loo) > 1e-12, v / loo, 1.0), 1e-3, 1.0)
            w = np.abs(v) / (s0 * np.sqrt(r)) if s0 > 0 else np.zeros_like(v)
        wmax = np.nanmax(w, axis=1)
        k = int(np.nanargmax(wmax)) if np.isfinite(wmax).any() else -1
        flagged = [(ids[idx[j]], float(wmax[j])) for j in np.flatnonzero(wmax > CRITICAL_W)]
        if k < 0 or wmax[k] <= CRITICAL_W:
            break
        can_remove = remove and sum(f["removed"] for f in findings) < budget
        findings.append({"id": str(ids[idx[k]]), "w": float(wmax[k]), "removed": bool(can_remove),
                         "reason": f"standardised residual |w| = {wmax[k]:.2f} > {CRITICAL_W} "
                                   f"(residual {np.hypot(*v[k]):.3f} px)",
                         "also_flagged": [(str(i), round(x, 2)) for i, x in flagged if i != ids[idx[k]]]})
        if not can_remove:
            break
        control[idx[k]] = False
    return control, findings


def fit_orientation(model_name: str, ground, pixel, role, ids, *, snooping: bool = True,
                    remove_blunders: bool = False, scale_mm: float | None = None, camera=None) -> OrientFit:
    """Fit ``model_name`` on the control points, evaluate it on control and check points.

    ``camera`` (a :class:`~fotogeo.geometry.camera.FrameCamera`) is passed to the models that
    take it as a fit option (collinearity, see :meth:`~fotogeo.models.base.Model.options_from`).
    """
    cls = get_model(model_name)
    fit_options = cls.options_from(camera=camera)
    src = model_src(cls, np.asarray(ground, float))
    pix = np.asarray(pixel, float)
    role = np.asarray(role).astype(object)
    control = role == "control"
    if control.sum() < cls.min_points:
        raise ModelError(f"model {cls.name!r} needs at least {cls.min_points} control points; got {int(control.sum())}")
    findings = []
    if snooping:
        control, findings = snoop(cls, src, pix, control, np.asarray(ids), remove=remove_blunders,
                                  fit_options=fit_options)
    model, warns = _fit(cls, src, pix, control, fit_options)
    res = model.forward(src) - pix
    role = role.copy()
    role[(role == "control") & ~control] = "blunder"
    stats = {r: role_stats(res[role == r], scale_mm) for r in ("control", "check")}
    if (role == "blunder").any():
        stats["blunder"] = role_stats(res[role == "blunder"], scale_mm)
    return OrientFit(model, res, role.astype(str), stats, findings, warns)
