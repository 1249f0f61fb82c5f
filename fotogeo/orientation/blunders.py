"""Blunder detection on the control points of an orientation fit, at real click noise (array layer).

Every control point ``i`` is measured as a pair ``(col, row)`` from one click, so it is tested as one
2-D observation. With ``v_i`` its residual under the least-squares (LS) fit, ``R_i`` the 2x2 block of
``I − H`` (``H`` the hat matrix of the fit's Jacobian, the point's redundancy numbers; Förstner 1987)
and ``SSR = Σ vᵀv``, the drop of ``SSR`` when the point leaves the fit is
``T_i = v_iᵀ R_i⁻¹ v_i`` (exact for linear LS; Cook & Weisberg 1982). A point outside the fit, with
``e_i`` its prediction error and ``J_i`` its Jacobian rows, gives the same quantity as
``T_i = e_iᵀ (I + J_i N⁻¹ J_iᵀ)⁻¹ e_i`` (``N = JᵀJ`` of the fit without it). The test of point ``i``
(Baarda 1968, one alternative per point, its error in any direction):

- with the a priori image σ (``sigma``: the click precision, in pixels) ``T_i / σ² ~ χ²(2)``;
- without it, σ is estimated without the point itself, ``s_i² = (SSR − T_i) / (f − 2)``
  (``f = 2n − u``), and ``T_i / (2 s_i²) ~ F(2, f − 2)`` — the externally studentised residual,
  which a blunder does not mask by inflating σ̂ as it does in Pope's (1976) τ.

The point's standardised residual is ``w_i = √T_i / σ̂`` (σ̂ = σ or ``s_i``). A point is flagged
when its p-value is below ``alpha / m`` (Bonferroni over the ``m`` points tested): ``alpha`` is the
probability that a fit of clean points flags any point at all.

The solution is found robustly first: iteratively reweighted LS with the Danish weights of Krarup,
Juhl & Kubik (1980), ``p = 1`` for ``z ≤ c`` and ``exp(1 − (z/c)²)`` above (``z`` = the point's
standardised residual with σ or the robust scale ``median √T / √(2 ln 2)``). Points it leaves below
half weight start outside the final LS; then, one at a time, the most significant point inside is put
out and an outside point whose test passes is put back, until every point inside passes and every
point outside fails. Those are the flagged points: ``"blunder"`` where the test has the redundancy to
say so (``f ≥`` :data:`MIN_REDUNDANCY_BLUNDER`, the point's own redundancy number at least
:data:`MIN_POINT_REDUNDANCY_BLUNDER`, σ known or ``f − 2 ≥ 4``), else ``"suspect"``. A point whose
redundancy is below :data:`MIN_POINT_REDUNDANCY` cannot show its error: ``"not testable"``.

The test's power per point is Baarda's (1968) minimal detectable bias (internal reliability): a blunder ``b``
moves ``T_i / σ²`` to a non-central χ²(2) (or ``T_i / (2 s_i²)`` to a non-central F) with non-centrality
``λ = bᵀ R_i b / σ²``; ``λ₀`` is the non-centrality the test finds with probability ``1 − β`` (:data:`BETA`) at
its critical value, so ``mdb_i = σ̂ √(λ₀ / r_min)`` with ``r_min`` the smaller eigenvalue of ``R_i`` (the least
favourable direction): a blunder at point ``i`` smaller than ``mdb_i`` may go unnoticed. With σ given, the global
test ``SSR / σ² ~ χ²(f)`` of the final fit says when the residuals disagree with it (:meth:`BlunderTest.note`):
a σ given too large weakens the test, one too small makes clean points look like blunders.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import FotogeoError

ALPHA = 0.01
#: the probability of missing a blunder of the size :attr:`BlunderTest.mdb` (power 1 − BETA)
BETA = 0.2
#: the two-sided level of the global test of a given σ against the residuals
ALPHA_GLOBAL = 0.01
DANISH_C = 2.5
MIN_POINT_REDUNDANCY = 0.1
MIN_POINT_REDUNDANCY_BLUNDER = 0.2
MIN_REDUNDANCY_BLUNDER = 6
#: an estimated image σ̂ below this (pixels) means the fit is exact: a tenth of the 0.1 px least-squares matching
#: reaches at best (Ackermann), so the image positions were computed from the model (up to their rounding), not
#: measured, and the residuals hold no measurement error a blunder could be told from
EXACT_SIGMA_PX = 0.01
_RAYLEIGH_MEDIAN = float(np.sqrt(2 * np.log(2)))


@dataclass(frozen=True)
class BlunderTest:
    """Per control point (in the order of the ``control`` mask): ``w`` (NaN: not tested), ``p`` its
    p-value, ``residual`` (n, 2) under the final LS fit, ``redundancy`` (mean of the point's two redundancy numbers in the final fit, or of the fit
    with it for a point left out), ``flag`` ("", "blunder", "suspect", "not testable"), ``outside``
    (left out of the final LS); ``critical`` the ``w`` a point with σ known / the median ``s_i`` must
    exceed, ``f`` the final fit's redundancy, ``sigma`` (given or estimated) and ``alpha``; ``mdb`` (n,) the
    minimal detectable blunder in pixels (module docstring; NaN: not known), ``sigma_fit`` the σ̂ of the final LS
    fit's residuals and ``sigma_fit_p`` the global test's two-sided p-value of a given σ (NaN without one)."""
    w: np.ndarray
    p: np.ndarray
    residual: np.ndarray
    redundancy: np.ndarray
    flag: np.ndarray
    outside: np.ndarray
    critical: float | None
    f: int
    sigma: float
    sigma_given: bool
    alpha: float
    mdb: np.ndarray | None = None
    sigma_fit: float = float("nan")
    sigma_fit_p: float = float("nan")

    def note(self) -> str:
        """What the test did, in one line."""
        if self.critical is None:
            return f"blunder test: not testable (redundancy 2n − u = {self.f})"
        if not self.sigma_given and self.sigma < EXACT_SIGMA_PX:
            return (f"blunder test: not possible, the fit is exact (σ̂ = {self.sigma:.1g} px estimated, below "
                    f"{EXACT_SIGMA_PX:g} px: image positions computed from the model, not measured; redundancy "
                    f"{self.f})")
        s = f"σ = {self.sigma:.2f} px given" if self.sigma_given else f"σ̂ = {self.sigma:.2f} px estimated"
        text = (f"blunder test: |w| > {self.critical:.2f} ({s}, redundancy {self.f}, {100 * self.alpha:g} % false "
                f"alarms per fit)")
        mdb = np.array([]) if self.mdb is None else self.mdb[np.isfinite(self.mdb)]
        if mdb.size:
            text += (f"; blunders above {np.median(mdb):.1f} px (median point; {mdb.min():.1f}–{mdb.max():.1f} px) "
                     f"are found with {100 * (1 - BETA):g} % probability")
        if self.sigma_given and self.sigma_fit_p < ALPHA_GLOBAL:
            which = "large: the test is weaker than it could be" if self.sigma_fit < self.sigma else \
                "small: clean points may be flagged"
            text += f"; the residuals say σ̂ = {self.sigma_fit:.2f} px, the σ given looks too {which}"
        return text


def _danish(z: np.ndarray, c: float = DANISH_C) -> np.ndarray:
    return np.where(z <= c, 1.0, np.exp(1.0 - (np.nan_to_num(z, nan=0.0) / c) ** 2))


def _geometric(model, src, pix, weights, dirs, iterations: int = 6):
    """Gauss-Newton steps from a model's own estimate (e.g. the DLT's algebraic one) to the least-squares
    solution in image pixels, along the model's free parameter directions; the statistics assume it."""
    from dataclasses import replace

    from .design import jacobian
    sw = np.ones(len(src)) if weights is None else np.sqrt(np.asarray(weights, float))
    v = (model.forward(src) - pix) * sw[:, None]
    ssr = float(np.sum(v ** 2))
    for _ in range(iterations):
        J = jacobian(model, src, dirs).reshape(len(src), 2, -1) * sw[:, None, None]
        step = np.linalg.lstsq(J.reshape(-1, J.shape[2]), -v.reshape(-1), rcond=1e-10)[0]
        trial = replace(model, params=model.params + dirs @ step)
        tv = (trial.forward(src) - pix) * sw[:, None]
        tssr = float(np.sum(tv ** 2))
        if not np.isfinite(tssr) or tssr >= ssr:
            break
        done = ssr - tssr < 1e-10 * max(ssr, 1e-30)
        model, v, ssr = trial, tv, tssr
        if done:
            break
    return model


