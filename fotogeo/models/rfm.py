"""Rational Function Models (RFM / RPC) with cubic numerators and denominators.

In normalised coordinates (RPC00B style: ``u = (x − offset) / scale``, about [−1, 1]; the
offsets/scales are the model's ``src_norm`` / ``dst_norm``), with ``t(s)`` the 20 cubic terms
of :func:`~fotogeo.models.polynomial.terms_3d` in RPC00B order (``L, P, H`` = first, second,
third source axis)::

    x = (a · t(s)) / (b · t(s)),    y = (c · t(s)) / (d · t(s)),    b0 = d0 = 1

Variants (Öztürk et al.; Tao & Hu 2001):

* ``rfm`` — separate denominators ``b ≠ d`` (20 + 19 per axis, 78 parameters);
* ``rfm-common`` — one common denominator ``b = d`` (59 parameters);
* ``rfm-poly`` — no denominator ``b = d = (1, 0, …)``: a cubic polynomial (40 parameters).

Direction: ``rfm*`` classes are fitted ground -> image (``src = (X, Y, Z)``, ``dst = (col,
row)``, like RPC00B). The ``rfm*-i2g`` classes are the same equations fitted image ->
ground: ``src = (col, row, Z)``, ``dst = (X, Y)``; their ``inverse(XY, heights)`` gives pixels.

Solution (linearised, iterative, regularised): each rational equation is multiplied by its
denominator, ``a·t − x (b·t) = 0``, which is linear in the parameters: rows
``[t, −x·t₁..₁₉] p = x``. Each iteration re-weights the rows by ``w / Q²`` with ``Q = b·t``
from the previous iteration, so the minimised quantity tends to the true image error
Σ w (x − a·t / b·t)² (Tao & Hu's iterative least squares); both axes are solved in one
system. Every solve is Tikhonov-regularised, ``min ‖W^½(A p − l)‖² + λ² ‖L p‖²``, where
``L`` selects the coefficients of the second- and third-degree terms (the constant and
linear terms are free) and, for ``rfm``, also the difference ``b − d`` of the two
denominators. Strong regularisation thus tends to the first-order rational function with a
common denominator — the 11-parameter DLT, already exact for a pinhole frame camera — and
weak regularisation to the full cubic RFM (exact for a satellite RPC).

Choice of λ (documented decision): generalised cross-validation and the L-curve were
considered; GCV was tried first and picks too little regularisation when the number of
observations is close to the number of parameters (40 GCPs, 78 parameters: check RMS
7.9/7.4 px on the ngi frame against 0.13/0.14 px now). λ is therefore chosen by exact
leave-one-out cross-validation of the linear smoother, ``PRESS(λ) = Σ (rᵢ / (1 − Hᵢᵢ))²``
(``H_λ`` the influence matrix), over a logarithmic grid ``λ = σ_max(A) · 10^k``,
``k = −8, −7.75, …, 1`` (σ_max the largest singular value of the weighted design), taking
the *largest* λ whose PRESS is within ``SE_FACTOR`` standard errors (``√n · std(eᵢ²)`` of
the leave-one-out errors ``eᵢ``) plus ``TOLERANCE`` (5 %) of the minimum — the
one-standard-error rule: the simplest model the data cannot tell apart from the best. (Taking
the plain minimum was measured worse with few GCPs: ngi 0182, 10 clustered GCPs, check RMS
4.4/5.3 px against 2.2/4.9 px with the rule; DLT 2.2/4.4 px.) Candidate λ whose solution
has a denominator nearly vanishing inside the normalised cube are skipped. The iteration starts from the unregularised first-order rational fit with a common
denominator (the linear DLT) and stops when the parameters change by < 1e-9.

Speed (issue 15): every λ of the grid is evaluated from one generalised SVD of the weighted
design and ``L`` (:func:`~fotogeo.models.tikhonov.tikhonov_cv`), the x and y rows factorised
apart; and once two successive iterations choose the same λ / σ_max, the next iterations
solve at that λ only (:func:`~fotogeo.models.tikhonov.tikhonov_at`), until the iteration
stops — where cross-validation runs again and, if it picks another λ, the iteration goes
on choosing λ every time. The chosen λ and the solution are those of a solve per λ and
iteration (1000 GCPs on an NGI frame: rfm 9.9 s -> 0.57 s, same check RMSE;
``benchmarks/fits_bench.py``).

``info``: ``lambda`` and ``lambda_rel`` (λ / σ_max) per solved block, ``dof`` (effective
number of parameters tr H), ``cond`` and ``rank`` of the unregularised weighted design (the
effective rank at rtol 1e-12), ``iterations``, ``direction``, ``min_denominator`` (smallest
|Q| over a 5×5×5 grid of the normalised cube, relative to its largest; candidate solutions
below 0.05 are rejected during the λ search). An
:class:`~fotogeo.models.spatial.IllPosedWarning` is issued when there are fewer observations
than twice the parameters (the higher-order terms are then set by the regularisation), when
the points are clustered, on nearly flat terrain, or when a denominator nearly vanishes. The
condition number is reported but not used for warnings: RFM designs are ill-conditioned by
nature (cond 1e6–1e10 even with hundreds of well spread points).
"""
from __future__ import annotations

