"""Plane-to-plane models as 3x3 matrices: similarity, affine 2-D, projective (homography).

In normalised coordinates ``s`` (source) and ``d`` (destination), each model is a matrix
``M`` with ``[d; 1] ~ M [s; 1]``:

* similarity (4 parameters, ≥3 points): ``d = [[a, -b], [b, a]] s + t`` (proper: scale,
  rotation, shift) or ``d = [[a, b], [b, -a]] s + t`` (improper: the same after a mirror),
  whichever fits with the smaller weighted residual. Pixel → map needs the improper one
  (rows grow down, Y grows up), map → map the proper one; two points fit both exactly, so
  three are needed, and collinear points cannot tell them apart (refused);
* affine (6 parameters, ≥3 points): ``d = A s + t``;
* projective (8 parameters, ≥4 points): ``d = (H[:2] [s; 1]) / (H[2] [s; 1])``, fitted by the
  normalised DLT (Hartley) and refined by Gauss-Newton on the weighted geometric error
  ``Σ w |d - H(s)|²``.

The linear models (similarity, affine) check the numerical rank of their weighted design in
normalised coordinates (singular values below ``1e-10`` of the largest count as zero), so
exactly collinear points are refused as projective and the polynomials refuse them, instead
of being interpolated with a zero residual by a rounding-level singular value.

``world_matrix()`` gives the same mapping in real (un-normalised) coordinates. A matrix model
folds a region (:meth:`~fotogeo.models.base.Model.folds`) when its horizon, the line
``M[2, :2]·xy + M[2, 2] = 0`` in real source coordinates, crosses it: the denominator must
keep one sign over the region's points (always so for similarity and affine).
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .base import Model, register_model, weighted_lstsq

#: relative singular value below which a linear design counts as rank deficient
RANK_RTOL = 1e-10


def _check_rank(A: np.ndarray, w: np.ndarray, name: str, what: str = "collinear, duplicated or too clustered"):
    """Refuse a weighted design ``sqrt(w)·A`` whose numerical rank (rtol :data:`RANK_RTOL`) is deficient."""
    sv = np.linalg.svd(A * np.sqrt(w)[:, None], compute_uv=False)
    rank = int(np.sum(sv > sv[0] * RANK_RTOL)) if sv[0] > 0 else 0
    if rank < A.shape[1]:
        raise ModelError(f"model {name!r}: the points are degenerate ({what}) — rank {rank} < {A.shape[1]} "
                         f"parameters; spread the points over the image")


class _MatrixModel(Model):
    """Shared machinery of the 3x3-matrix models."""

    @property
    def matrix(self) -> np.ndarray:
        return self.params.reshape(3, 3)

    def _apply(self, s):
        M = self.matrix
        h = s @ M[:, :2].T + M[:, 2]
        return h[:, :2] / h[:, 2:3]

    def inverse(self, dst, heights=None, **_):
        """Closed-form inverse through the inverted matrix (``heights`` is ignored: a 2-D model)."""
        d = self.dst_norm.normalise(np.asarray(dst, dtype=np.float64))
        Mi = np.linalg.inv(self.matrix)
        h = d @ Mi[:, :2].T + Mi[:, 2]
        return self.src_norm.denormalise(h[:, :2] / h[:, 2:3])

    def world_matrix(self) -> np.ndarray:
        """3x3 matrix mapping real source coordinates to real destination coordinates."""
        S = np.diag([*(1 / self.src_norm.scale), 1.0])
        S[:2, 2] = -self.src_norm.offset / self.src_norm.scale
        D = np.diag([*self.dst_norm.scale, 1.0])
        D[:2, 2] = self.dst_norm.offset
        W = D @ self.matrix @ S
        return W / W[2, 2]

    def folds(self, points) -> bool:
        """True when the horizon of the matrix crosses the region outlined by ``points`` (module doc)."""
        M = self.world_matrix()
        den = np.asarray(points, dtype=np.float64) @ M[2, :2] + M[2, 2]
        return not (np.all(den > 0) or np.all(den < 0))


@register_model
class Similarity(_MatrixModel):
    name = "similarity"
    n_params = 4
    min_points = 3  # two points fit a proper and an improper similarity exactly
    isotropic = True  # a similarity stays one only under equal scaling of both axes

    @classmethod
    def _fit(cls, s, d, w):
        _check_rank(np.column_stack([s, np.ones(len(s))]), w, cls.name,
                    "collinear: a mirror about their line fits as well, so the similarity is undetermined")
        fits = [cls._fit_handed(s, d, w, mirror) for mirror in (False, True)]
        return min(fits, key=lambda f: f[1])[0]

    def param_directions(self) -> np.ndarray:
        """(9, 4) directions of ``a``, ``b``, ``tx``, ``ty`` in the stored 3x3 matrix (proper or
        improper, as fitted): the free parameters, e.g. for the redundancy numbers of data snooping."""
        mirror = np.linalg.det(self.matrix[:2, :2]) < 0
        D = np.zeros((3, 3, 4))
        D[0, 0, 0], D[1, 1, 0] = 1.0, (-1.0 if mirror else 1.0)
        D[1, 0, 1], D[0, 1, 1] = 1.0, (1.0 if mirror else -1.0)
        D[0, 2, 2] = D[1, 2, 3] = 1.0
        return D.reshape(9, 4)

    @classmethod
    def _fit_handed(cls, s, d, w, mirror: bool):
        """Weighted least-squares proper (``mirror`` False) or improper similarity: (matrix, Σ w r²)."""
        n = len(s)
        x, y = s[:, 0], (-s[:, 1] if mirror else s[:, 1])  # improper = proper after y -> -y
        A = np.zeros((2 * n, 4))
        A[0::2] = np.column_stack([x, -y, np.ones(n), np.zeros(n)])
        A[1::2] = np.column_stack([y, x, np.zeros(n), np.ones(n)])
        ww = np.repeat(w, 2)
        p = weighted_lstsq(A, d.reshape(-1), ww, cls.name)
        a, b, tx, ty = p
        M = np.array([[a, -b, tx], [b, a, ty], [0, 0, 1.0]])
        if mirror:
            M[:, 1] *= -1
        return M.ravel(), float(np.sum(ww * (A @ p - d.reshape(-1)) ** 2))


@register_model
class Affine(_MatrixModel):
    name = "affine"
    n_params = 6
    min_points = 3

    @classmethod
    def _fit(cls, s, d, w):
        A = np.column_stack([s, np.ones(len(s))])
        _check_rank(A, w, cls.name)
        X = weighted_lstsq(A, d, w, cls.name)  # (3, 2)
        return np.vstack([X.T, [0, 0, 1.0]]).ravel()


@register_model
class Projective(_MatrixModel):
    name = "projective"
    n_params = 8
    min_points = 4

    @classmethod
    def _fit(cls, s, d, w, iterations: int = 10):
        n = len(s)
        x, y, u, v = s[:, 0], s[:, 1], d[:, 0], d[:, 1]
        z, o = np.zeros(n), np.ones(n)
        A = np.empty((2 * n, 9))
        A[0::2] = np.column_stack([x, y, o, z, z, z, -u * x, -u * y, -u])
        A[1::2] = np.column_stack([z, z, z, x, y, o, -v * x, -v * y, -v])
        A *= np.sqrt(np.repeat(w, 2))[:, None]
        # the thin SVD suffices once A has 9 rows; 4 points need the full one for the null space
        _, sv, vt = np.linalg.svd(A, full_matrices=2 * n < 9)
        if len(sv) < 8 or sv[7] < 1e-9 * sv[0]:
            raise ModelError("model 'projective': the points are degenerate (collinear or duplicated)")
        H = vt[-1].reshape(3, 3)
        H = H / H[2, 2] if abs(H[2, 2]) > 1e-12 else H / np.linalg.norm(H)
        if n == cls.min_points:  # a minimal sample is interpolated exactly: nothing to refine
            return H.ravel()
        return cls._refine(H, s, d, w, iterations).ravel()

    @staticmethod
    def _refine(H, s, d, w, iterations):
        """Gauss-Newton on the 8 parameters (h33 = 1) minimising the weighted geometric error."""
        h = H.ravel()[:8].copy()
        sw = np.sqrt(np.repeat(w, 2))
        x, y = s[:, 0], s[:, 1]
        for _ in range(iterations):
            den = h[6] * x + h[7] * y + 1.0
            if np.any(np.abs(den) < 1e-9):
                break
            pu = (h[0] * x + h[1] * y + h[2]) / den
            pv = (h[3] * x + h[4] * y + h[5]) / den
            J = np.zeros((2 * len(x), 8))
            J[0::2, 0], J[0::2, 1], J[0::2, 2] = x / den, y / den, 1 / den
            J[1::2, 3], J[1::2, 4], J[1::2, 5] = x / den, y / den, 1 / den
            J[0::2, 6], J[0::2, 7] = -pu * x / den, -pu * y / den
            J[1::2, 6], J[1::2, 7] = -pv * x / den, -pv * y / den
            r = (d - np.column_stack([pu, pv])).reshape(-1)
            step, *_ = np.linalg.lstsq(J * sw[:, None], r * sw, rcond=None)
            h += step
            if np.max(np.abs(step)) < 1e-12:
                break
        return np.append(h, 1.0).reshape(3, 3)
