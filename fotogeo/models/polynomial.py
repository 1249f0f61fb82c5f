"""Polynomial orientation models, linear in their parameters (weighted least squares).

All work in normalised coordinates (``u, v[, w]`` = source X, Y[, Z]; both destination axes
use the same terms with their own coefficients):

* ``bilinear`` (2-D, 8 parameters, ≥ 4 points): ``x = a0 + a1 u + a2 v + a3 u v``;
* ``poly1`` / ``poly2`` / ``poly3`` (2-D; 6 / 12 / 20 parameters; ≥ 3 / 6 / 10 points):
  all monomials ``u^i v^j`` with ``i + j ≤ n`` (terms of :func:`terms_2d`); poly1 is an
  affine transformation, and these are the models of GDAL's ``-order 1..3``;
* ``affine-height`` (3-D, 8 parameters, ≥ 4 points): ``x = a0 + a1 X + a2 Y + a3 Z``
  (Öztürk et al.: the "affine with height" model; same as ``poly3d-1``);
* ``poly3d-1`` / ``poly3d-2`` / ``poly3d-3`` (3-D; 8 / 20 / 40 parameters; ≥ 4 / 10 / 20
  points): all monomials of degree ≤ n in ``(u, v, w)``, in the RPC00B term order of
  :func:`terms_3d` (poly3d-3 is the "no denominator" cubic RFM without regularisation).

Parameters are stored as ``(n_terms, 2)`` raveled: ``params.reshape(-1, 2)[:, k]`` are the
coefficients of destination axis ``k``.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .base import register_model
from .spatial import FittedModel, design_diagnostics


def terms_2d(s: np.ndarray, degree: int) -> np.ndarray:
    """Monomials ``u^i v^j`` (i + j ≤ degree) ordered by degree: 1, u, v, u², uv, v², u³, u²v, uv², v³."""
    u, v = s[:, 0], s[:, 1]
    cols = [np.ones(len(s))]
    for k in range(1, degree + 1):
        cols += [u ** (k - j) * v ** j for j in range(k + 1)]
    return np.column_stack(cols)


def terms_3d(s: np.ndarray, n_terms: int = 20) -> np.ndarray:
    """The first ``n_terms`` (4, 10 or 20) cubic monomials of ``(L, P, H) = (u, v, w)`` in RPC00B order.

    1, L, P, H, LP, LH, PH, L², P², H², PLH, L³, LP², LH², L²P, P³, PH², L²H, P²H, H³ — with L
    the first source axis (longitude / X / col), P the second (latitude / Y / row), H the third.
    """
    L, P, H = (np.ascontiguousarray(s[:, k], dtype=np.float64) for k in range(3))
    t = np.empty((20, len(s)))  # one contiguous row per term, returned transposed (no column copies)
    t[0], t[1], t[2], t[3] = 1.0, L, P, H
    np.multiply(L, P, out=t[4]), np.multiply(L, H, out=t[5]), np.multiply(P, H, out=t[6])
    np.multiply(L, L, out=t[7]), np.multiply(P, P, out=t[8]), np.multiply(H, H, out=t[9])
    np.multiply(t[4], H, out=t[10]), np.multiply(t[7], L, out=t[11]), np.multiply(t[8], L, out=t[12])
    np.multiply(t[9], L, out=t[13]), np.multiply(t[7], P, out=t[14]), np.multiply(t[8], P, out=t[15])
    np.multiply(t[9], P, out=t[16]), np.multiply(t[7], H, out=t[17]), np.multiply(t[8], H, out=t[18])
    np.multiply(t[9], H, out=t[19])
    return t[:n_terms].T


#: total degree of each RPC00B term (first 4: ≤ 1, first 10: ≤ 2)
TERM_DEGREE_3D = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3])


class _LinearPolynomial(FittedModel):
    """Shared weighted-LS fit for models ``dst = terms(src) @ C``."""

    @classmethod
    def _terms(cls, s):
        raise NotImplementedError

    @classmethod
    def _fit(cls, s, d, w):
        A = cls._terms(s)
        cond, rank = design_diagnostics(A, w)
        if rank < A.shape[1]:
            raise ModelError(f"model {cls.name!r}: the points are degenerate (collinear, coplanar, "
                             f"duplicated or too clustered) — rank {rank} < {A.shape[1]} terms; use a "
                             "lower-order model or spread the points")
        sw = np.sqrt(w)[:, None]
        C, *_ = np.linalg.lstsq(A * sw, d * sw, rcond=None)
        return C.ravel(), {"cond": cond, "rank": rank}

    def _apply(self, s):
        return self._terms(s) @ self.params.reshape(-1, 2)


@register_model
class Bilinear(_LinearPolynomial):
    name = "bilinear"
    n_params = 8
    min_points = 4

    @classmethod
    def _terms(cls, s):
        return np.column_stack([np.ones(len(s)), s[:, 0], s[:, 1], s[:, 0] * s[:, 1]])


def _poly2d(degree: int):
    n_terms = (degree + 1) * (degree + 2) // 2

    class Poly(_LinearPolynomial):
        name = f"poly{degree}"
        n_params = 2 * n_terms
        min_points = n_terms
        __doc__ = f"2-D polynomial of degree {degree} ({n_terms} terms per axis; GDAL -order {degree})."

        @classmethod
        def _terms(cls, s):
            return terms_2d(s, degree)

    Poly.__name__ = Poly.__qualname__ = f"Poly{degree}"
    return register_model(Poly)


def _poly3d(degree: int, name: str | None = None, cls_name: str | None = None):
    n_terms = {1: 4, 2: 10, 3: 20}[degree]

    class Poly3D(_LinearPolynomial):
        n_params = 2 * n_terms
        min_points = n_terms
        src_dims = 3
        uses_height = True
        __doc__ = f"3-D polynomial of degree {degree} in (X, Y, Z) ({n_terms} RPC00B-ordered terms per axis)."

        @classmethod
        def _terms(cls, s):
            return terms_3d(s, n_terms)

    Poly3D.name = name or f"poly3d-{degree}"
    Poly3D.__name__ = Poly3D.__qualname__ = cls_name or f"Poly3D{degree}"
    return register_model(Poly3D)


Poly1, Poly2, Poly3 = _poly2d(1), _poly2d(2), _poly2d(3)
Poly3D1, Poly3D2, Poly3D3 = _poly3d(1), _poly3d(2), _poly3d(3)
AffineHeight = _poly3d(1, "affine-height", "AffineHeight")
AffineHeight.__doc__ = "Affine with height: x = a0 + a1 X + a2 Y + a3 Z (8 parameters, ≥ 4 points)."
