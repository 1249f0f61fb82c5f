"""σ₀ per observation group of the bundle adjustment: which observations carry the weighted residuals (array layer).

The global ``σ₀² = vᵀPv / (n − u)`` mixes groups of different kind: the image measurements (px), the control
coordinates (m), the priors on the projection centres (GNSS, m) and on the attitude (INS, gimbal, autopilot).
Each group ``g`` has its share ``Ω_g = Σ_{i∈g} p_i v_i²`` of ``vᵀPv`` and its share ``r_g = Σ_{i∈g} r_i`` of the
redundancy (``r_i`` the redundancy numbers, ``Σ_g r_g = n − u``), and its own estimate
``σ̂_g = √(Ω_g / r_g)`` (Förstner 1979, the variance components of the groups; one iteration, the a-priori
weights unchanged). ``σ̂_g ≈ 1`` where the group's a-priori σ are right; ``σ̂_g ≫ 1`` names the group whose
a-priori σ are too small (e.g. GNSS positions given a σ of centimetres that are metres off, or image points
given a formal matching σ far below what they measure). One group far above the others makes the global
``σ₀`` — and the covariances scaled by it — speak of that group only: a parameter held by another group's
prior then gets a σ inflated by a factor its observations do not show.

Redundancy numbers: image observations ``r = p·q_vv`` (:func:`fotogeo.orientation.bundle_robust.posterior`);
a control coordinate ``r = 1 − w·(Σ_bb)_ii``; a prior on an orientation component ``r = 1 − w·(S⁻¹)_ii`` (its
weight times the a-posteriori cofactor of the parameter it observes directly).
"""
from __future__ import annotations

import numpy as np

#: a group with less redundancy than this gets no σ̂ (NaN): its residuals cannot tell its σ
MIN_GROUP_REDUNDANCY = 1.0


def _group(omega: float, r: float, n: int, **extra) -> dict:
    sig = float(np.sqrt(omega / r)) if r >= MIN_GROUP_REDUNDANCY and omega >= 0 else float("nan")
    return {"sigma0": sig, "redundancy": float(r), "n": int(n), "vtpv": float(omega), **extra}


def variance_components(p, v, r_image, ctrl_w, ctrl_v, ctrl_q, eo_w, eo_v, S_inv_diag) -> dict:
    """``{group: {"sigma0", "redundancy", "n", "vtpv", …}}`` for the groups present (module docstring):
    ``image`` (weights ``p`` ``(n,)`` px⁻², residuals ``v`` ``(n, 2)``, redundancy numbers ``r_image``
    ``(n, 2)``; ``a_priori_px`` the median a-priori σ), ``control`` (weights, residuals and a-posteriori
    cofactor diagonals ``(P, 3)``; ``a_priori`` the median σ of a coordinate, m), ``position_prior`` and
    ``attitude_prior`` (``eo_w``, ``eo_v`` ``(m, 6)``;
    ``S_inv_diag`` the first ``6m`` diagonal entries of the inverse reduced camera matrix; ``a_priori`` the
    median a-priori σ, m or degrees). ``σ̂_g × a_priori`` is what the group's observations measure."""
    out = {}
    p = np.asarray(p, float)
    if len(p):
        out["image"] = _group(float(np.sum(p[:, None] * v ** 2)), float(np.sum(r_image)), 2 * len(p),
                              a_priori_px=float(np.median(1.0 / np.sqrt(np.maximum(p, 1e-300)))))
    ctrl = ctrl_w > 0
    if ctrl.any():
        r_c = np.clip(1.0 - ctrl_w[ctrl] * ctrl_q[ctrl], 0.0, 1.0)
        out["control"] = _group(float(np.sum(ctrl_w[ctrl] * ctrl_v[ctrl] ** 2)), float(np.sum(r_c)),
                                int(ctrl.sum()), a_priori=float(np.median(1.0 / np.sqrt(ctrl_w[ctrl]))))
    m = len(eo_w)
    q = np.asarray(S_inv_diag, float)[:6 * m].reshape(m, 6)
    for name, cols in (("position_prior", slice(0, 3)), ("attitude_prior", slice(3, 6))):
        w, vv, qq = eo_w[:, cols], eo_v[:, cols], q[:, cols]
        has = w > 0
        if has.any():
            r = np.clip(1.0 - w[has] * qq[has], 0.0, 1.0)
            prior = 1.0 / np.sqrt(w[has])
            prior = np.degrees(prior) if name == "attitude_prior" else prior
            out[name] = _group(float(np.sum(w[has] * vv[has] ** 2)), float(np.sum(r)), int(has.sum()),
                               a_priori=float(np.median(prior)))
    return out