class _Fit:
    """One LS fit on ``inside`` (bool over the points) with the deletion statistic ``T`` of every point."""

    def __init__(self, cls, src, pix, inside, weights, fit_options):
        from .design import free_directions, jacobian
        w = None if weights is None else weights[inside]
        self.model = cls.estimate(src[inside], pix[inside], w, **fit_options)
        dirs = free_directions(self.model)
        n = len(src)
        self.T = np.full(n, np.nan)
        self.r = np.full(n, np.nan)
        self.rmin = np.full(n, np.nan)
        if dirs is None:  # a regularised model: the statistic by refits
            self.v = self.model.forward(src) - pix
            self._by_refits(cls, src, pix, inside, fit_options)
            return
        self.model = _geometric(self.model, src[inside], pix[inside], w, dirs)
        self.v = self.model.forward(src) - pix
        J = jacobian(self.model, src, dirs).reshape(n, 2, -1)
        Ji = J[inside].reshape(-1, J.shape[2])
        Ninv = np.linalg.pinv(Ji.T @ Ji, rcond=1e-10)
        P = np.einsum("nak,kl,nbl->nab", J, Ninv, J)  # J_i N⁻¹ J_iᵀ, (n, 2, 2)
        R = np.where(inside[:, None, None], np.eye(2) - P, np.eye(2) + P)
        self.R = R.copy()  # the point's 2x2 block of I − H in the fit with it
        self.R[~inside] = np.linalg.inv(R[~inside])
        lam, vec = np.linalg.eigh(R)
        self.r = np.where(inside, lam.mean(axis=1), (1.0 / lam).mean(axis=1))  # outside: R with it = (I + P)⁻¹
        self.rmin = np.where(inside, lam.min(axis=1), 1.0 / lam.max(axis=1))
        ok = lam >= MIN_POINT_REDUNDANCY
        proj = np.einsum("nab,na->nb", vec, self.v)  # components along R's eigenvectors
        self.T = np.sum(np.where(ok, proj ** 2 / lam, 0.0), axis=1)
        self.T[inside & ~ok.all(axis=1)] = np.nan  # too little redundancy in one direction: not testable

    def _by_refits(self, cls, src, pix, inside, fit_options):
        ssr = float(np.sum(self.v[inside] ** 2))
        for i in range(len(src)):
            keep = inside.copy()
            keep[i] = not inside[i]
            try:
                m = cls.estimate(src[keep], pix[keep], **fit_options)
            except (FotogeoError, np.linalg.LinAlgError):
                continue
            other = float(np.sum((m.forward(src[keep]) - pix[keep]) ** 2))
            self.T[i] = max(ssr - other if inside[i] else other - ssr, 0.0)
            self.r[i] = 1.0


