"""A 3-D similarity ``y = s·Q·x + t`` between two point sets, its precision and a fit robust to one blunder.

:func:`fit_similarity` is the weighted least-squares solution in closed form (Umeyama 1991; Horn 1987 by unit
quaternions reaches the same rotation): with weights ``w_i`` (normalised to sum 1), the weighted centroids
``x̄, ȳ``, the cross-covariance ``Σ = Σ w_i (y_i − ȳ)(x_i − x̄)ᵀ`` and ``σ_x² = Σ w_i |x_i − x̄|²``, the rotation
is :func:`~fotogeo.geometry.camera.nearest_rotation` of ``Σ`` (Kabsch's sign on the last axis keeps ``det Q = +1``),
``s = trace(Qᵀ Σ) / σ_x²`` and ``t = ȳ − s·Q·x̄``. One weight per point: per-axis σ (GPS σ_h ≠ σ_v) enter the
precision and the residual test, not the closed form.

:func:`similarity_precision` linearises ``y_i = s·Q·exp([ω]×)·x_i·(1 + δ) + t`` in the seven unknowns
``(δ, ω, t)`` with per-axis σ, ``N = Σ J_iᵀ W_i J_i`` and ``Cov = N⁻¹``: from it the σ of any aligned point and the
tilt (rotation about the horizontal axes). ``x`` is taken about its weighted centroid ``x̄`` (``t`` then the aligned
centroid): linearised about a far origin (map coordinates ~1e5 m) the rotation and the translation are nearly
collinear columns of ``J`` and ``N`` loses the tilt's precision to rounding (the tilt σ of a corridor came out 20 x
too small). The similarity is ill-determined when the points lie on a line (the rotation about it is free, ``N``
singular): the condition number of ``N`` scaled to a unit diagonal (:attr:`Precision.condition`) says it, and the
covariance of a nearly singular ``N`` states the large σ it implies (no pseudo-inverse hides the free direction).

:func:`robust_similarity` fits all points and, when their normalised residuals fail the χ² test and there are
enough points, leaves out the one point whose leave-one-out residual is largest (one blunder, e.g. one bad GPS
fix); it returns which point was left out and the test of the rest.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .camera import nearest_rotation

#: χ² per degree of freedom above which the residuals do not agree with the σ given (3σ RMS)
CHI2_DOF_MAX = 9.0
#: condition number of the scaled normal matrix beyond which the points are taken as a line (double precision
#: keeps ~16 digits; at 1e12 the covariance has lost all but ~4 of them)
MAX_CONDITION = 1e12


@dataclass(frozen=True)
class Similarity3D:
    """``y = scale·rotation·x + translation``."""

    scale: float
    rotation: np.ndarray
    translation: np.ndarray

    def apply(self, x) -> np.ndarray:
        return self.scale * np.asarray(x, np.float64) @ self.rotation.T + self.translation


def fit_similarity(x, y, weights=None) -> Similarity3D:
    """The weighted least-squares similarity ``y ≈ s·Q·x + t`` of ``(N, 3)`` point sets (module docstring)."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    if x.shape != y.shape or x.ndim != 2 or x.shape[1] != 3 or len(x) < 3:
        raise InputError(f"a 3-D similarity needs at least 3 point pairs of shape (N, 3); got {x.shape}, {y.shape}")
    w = np.ones(len(x)) if weights is None else np.asarray(weights, np.float64)
    w = w / w.sum()
    mx, my = w @ x, w @ y
    dx, dy = x - mx, y - my
    var = float(w @ np.sum(dx * dx, axis=1))
    if not var > 0:
        raise InputError("a 3-D similarity needs distinct points; all source points coincide")
    S = (dy * w[:, None]).T @ dx
    Q = nearest_rotation(S)
    s = float(np.trace(Q.T @ S) / var)
    return Similarity3D(s, Q, my - s * Q @ mx)


def _skew(v) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _jacobian(sim: Similarity3D, x) -> np.ndarray:
    """``(N, 3, 7)``: derivatives of the aligned points in ``(δ, ω, t)`` (module docstring)."""
    q = sim.scale * np.asarray(x, np.float64) @ sim.rotation.T  # s·Q·x
    J = np.zeros((len(q), 3, 7))
    J[:, :, 0] = q
    for i, xi in enumerate(np.asarray(x, np.float64)):
        J[i, :, 1:4] = -sim.scale * sim.rotation @ _skew(xi)
    J[:, :, 4:] = np.eye(3)
    return J


