"""Shared machinery of the ground -> image orientation models, and the 3-D DLT.

3-D models map ``src = (X, Y, Z)`` ground points (``src_dims = 3``) to ``dst = (col, row)``
pixels (GDAL corner convention). The same classes can be fitted the other way round, image
-> ground, by passing ``src = (col, row, Z)`` and ``dst = (X, Y)``: the equations only see a
3-D source and a 2-D destination (the ``-i2g`` RFM names record that direction).

``inverse(dst, heights)`` of a 3-D model needs the third source coordinate. A number or an
``(N,)`` array is that height (or, for an image -> ground fit, the height that goes with the
pixel), and the first two source coordinates are found by Newton's method at that fixed
height. A :class:`~fotogeo.geometry.dem.HeightSource` (a DEM) instead is intersected
(ground -> image models): ``Z`` is updated from the DEM's height at ``(X, Y)`` until it
changes by less than ``tol_z``, point by point: a point that has converged keeps the answer of
that step and is not iterated further (``FittedModel._intersect``).

Estimation runs in normalised coordinates (:class:`~fotogeo.models.base.Normalisation`),
records diagnostics in ``model.info`` (``cond``: condition number of the weighted design
matrix in normalised coordinates; ``rank``: its numerical rank; ``relief``: the ratio of
the source's third-axis range to its horizontal range; ``coverage``: the fraction of a 4x4
grid over the points' normalised extent that holds a point) and warns with
:class:`IllPosedWarning` when the problem is ill-posed: nearly flat terrain (relief <
``RELIEF_WARN``) for a model with height terms, a condition number above ``cond_warn``,
fewer observations than ``redundancy_warn`` x parameters, or clustered points (coverage <
``COVERAGE_WARN``, models with more than 8 parameters, 16 points or more). The warnings are also listed in
``info["ill_posed"]``.

DLT (11 parameters, ≥ 6 points, not all coplanar): ``col = (L1 X + L2 Y + L3 Z + L4) /
(L9 X + L10 Y + L11 Z + 1)``, ``row = (L5 X + L6 Y + L7 Z + L8) / (L9 X + L10 Y + L11 Z + 1)``
— an exact pinhole camera. Solved by the linear (homogeneous, SVD) DLT in normalised
coordinates, then refined by Gauss-Newton on the weighted image error.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import IllPosedWarning, InputError, ModelError
from ..geometry.dem import heights_at, is_height_source
from ..geometry.georeference import intersect_terrain
from .base import Model, Normalisation, check_pairs, newton_2d, register_model
from .threads import blas_threads_for

#: condition number (normalised weighted design) above which a fit is reported ill-posed
COND_WARN = 1e7
#: relief ratio below which height terms are reported as poorly determined
RELIEF_WARN = 0.01
#: occupied fraction of a 4x4 grid over the points' extent below which they count as clustered
COVERAGE_WARN = 0.5


def design_diagnostics(A: np.ndarray, w: np.ndarray | None = None) -> tuple[float, int]:
    """Condition number and numerical rank (rtol 1e-12) of ``sqrt(w)·A``."""
    Aw = A if w is None else A * np.sqrt(w)[:, None]
    s = np.linalg.svd(Aw, compute_uv=False)
    if s.size == 0 or s[0] == 0:
        return float("inf"), 0
    rank = int(np.sum(s > s[0] * 1e-12))
    cond = float(s[0] / s[-1]) if s[-1] > 0 and len(s) == A.shape[1] else float("inf")
    return cond, rank


def coverage(s: np.ndarray, cells: int = 4) -> float:
    """Fraction of a ``cells`` x ``cells`` grid over [-1, 1]² (first two normalised axes) holding a point."""
    ij = np.clip(((s[:, :2] + 1.0) / 2.0 * cells).astype(int), 0, cells - 1)
    return len(np.unique(ij[:, 0] * cells + ij[:, 1])) / cells ** 2


class FittedModel(Model):
    """A :class:`Model` whose ``_fit`` returns ``(params, info)``; checks and warns on ill-posedness."""

    #: models whose equations contain the third source axis (height) as a variable
    uses_height = False
    #: warn above this condition number of the (normalised, weighted) design
    cond_warn = COND_WARN
    #: warn when observations (2 per point) < redundancy_warn x parameters
    redundancy_warn = 1.0

    @classmethod
    def estimate(cls, src, dst, weights=None):
        """Weighted least-squares estimate from ``src`` -> ``dst`` pairs (see the module doc)."""
        src, dst, w = check_pairs(cls, src, dst, weights)
        sn, dn = Normalisation.of(src[w > 0], cls.isotropic), Normalisation.of(dst[w > 0], cls.isotropic)
        with blas_threads_for(2 * len(src), cls.n_params):  # small fits: one BLAS thread (models/threads.py)
            params, info = cls._fit(sn.normalise(src), dn.normalise(dst), w)
        info = dict(info)
        info.setdefault("n_points", int(np.count_nonzero(w)))
        info["coverage"] = coverage(sn.normalise(src[w > 0]))
        if cls.src_dims == 3:
            span = src[w > 0].max(axis=0) - src[w > 0].min(axis=0)
            info["relief"] = float(span[2] / max(span[0], span[1], 1e-300))
        model = cls(np.asarray(params, dtype=np.float64), sn, dn, info)
        model._warn_if_ill_posed()
        return model

    def _warn_if_ill_posed(self):
        info, problems = self.info, []
        if self.uses_height and info.get("relief", 1.0) < RELIEF_WARN:
            problems.append(f"nearly flat terrain (height range / horizontal range = {info['relief']:.2g} "
                            f"< {RELIEF_WARN}): the height terms are poorly determined; use a 2-D model "
                            "(projective, poly1-3) or add points at other heights")
        cond = np.max(np.atleast_1d(info.get("cond", 0.0)))
        if cond > self.cond_warn:
            problems.append(f"condition number {cond:.3g} > {self.cond_warn:.0g}: the points do not determine "
                            "all parameters; add points spread over the image (and heights)")
        n = info.get("n_points", np.inf)
        if 2 * n < self.redundancy_warn * self.n_params:
            problems.append(f"few points: {n} points ({2 * n} observations) for {self.n_params} parameters; "
                            "the higher-order terms are set by the regularisation, not by the data")
        cov = info.get("coverage", 1.0)
        if self.n_params > 8 and n >= 16 and cov < COVERAGE_WARN:  # not for (RANSAC) minimal sets
            problems.append(f"points clustered: they occupy {cov:.0%} of a 4x4 grid over their extent; "
                            "predictions between and beyond the clusters are extrapolations")
        if problems:
            info["ill_posed"] = problems
            warnings.warn(f"model {self.name!r}: " + "; ".join(problems), IllPosedWarning, stacklevel=3)

    # -- inverse of 3-D models ---------------------------------------------------------------
    def inverse(self, dst, heights=None, *, iterations: int = 30, tol: float = 1e-12, tol_z: float = 1e-4):
        """First two source coordinates of ``dst`` at fixed ``heights`` or on a DEM (module doc).

        2-D models ignore ``heights`` and use the Newton inverse of the base class.
        """
        if self.src_dims == 2:
            return super().inverse(dst, iterations=iterations, tol=tol)
        dst = np.asarray(dst, dtype=np.float64)
        if dst.ndim != 2 or dst.shape[1] != 2:
            raise InputError(f"{self.name}: points to invert must have shape (N, 2); got {dst.shape}")
        if heights is None:
            raise InputError(f"{self.name}: the inverse of a 3-D model needs the height: pass heights= "
                             "(a number, one per point, or a DEM)")
        if not is_height_source(heights):
            z = np.broadcast_to(np.asarray(heights, dtype=np.float64), (len(dst),))
            return self._inverse_at(dst, z, iterations, tol)
        return self._intersect(dst, heights, iterations, tol, tol_z)

    def _intersect(self, dst, src, iterations, tol, tol_z):
        """Ray–DEM intersection by fixed point on ``Z``, iterating only the points still moving
        (:func:`fotogeo.geometry.georeference.intersect_terrain`); ``src`` is sampled for heights only
        (:func:`~fotogeo.geometry.dem.heights_at`: no gradient, which a callable's central differences would
        cost four more samplings each).

        Step k: ``Z_k = h(XY_{k-1})``, ``XY_k`` = the inverse at ``Z_k`` (Newton, started at
        ``XY_{k-1}``). A point converges at the step where ``|Z_k − Z_{k-1}| < tol_z`` (or ``Z_k``
        is NaN: off the DEM) and keeps ``XY_k``; the others go on, at most ``iterations`` steps. ``Z_0``: the
        model's height offset, moved into the source's ``z_range`` when it has one: a ray started above or below
        every height of a small DEM lands beside it, off the terrain, and is lost.
        """
        z0 = float(self.src_norm.offset[2])
        zr = getattr(src, "z_range", None)
        if zr is not None and np.isfinite(zr).all():
            z0 = min(max(z0, float(zr[0])), float(zr[1]))
        z0 = np.full(len(dst), z0)
        return intersect_terrain(lambda idx, z, start: self._inverse_at(dst[idx], z, iterations, tol, start=start),
                                 lambda XY: heights_at(src, XY), z0, iterations, tol_z)

    def _inverse_at(self, dst, z, iterations, tol, start=None):
        d = self.dst_norm.normalise(dst)
        zn = (z - self.src_norm.offset[2]) / self.src_norm.scale[2]
        s0 = np.zeros((len(d), 2)) if start is None else self.src_norm.normalise(start)[:, :2]
        s0 = np.where(np.isfinite(s0), s0, 0.0)
        s = newton_2d(self._apply, d, s0, iterations, tol, extra=zn[:, None])
        return self.src_norm.denormalise(np.column_stack([s, zn]))


@register_model
class DLT(FittedModel):
    name = "dlt"
    n_params = 11
    min_points = 6
    src_dims = 3
    uses_height = True

    @property
    def matrix(self) -> np.ndarray:
        """3x4 projection matrix in normalised coordinates (``P[2, 3] = 1``)."""
        return self.params.reshape(3, 4)

    def _apply(self, s):
        P = self.matrix
        h = s @ P[:, :3].T + P[:, 3]
        return h[:, :2] / h[:, 2:3]

    @property
    def projection_centre(self) -> np.ndarray:
        """The camera's projection centre ``(X, Y, Z)``: the ground point the 3x4 matrix maps to nothing
        (``W [C; 1] = 0``); NaN where the matrix is singular."""
        W = self.world_matrix()
        try:
            return -np.linalg.solve(W[:, :3], W[:, 3])
        except np.linalg.LinAlgError:
            return np.full(3, np.nan)

    def world_matrix(self) -> np.ndarray:
        """3x4 matrix mapping real (X, Y, Z, 1) to homogeneous real pixels (scaled so P[2,3] = 1)."""
        S = np.diag([*(1 / self.src_norm.scale), 1.0])
        S[:3, 3] = -self.src_norm.offset / self.src_norm.scale
        D = np.diag([*self.dst_norm.scale, 1.0])
        D[:2, 2] = self.dst_norm.offset
        W = D @ self.matrix @ S
        return W / W[2, 3]

    @classmethod
    def _fit(cls, s, d, w, iterations: int = 15):
        n = len(s)
        Xh = np.column_stack([s, np.ones(n)])
        z = np.zeros((n, 4))
        A = np.empty((2 * n, 12))
        A[0::2] = np.column_stack([Xh, z, -d[:, :1] * Xh])
        A[1::2] = np.column_stack([z, Xh, -d[:, 1:] * Xh])
        A *= np.sqrt(np.repeat(w, 2))[:, None]
        _, sv, vt = np.linalg.svd(A, full_matrices=False)
        if len(sv) < 11 or sv[10] < 1e-9 * sv[0]:
            raise ModelError("model 'dlt': the points are degenerate — coplanar (flat terrain), collinear or "
                             "duplicated; DLT needs ≥ 6 points not on one plane (use 'projective' for flat terrain)")
        P = vt[-1].reshape(3, 4)
        P = P / P[2, 3] if abs(P[2, 3]) > 1e-12 else P / np.linalg.norm(P)
        p, cond = cls._refine(P.ravel()[:11], s, d, w, iterations)
        cond_lin = float(sv[0] / sv[10])
        return np.append(p, 1.0), {"cond": cond, "cond_linear": cond_lin, "rank": 11 if np.isfinite(cond) else 10}

    @staticmethod
    def _refine(p, s, d, w, iterations):
        """Gauss-Newton on L1..L11 minimising Σ w |d - P(s)|²; returns params and cond of the Jacobian."""
        sw = np.sqrt(np.repeat(w, 2))
        n = len(s)
        Xh = np.column_stack([s, np.ones(n)])
        cond = float("inf")
        for _ in range(iterations):
            P = np.append(p, 1.0).reshape(3, 4)
            den = Xh @ P[2]
            if np.any(np.abs(den) < 1e-9):
                break
            u, v = (Xh @ P[0]) / den, (Xh @ P[1]) / den
            J = np.zeros((2 * n, 11))
            J[0::2, 0:4] = Xh / den[:, None]
            J[1::2, 4:8] = Xh / den[:, None]
            J[0::2, 8:11] = -u[:, None] * s / den[:, None]
            J[1::2, 8:11] = -v[:, None] * s / den[:, None]
            r = (d - np.column_stack([u, v])).reshape(-1)
            Jw = J * sw[:, None]
            q, rj = np.linalg.qr(Jw)
            sv = np.linalg.svd(rj, compute_uv=False)
            if sv[-1] <= sv[0] * max(Jw.shape) * np.finfo(float).eps:  # rank < 11, as lstsq decides it
                cond = float("inf")
                step = np.linalg.lstsq(Jw, r * sw, rcond=None)[0]
            else:
                cond = float(sv[0] / sv[-1])
                step = np.linalg.solve(rj, q.T @ (r * sw))
            p = p + step
            if np.max(np.abs(step)) < 1e-13:
                break
        return p, cond