def _p_values(T, inside, ssr, f, sigma):
    """p-values of the deletion statistics (module docstring) and each point's σ̂."""
    from scipy.stats import chi2
    from scipy.stats import f as fisher
    if sigma is not None:
        return chi2.sf(T / sigma ** 2, 2), np.full(len(T), float(sigma))
    df = np.where(inside, f - 2, f)
    s2 = np.where(inside, ssr - T, ssr) / np.maximum(df, 1)
    s2 = np.maximum(s2, 1e-24)
    p = np.where(df >= 1, fisher.sf(T / (2 * s2), 2, np.maximum(df, 1)), np.nan)
    return p, np.sqrt(s2)


def _robust_start(cls, src, pix, sigma, fit_options, iterations: int = 12):
    """Danish IRLS (module docstring): the points' final weights."""
    weights = np.ones(len(src))
    for _ in range(iterations):
        fit = _Fit(cls, src, pix, np.ones(len(src), bool), weights, fit_options)
        root = np.sqrt(fit.T)
        scale = sigma or (np.nanmedian(root) / _RAYLEIGH_MEDIAN if np.isfinite(root).any() else 0.0)
        if not scale > 0:
            break
        new = _danish(root / scale)
        new[~np.isfinite(root)] = 1.0
        if np.max(np.abs(new - weights)) < 1e-3:
            break
        weights = np.maximum(new, 1e-6)
    return weights