@dataclass(frozen=True)
class Precision:
    """σ (1σ, metres) of the aligned points, horizontally and vertically (RMS over the points asked), and of the
    tilt (degrees, the rotation about the horizontal axes) of a :class:`Similarity3D` fitted to points of σ given."""

    horizontal: float
    vertical: float
    tilt_deg: float
    condition: float = 1.0  # of N scaled to a unit diagonal: > MAX_CONDITION, the points lie on a line


def similarity_precision(sim: Similarity3D, x, sigma, at=None, chi2_dof: float = 1.0) -> Precision:
    """The precision of ``sim`` fitted to ``x`` (``(N, 3)``) with per-axis σ ``sigma`` ``(N, 3)`` (module
    docstring), at the points ``at`` [``x``]; the covariance is scaled by ``chi2_dof`` when above 1 (residuals
    larger than the σ given: the a-posteriori variance factor), never shrunk."""
    W = 1.0 / np.asarray(sigma, np.float64) ** 2
    x = np.asarray(x, np.float64)
    w = np.mean(W, axis=1)
    c = w @ x / np.sum(w)  # the weighted centroid: N about it keeps its digits (module docstring)
    J = _jacobian(sim, x - c)
    N = np.einsum("nai,na,naj->ij", J, W, J)
    d = np.sqrt(np.diag(N))
    if not np.all(d > 0):
        return Precision(np.inf, np.inf, np.inf, np.inf)
    ev = np.linalg.eigvalsh(N / np.outer(d, d))
    cond = float(ev[-1] / ev[0]) if ev[0] > 0 else np.inf
    if not cond <= MAX_CONDITION:
        return Precision(np.inf, np.inf, np.inf, cond)
    cov = np.linalg.inv(N) * max(1.0, float(chi2_dof))
    Ja = _jacobian(sim, (x if at is None else np.asarray(at, np.float64)) - c)
    C = np.einsum("nai,ij,nbj->nab", Ja, cov, Ja)
    h = float(np.sqrt(np.mean(C[:, 0, 0] + C[:, 1, 1])))
    v = float(np.sqrt(np.mean(C[:, 2, 2])))
    # ω is the rotation in the source frame: its horizontal part in the target frame is Q·ω's x, y
    Qc = sim.rotation @ cov[1:4, 1:4] @ sim.rotation.T
    tilt = float(np.degrees(np.sqrt(Qc[0, 0] + Qc[1, 1])))
    return Precision(h, v, tilt, cond)


@dataclass(frozen=True)
class RobustSimilarity:
    """The fit, the index of the point left out (or None), the residuals ``(N, 3)`` of every point (the left-out
    one included) and the χ² per degree of freedom of the points kept."""

    similarity: Similarity3D
    left_out: int | None
    residuals: np.ndarray
    chi2_dof: float


def _fit_test(x, y, sigma, keep) -> tuple:
    w = 1.0 / np.mean(sigma[keep] ** 2, axis=1)
    sim = fit_similarity(x[keep], y[keep], w)
    r = sim.apply(x) - y
    dof = max(3 * int(keep.sum()) - 7, 1)
    return sim, r, float(np.sum((r[keep] / sigma[keep]) ** 2) / dof)


def robust_similarity(x, y, sigma) -> RobustSimilarity:
    """The similarity ``y ≈ s·Q·x + t`` with per-axis σ ``(N, 3)``, leaving out one blunder (module docstring):
    tried when the fit of all fails ``χ²/dof ≤`` :data:`CHI2_DOF_MAX` and at least 5 points are given (4 left)."""
    x, y, sigma = (np.asarray(a, np.float64) for a in (x, y, sigma))
    keep = np.ones(len(x), bool)
    sim, r, chi = _fit_test(x, y, sigma, keep)
    if chi <= CHI2_DOF_MAX or len(x) < 5:
        return RobustSimilarity(sim, None, r, chi)
    best = None
    for i in range(len(x)):
        k = keep.copy()
        k[i] = False
        s_i, r_i, c_i = _fit_test(x, y, sigma, k)
        out = float(np.sum((r_i[i] / sigma[i]) ** 2))  # how far the left-out point is from the others' fit
        if best is None or out > best[0]:
            best = (out, i, s_i, r_i, c_i)
    _, i, sim, r, chi = best
    return RobustSimilarity(sim, i, r, chi)