#: a group σ̂ above this, and above :data:`DOMINANT_RATIO` times every other group's, drives the global σ₀
DOMINANT_SIGMA0 = 1.5
DOMINANT_RATIO = 1.5


def _finite_sigmas(groups: dict) -> dict:
    """``{group: σ̂}`` of the groups whose σ̂ is known (None is NaN read back from JSON)."""
    return {k: float(g["sigma0"]) for k, g in groups.items()
            if g.get("sigma0") is not None and np.isfinite(g["sigma0"])}


def dominant_group(groups: dict) -> str | None:
    """The group whose σ̂ drives σ₀ (above :data:`DOMINANT_SIGMA0` and :data:`DOMINANT_RATIO` times every other
    finite group's), or None.

    >>> dominant_group({"image": {"sigma0": 4.6}, "position_prior": {"sigma0": 0.4}})
    'image'
    >>> dominant_group({"image": {"sigma0": 1.1}, "position_prior": {"sigma0": 0.9}}) is None
    True
    >>> dominant_group({"image": {"sigma0": 1.7}, "position_prior": {"sigma0": None}})
    'image'
    """
    finite = _finite_sigmas(groups)
    if not finite:
        return None
    top = max(finite, key=finite.get)
    others = [s for k, s in finite.items() if k != top]
    if finite[top] > DOMINANT_SIGMA0 and all(finite[top] > DOMINANT_RATIO * s for s in others):
        return top
    return None


def images_too_strong(groups: dict, level: float = 0.95) -> bool:
    """True when the image points' σ should be estimated: their σ̂ above :data:`DOMINANT_SIGMA0` and no other
    group's σ̂ significantly larger (one-sided F-test at ``level``, ``F = σ̂_g² / σ̂_image²`` on ``(r_g, r_image)``
    degrees of freedom). Unlike :func:`dominant_group` no margin over the others is asked: the image points hold
    nearly all the redundancy, and weighted too strongly they push their misfit into the small groups — 8 control
    points at centimetres then read σ̂ 2–4 on 2–4 of redundancy beside the images' 3, which says nothing about the
    control's own σ. After the images' σ is estimated a group whose own σ is wrong keeps σ̂ > 1 and is named; one
    that only carried the images' misfit falls to ≈ 1.

    >>> images_too_strong({"image": {"sigma0": 2.9, "redundancy": 1e4},
    ...                    "control": {"sigma0": 3.8, "redundancy": 2.4}})
    True
    >>> images_too_strong({"image": {"sigma0": 1.7, "redundancy": 300},
    ...                    "position_prior": {"sigma0": 3.2, "redundancy": 20}})
    False
    """
    from scipy.stats import f as f_distribution
    finite = _finite_sigmas(groups)
    s_image = finite.pop("image", None)
    if s_image is None or s_image <= DOMINANT_SIGMA0:
        return False
    r_image = float(groups["image"].get("redundancy") or np.inf)
    for name, s in finite.items():
        r = float(groups[name].get("redundancy") or np.inf)
        if s > s_image and (s / s_image) ** 2 > f_distribution.ppf(level, r, r_image):
            return False
    return True