def detect_blunders(cls, src, pix, *, sigma: float | None = None, alpha: float = ALPHA,
                    max_fraction: float = 0.3, fit_options: dict | None = None, progress=None) -> BlunderTest:
    """Test every point of ``src``/``pix`` (the control points: ground → image pairs of model class
    ``cls``); see the module docstring. ``sigma``: the a priori image σ (pixels) or None. ``progress``
    (:func:`fotogeo.progress.as_progress`) is told each round and may cancel."""
    from ..progress import as_progress
    progress = as_progress(progress)
    fit_options = fit_options or {}
    src, pix = np.asarray(src, float), np.asarray(pix, float)
    n, u = len(src), cls.n_params
    nan = np.full(n, np.nan)
    if 2 * n - u < (1 if sigma else 3) or n - 1 < cls.min_points:
        return BlunderTest(nan, nan, np.full((n, 2), np.nan), nan, np.full(n, "not testable", object), np.zeros(n, bool), None, 2 * n - u,
                           float(sigma or np.nan), sigma is not None, alpha)
    if sigma is None:  # an exact fit (image positions computed from the model): nothing to test against
        everything = np.ones(n, bool)
        fit, p, s, f, m = _evaluate(cls, src, pix, everything, sigma, fit_options)
        if np.nanmedian(s) < EXACT_SIGMA_PX:
            return _result(fit, everything, p, s, f, sigma, alpha, m)
    inside = _robust_start(cls, src, pix, sigma, fit_options) >= 0.5
    budget = max(0, min(int(max_fraction * n), n - cls.min_points, (2 * n - u - (1 if sigma else 3)) // 2))
    if (~inside).sum() > budget:
        inside[:] = True
    for k in range(2 * n):
        progress(k / (k + 1), f"testing the control points for blunders (round {k + 1})")  # rounds: unknown
        fit, p, s, f, m = _evaluate(cls, src, pix, inside, sigma, fit_options)
        bad = np.isfinite(p) & (p < alpha / m)
        if (bad & inside).any() and (~inside).sum() < budget:
            inside[np.flatnonzero(bad & inside)[np.argmin(p[bad & inside])]] = False
        elif (~bad & ~inside).any():
            inside[np.flatnonzero(~bad & ~inside)[np.argmax(np.nan_to_num(p[~bad & ~inside], nan=1.0))]] = True
        else:
            break
    else:
        fit, p, s, f, m = _evaluate(cls, src, pix, inside, sigma, fit_options)
    progress(1.0, "blunder test done")
    return _result(fit, inside, p, s, f, sigma, alpha, m)


def _evaluate(cls, src, pix, inside, sigma, fit_options):
    fit = _Fit(cls, src, pix, inside, None, fit_options)
    f = 2 * int(inside.sum()) - cls.n_params
    p, s = _p_values(fit.T, inside, float(np.sum(fit.v[inside] ** 2)), f, sigma)
    return fit, p, s, f, max(int(np.isfinite(p).sum()), 1)


def _result(fit, inside, p, s, f, sigma, alpha, m) -> BlunderTest:
    from scipy.stats import chi2
    from scipy.stats import f as fisher
    w = np.sqrt(fit.T) / s
    bad = np.isfinite(p) & (p < alpha / m)
    if sigma is None and np.nanmedian(s) < EXACT_SIGMA_PX:
        bad[:] = False  # no blunder test on an exact fit (:meth:`BlunderTest.note`)
    if sigma is not None:
        critical = float(np.sqrt(chi2.isf(alpha / m, 2)))
    else:
        critical = float(np.sqrt(2 * fisher.isf(alpha / m, 2, max(f - 2, 1))))
    redundancy = fit.r.copy()
    sure = (f >= MIN_REDUNDANCY_BLUNDER) and (sigma is not None or f - 2 >= 4)
    flag = np.full(len(w), "", object)
    flag[~np.isfinite(w)] = "not testable"
    flag[bad] = "blunder" if sure else "suspect"
    low = bad & (np.nan_to_num(redundancy, nan=1.0) < MIN_POINT_REDUNDANCY_BLUNDER)
    flag[low] = "suspect"
    ssr = float(np.sum(fit.v[inside] ** 2))
    sigma_fit = float(np.sqrt(ssr / f)) if f > 0 else float("nan")
    p_global = float("nan")
    if sigma is not None and f > 0:
        c = chi2.cdf(ssr / sigma ** 2, f)
        p_global = float(2 * min(c, 1 - c))
    mdb = minimal_detectable(fit.rmin, s, np.where(inside, f - 2, f), sigma is not None, alpha / m)
    mdb[~np.isfinite(w)] = np.nan
    return BlunderTest(w, p, fit.v, redundancy, flag, ~inside, critical, f, float(sigma if sigma else np.nanmedian(s)),
                       sigma is not None, alpha, mdb, sigma_fit, p_global)


def noncentrality(level: float, df: int | None, beta: float = BETA) -> float:
    """``λ₀``: the non-centrality at which the point test of size ``level`` (per point) has power ``1 − beta``;
    χ²(2) (σ given, ``df`` None) or F(2, ``df``) (σ estimated).

    >>> round(noncentrality(0.01 / 15, None), 1)
    20.7
    """
    from scipy.optimize import brentq
    from scipy.stats import chi2, ncf, ncx2
    from scipy.stats import f as fisher
    if df is None:
        c = chi2.isf(level, 2)
        power = lambda lam: ncx2.sf(c, 2, lam) - (1 - beta)  # noqa: E731
    else:
        c = fisher.isf(level, 2, df)
        power = lambda lam: ncf.sf(c, 2, df, lam) - (1 - beta)  # noqa: E731
    hi = 64.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # scipy's non-central F at extreme arguments
        while power(hi) < 0 and hi < 1e6:
            hi *= 2
        return float(brentq(power, 1e-6, hi)) if power(hi) >= 0 else float("inf")


def minimal_detectable(rmin, s, df, sigma_given: bool, level: float, beta: float = BETA) -> np.ndarray:
    """Per point ``σ̂ √(λ₀ / r_min)`` (module docstring); NaN where ``r_min`` is below :data:`MIN_POINT_REDUNDANCY`."""
    rmin, s, df = np.asarray(rmin, float), np.asarray(s, float), np.asarray(df)
    out = np.full(len(rmin), np.nan)
    ok = np.isfinite(rmin) & (rmin >= MIN_POINT_REDUNDANCY) & np.isfinite(s) & (sigma_given | (df >= 1))
    cache = {}
    for i in np.flatnonzero(ok):
        key = None if sigma_given else int(df[i])
        if key not in cache:
            cache[key] = noncentrality(level, key, beta)
        out[i] = s[i] * np.sqrt(cache[key] / rmin[i])
    return out
