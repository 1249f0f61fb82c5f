"""Precision of a least-squares estimate: the inverse of its normal matrix and the σ it says (array layer).

``N⁻¹`` is taken with ``N`` scaled to a unit diagonal first, ``Ñ = D⁻¹ N D⁻¹`` with ``D = √diag(N)``, and a ridge
of :data:`RIDGE` added to ``Ñ``'s diagonal, so a singular ``N`` still inverts (:func:`ridge_inverse`; Cholesky,
LAPACK ``potrf``/``potri``, falling back to the general and then the pseudo-inverse). A parameter's variance
inflation ``N_ii·(N⁻¹)_ii`` is 1 when nothing else correlates with it and ``1 / (1 − ϱ_i²)`` with ``ϱ_i`` its
multiple correlation with the other unknowns; :func:`determined_sqrt` reads a parameter whose inflation exceeds
:data:`UNDETERMINED_INFLATION` as undetermined (NaN σ). The space resection
(:mod:`fotogeo.models.collinearity`) and the bundle (:mod:`fotogeo.orientation.bundle_result`) both read
undetermined by this rule.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

#: added to the unit diagonal of the scaled normal matrix before it is inverted (:func:`ridge_inverse`)
RIDGE = 1e-12

#: a parameter whose variance inflation ``N_ii·(N⁻¹)_ii`` exceeds this is undetermined (NaN σ). The ridge
#: (:data:`RIDGE` on the unit diagonal) puts a direction the system leaves free at an inflation near ``v_i²·1e12``
#: (``v`` the free direction) — or, after rounding in the BLAS at hand, at any sign and size — so above 1e10 the
#: ridge supplies a percent or more of the parameter's information: its σ says nothing of the data. A parameter held
#: only by a prior stays far below (2.5e8 measured: the roll of a three-frame drone strip held by its 5° attitude
#: prior).
UNDETERMINED_INFLATION = 1e10


def unit_scaled(N: np.ndarray) -> tuple:
    """``(Ñ, d)``: ``Ñ = N / d dᵀ`` with :data:`RIDGE` added to its diagonal, ``d = √diag(N)`` (module docstring)."""
    d = np.sqrt(np.maximum(np.diag(N), 1e-300))
    Nn = N / d[:, None] / d[None, :]
    Nn[np.diag_indices(len(N))] += RIDGE
    return Nn, d


def dense_inverse(Nn: np.ndarray) -> np.ndarray:
    """The inverse of the symmetric ``Nn`` by Cholesky (``potrf``, ``potri``: a third of the work of a general
    inverse); the general inverse when ``Nn`` is not positive definite, the pseudo-inverse when it is singular."""
    c, info = lapack.dpotrf(Nn, lower=0)
    if info == 0:
        inv, info = lapack.dpotri(c, lower=0)
    if info == 0:
        return np.triu(inv) + np.triu(inv, 1).T
    try:
        return np.linalg.inv(Nn)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(Nn)


def ridge_inverse(N: np.ndarray) -> np.ndarray:
    """``N⁻¹`` of a small dense normal matrix, scaled to a unit diagonal with a ridge (module docstring)."""
    Nn, d = unit_scaled(N)
    return dense_inverse(Nn) / d[:, None] / d[None, :]


def determined_sqrt(variance, inflation=None) -> np.ndarray:
    """``√variance``, NaN where it is negative or where its ``inflation`` (``N_ii·(N⁻¹)_ii``) is not finite or above
    :data:`UNDETERMINED_INFLATION`: a singular system (a parameter nothing determines) inverts with a diagonal of any
    sign and size there; clipped to 0 it read as a perfect σ (the free position of a frame whose points have no third
    ray came out σ 0 m), on another BLAS as 5e3 km."""
    variance = np.asarray(variance, float)
    with np.errstate(invalid="ignore"):
        return np.where(undetermined(variance, inflation), np.nan, np.sqrt(np.abs(variance)))


def undetermined(variance, inflation=None) -> np.ndarray:
    """Where :func:`determined_sqrt` reads NaN: ``variance`` negative (or NaN), or its ``inflation`` not finite or
    above :data:`UNDETERMINED_INFLATION`. A covariance's rows and columns of such parameters say nothing of the
    data either (the bundle's report blanks them by this rule)."""
    variance = np.asarray(variance, float)
    ok = variance >= 0
    if inflation is not None:
        ok &= np.isfinite(inflation) & (np.asarray(inflation, float) <= UNDETERMINED_INFLATION)
    return ~ok