import functools
import warnings

import numpy as np

from ..errors import ModelError
from .base import register_model
from .polynomial import TERM_DEGREE_3D, terms_3d
from .spatial import FittedModel, IllPosedWarning
from .tikhonov import _LOG_GRID, tikhonov_at, tikhonov_cv

#: terms left unregularised: constant and linear (ground -> image: exact for a frame camera).
#: Image -> ground, a frame camera's exact form at height H, (a + b L + c P + H (d + e L + f P)) /
#: (1 + g L + h P), also has LH and PH terms; leaving those free as well was measured worse on
#: clustered GCPs (ngi 0182, 40/20, 0.3 px: check 4.2/5.3 px against 1.3/1.4 px), so both
#: directions use the same free set.
FREE_TERMS = TERM_DEGREE_3D <= 1


_CUBE = np.stack(np.meshgrid(*[np.linspace(-1, 1, 5)] * 3), -1).reshape(-1, 3)
#: cubic terms of a 5x5x5 grid over the normalised cube (where denominators are checked)
_CUBE_TERMS = terms_3d(_CUBE)


class _RFMBase(FittedModel):
    """Shared RFM machinery; ``variant`` is 'separate', 'common' or 'poly'."""

    src_dims = 3
    uses_height = True
    variant = "separate"
    direction = "ground-to-image"
    free_terms = FREE_TERMS
    # RFM designs are ill-conditioned by nature (denominator columns −x·t nearly proportional
    # to numerator columns): cond 1e6-1e10 even with hundreds of well spread points, so the
    # RFM warns on redundancy (observations < 2 x parameters) and spread instead
    cond_warn = np.inf
    redundancy_warn = 2.0
    #: log10(λ / σ_max) candidates; a subclass with ``np.array([-12.0])`` is the plain,
    #: (numerically) unregularised iterative LS of the paper — for comparisons only
    lambda_grid = _LOG_GRID
    reject_poles = True
    plain = False  # True: the paper's unregularised solve (the ``-plain`` names)

    @property
    def coefficients(self) -> np.ndarray:
        """``(4, 20)``: numerator x, denominator x, numerator y, denominator y (RPC00B order)."""
        return self.params.reshape(4, 20)

    def _apply(self, s):
        v = self.coefficients @ terms_3d(s).T  # (4, N): the four polynomials in one product
        return np.column_stack([v[0] / v[1], v[2] / v[3]])

    @classmethod
    def _blocks(cls, T, d):
        """Linearised design blocks ``(A, l, Lmat, first-order columns)``; their row weights
        (besides ``w``) are :meth:`_block_weights`."""
        high = ~cls.free_terms
        nh = int(high.sum())
        H, H1 = np.eye(20)[high], np.eye(19)[high[1:]]
        lin, lin1 = ~high, ~high[1:]
        if cls.variant == "poly":
            return [(T, d[:, k], H, lin) for k in range(2)]
        z, z1 = np.zeros_like(T), np.zeros_like(T[:, 1:])
        if cls.variant == "separate":
            # unknowns [a (20), c (20), b' (19), d' (19)]; besides the higher-order terms the
            # difference of the two denominators is penalised, so that strong regularisation
            # tends to the common-denominator first-order model: the DLT.
            A = np.vstack([np.column_stack([T, z, -d[:, :1] * T[:, 1:], z1]),
                           np.column_stack([z, T, z1, -d[:, 1:] * T[:, 1:]])])
            L = np.zeros((4 * nh + 19, 78))
            L[0:nh, 0:20], L[nh:2 * nh, 20:40] = H, H
            L[2 * nh:3 * nh, 40:59], L[3 * nh:4 * nh, 59:78] = H1, H1
            L[4 * nh:, 40:59], L[4 * nh:, 59:78] = np.eye(19), -np.eye(19)
            keep = np.concatenate([lin, lin, lin1, lin1])
            return [(A, d.T.reshape(-1), L, keep)]
        A = np.vstack([np.column_stack([T, z, -d[:, :1] * T[:, 1:]]),
                       np.column_stack([z, T, -d[:, 1:] * T[:, 1:]])])
        L = np.zeros((3 * nh, 59))
        L[0:nh, 0:20], L[nh:2 * nh, 20:40], L[2 * nh:, 40:59] = H, H, H1
        keep = np.concatenate([lin, lin, lin1])
        return [(A, d.T.reshape(-1), L, keep)]

    @classmethod
    def _block_weights(cls, q):
        """Row weights ``1 / Q²`` of each block of :meth:`_blocks` from the denominators ``q``."""
        if cls.variant == "poly":
            return [np.ones(len(q))] * 2
        if cls.variant == "separate":
            return [np.concatenate([1.0 / q[:, 0] ** 2, 1.0 / q[:, 1] ** 2])]
        return [np.tile(1.0 / q[:, 0] ** 2, 2)]

    @classmethod
    def _unpack(cls, sols):
        one = np.zeros(20)
        one[0] = 1.0
        if cls.variant == "poly":
            return np.concatenate([sols[0], one, sols[1], one])
        p = sols[0]
        if cls.variant == "separate":
            return np.concatenate([p[:20], [1.0], p[40:59], p[20:40], [1.0], p[59:78]])
        den = np.concatenate([[1.0], p[40:]])
        return np.concatenate([p[:20], den, p[20:40], den])

    @classmethod
    def _solve(cls, blocks, w, q, linear_only=False, lambda_rel=None):
        """One weighted solve of :meth:`_blocks`; λ by cross-validation, or at ``lambda_rel``
        (one per block) if given — then None when a block's solution is rejected (:meth:`_accept`)."""
        sols, lams, rels, dofs, conds, ranks = [], [], [], [], [], []
        for i, ((A, l, L, keep), qw) in enumerate(zip(blocks, cls._block_weights(q))):
            rw = np.sqrt(np.tile(w, len(l) // len(w)) * qw)
            Aw, lw = A * rw[:, None], l * rw
            if linear_only:  # only constant and linear terms, unregularised (separate: the DLT)
                sols.append(cls._linear_start(Aw, lw, keep))
                continue
            rows = cls._row_blocks(A)
            accept = cls._accept if cls.reject_poles else None
            if lambda_rel is not None:
                x = tikhonov_at(Aw, lw, L, lambda_rel[i], row_blocks=rows)
                if x is None or (accept is not None and not accept(x)):
                    return None, None
                sols.append(x)
                rels.append(lambda_rel[i])
                continue
            x, lam, rel, dof, (cond, rank) = tikhonov_cv(Aw, lw, L, grid=cls.lambda_grid, accept=accept,
                                                         row_blocks=rows)
            sols.append(x)
            lams.append(lam), rels.append(rel), dofs.append(dof), conds.append(cond), ranks.append(rank)
        return cls._unpack(sols), {"lambda": lams, "lambda_rel": rels, "dof": dofs, "cond": conds,
                                   "rank": ranks}

    @classmethod
    def _linear_start(cls, Aw, lw, keep):
        """Unregularised fit of the constant and linear terms (separate: one common denominator, the DLT)."""
        if cls.variant == "separate":
            keep = keep & ~np.concatenate([np.zeros(59, bool), np.ones(19, bool)])
            Aw = Aw.copy()
            Aw[:, 40:59] += Aw[:, 59:78]  # one common denominator: b' = d'
        x = np.zeros(Aw.shape[1])
        x[keep], _, rank, _ = np.linalg.lstsq(Aw[:, keep], lw, rcond=None)
        if rank < keep.sum():
            raise ModelError(f"model {cls.name!r}: the points do not determine even the first-order "
                             "terms (coplanar, collinear or duplicated points); use a 2-D model")
        if cls.variant == "separate":
            x[59:78] = x[40:59]
        return x

    @classmethod
    def _row_blocks(cls, A):
        """The x rows and the y rows of a linearised block with their columns (zero in each
        other's numerator), for :class:`_BlockDesign`; None for the polynomial's blocks."""
        if cls.variant == "poly":
            return None
        x_cols, y_cols = _support(cls)
        half = len(A) // 2
        return [(slice(0, half), x_cols), (slice(half, len(A)), y_cols)]

    @classmethod
    def _accept(cls, p):
        """Reject solutions whose denominator nearly vanishes inside the normalised cube."""
        if cls.variant == "poly":
            return True
        return cls._min_denominator(cls._unpack([p])) >= 0.05

    @classmethod
    def _fit(cls, s, d, w, iterations: int = 20, tol: float = 1e-9):
        T = terms_3d(s)
        blocks = cls._blocks(T, d)
        q = np.ones((len(s), 2))
        params = None
        for _ in range(1 if cls.variant == "poly" else 5):  # first-order start (Q = 1 for poly)
            params, _ = cls._solve(blocks, w, q, linear_only=True)
            q = cls._denominators(T, params)
        info, it, kept, last_rel = {}, 0, None, None
        for it in range(1, iterations + 1):
            new, info = cls._solve(blocks, w, q, lambda_rel=kept)
            if new is None:  # the kept λ gives a rejected solution: choose again
                kept = None
                new, info = cls._solve(blocks, w, q)
            change = np.max(np.abs(new - params))
            done = cls.variant == "poly" or change < tol or it == iterations
            if kept is not None and done:  # confirm the kept λ by cross-validation
                new, info = cls._solve(blocks, w, q)
                change = np.max(np.abs(new - params))
                done = info["lambda_rel"] == kept and change < tol or it == iterations
            if kept is None:
                kept = info["lambda_rel"] if info["lambda_rel"] == last_rel else None
                last_rel = info["lambda_rel"]
            elif info["lambda_rel"] != kept:
                kept, last_rel = None, info["lambda_rel"]
            params = new
            q = cls._denominators(T, params)
            if done:
                break
        info.update(iterations=it, direction=cls.direction, variant=cls.variant,
                    regularisation="tikhonov on degree-2/3 terms (and b-d), lambda by leave-one-out CV",
                    min_denominator=cls._min_denominator(params))
        return params, info

    @staticmethod
    def _denominators(T, params):
        c = params.reshape(4, 20)
        return np.column_stack([T @ c[1], T @ c[3]])

    @staticmethod
    def _min_denominator(params):
        q = np.abs(_RFMBase._denominators(_CUBE_TERMS, params))
        return float(q.min() / q.max())

    def _warn_if_ill_posed(self):
        super()._warn_if_ill_posed()
        if self.info.get("min_denominator", 1.0) < 0.05:
            self.info.setdefault("ill_posed", []).append("denominator nearly zero inside the normalised domain")
            warnings.warn(f"model {self.name!r}: a denominator nearly vanishes inside the fitted domain "
                          f"(min |Q| / max |Q| = {self.info['min_denominator']:.2g}); predictions there are "
                          "unreliable — use 'rfm-common', 'rfm-poly' or more, better spread points",
                          IllPosedWarning, stacklevel=3)


@functools.cache
def _support(cls):
    """Non-zero columns of the x row and of the y row of ``cls``'s design (from one point)."""
    A = cls._blocks(np.ones((1, 20)), np.ones((1, 2)))[0][0]
    return np.flatnonzero(A[0]), np.flatnonzero(A[1])


#: log10(λ / σ_max) of the plain RFMs: numerically no regularisation (the paper's solve)
PLAIN_GRID = np.array([-12.0])


def _rfm_class(cls_name, name, variant, n_params, min_points, direction, plain=False):
    how = ("unregularised iterative LS as in Öztürk, Karşlı & Dihkan — comparisons only" if plain
           else "Tikhonov, λ by leave-one-out CV")
    doc = (f"Cubic RFM, {variant} denominator(s), fitted {direction} "
           f"({n_params} parameters, ≥ {min_points} points; {how}).")
    attrs = {"name": name, "variant": variant, "n_params": n_params, "min_points": min_points,
             "direction": direction, "__doc__": doc, "__module__": __name__}
    if plain:  # λ = 1e-12 σ_max only, no check of the denominators: the paper's plain solve
        attrs.update(lambda_grid=PLAIN_GRID, reject_poles=False, plain=True)
    return register_model(type(cls_name, (_RFMBase,), attrs))


# minimum points: the unregularised first-order part must be determined with one point to
# spare for cross-validation (the first-order start has 4 + 4 + 3 unknowns for two axes with
# a common denominator, 6 points; 4 per axis without denominator, 4 points)
RFM = _rfm_class("RFM", "rfm", "separate", 78, 7, "ground-to-image")
RFMCommon = _rfm_class("RFMCommon", "rfm-common", "common", 59, 7, "ground-to-image")
RFMPoly = _rfm_class("RFMPoly", "rfm-poly", "poly", 40, 5, "ground-to-image")
RFMImageToGround = _rfm_class("RFMImageToGround", "rfm-i2g", "separate", 78, 7, "image-to-ground")
RFMCommonImageToGround = _rfm_class("RFMCommonImageToGround", "rfm-common-i2g", "common", 59, 6,
                                    "image-to-ground")
RFMPolyImageToGround = _rfm_class("RFMPolyImageToGround", "rfm-poly-i2g", "poly", 40, 5, "image-to-ground")
# the paper's own solutions (Öztürk, Karşlı & Dihkan): least squares without regularisation. With fewer
# observations than parameters (e.g. 40 GCPs, 78 parameters) they interpolate the control points and
# their check-point errors show what the regularised fits above avoid
RFMPlain = _rfm_class("RFMPlain", "rfm-plain", "separate", 78, 7, "ground-to-image", plain=True)
RFMCommonPlain = _rfm_class("RFMCommonPlain", "rfm-common-plain", "common", 59, 7, "ground-to-image", plain=True)
RFMPolyPlain = _rfm_class("RFMPolyPlain", "rfm-poly-plain", "poly", 40, 5, "ground-to-image", plain=True)
RFMPlainImageToGround = _rfm_class("RFMPlainImageToGround", "rfm-plain-i2g", "separate", 78, 7, "image-to-ground",
                                   plain=True)
