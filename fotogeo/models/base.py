"""The one model protocol shared by every geometric model in fotogeo.

A model maps *source* points (``(N, src_dims)``: image pixels, or ground X, Y[, Z]) to
*destination* points (``(N, 2)``). Every model class offers:

* ``Model.estimate(src, dst, weights=None, **fit_options)`` — weighted least squares from
  point pairs (raises :class:`~fotogeo.errors.ModelError` below ``min_points`` or on
  degenerate input). ``fit_options`` are the model's own parameters that are not estimated,
  declared in the class attribute ``fit_options`` (name -> what it is), e.g. the camera of
  the collinearity model; :meth:`Model.options_from` picks them from what a caller has;
* ``model.forward(src)`` and ``model.inverse(dst, heights=None)`` — the mapping and its
  inverse. ``heights`` completes the source points of 3-D models (``src_dims = 3``): a
  number, an ``(N,)`` array (one per point), or a
  :class:`~fotogeo.geometry.dem.HeightSource` (a DEM: the inverse then intersects the
  terrain). 2-D models ignore it, as pyproj's ``transform(xx, yy, zz=None)`` does;
* ``model.folds(points)`` — whether the mapping folds over a region (e.g. the image outline);
* ``model.residuals(src, dst)`` — Euclidean distance ``|forward(src) - dst|`` per pair;
* class attributes ``name``, ``n_params``, ``min_points``, ``src_dims``;
* ``model.to_dict()`` / :func:`model_from_dict` — JSON-ready serialisation.

All fits run in normalised coordinates (offset and scale per axis, the RPC00B way:
``u = (x - offset) / scale`` with values in about [-1, 1]), which keeps the normal
equations well conditioned whatever the map units.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..errors import InputError, ModelError
from .threads import blas_threads_for

#: name -> model class; filled by :func:`register_model`.
MODELS: dict[str, type["Model"]] = {}


def register_model(cls):
    """Class decorator adding a model to :data:`MODELS` under ``cls.name``."""
    MODELS[cls.name] = cls
    return cls


def get_model(name: str) -> type["Model"]:
    """The model class called ``name`` (raises :class:`InputError` listing the valid names).

    The protocol on four pixel → map pairs (10 px = 20 m, north up):

    >>> px = [[0, 0], [10, 0], [0, 10], [10, 10]]
    >>> XY = [[100, 200], [120, 200], [100, 180], [120, 180]]
    >>> m = get_model("affine").estimate(px, XY)
    >>> m.name, m.n_params, m.min_points, m.src_dims
    ('affine', 6, 3, 2)
    >>> m.forward([[5, 5]]).tolist()
    [[110.0, 190.0]]
    >>> m.residuals(px, XY).round(9).tolist()
    [0.0, 0.0, 0.0, 0.0]
    """
    try:
        return MODELS[name]
    except KeyError:
        raise InputError(f"unknown model {name!r}; choose one of: {', '.join(sorted(MODELS))}") from None


@dataclass(frozen=True)
class Normalisation:
    """Per-axis ``offset`` and ``scale``: ``normalise(x) = (x - offset) / scale``."""

    offset: np.ndarray
    scale: np.ndarray

    @classmethod
    def of(cls, pts: np.ndarray, isotropic: bool = False) -> "Normalisation":
        """Mid-range offset and half-range scale, so the points span [-1, 1] per axis.

        ``isotropic`` uses one scale (the largest half-range) for all axes.
        """
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        offset = (lo + hi) / 2.0
        scale = (hi - lo) / 2.0
        if isotropic:
            scale = np.full_like(scale, scale.max())
        scale = np.where(scale > 0, scale, 1.0)
        return cls(offset, scale)

    def normalise(self, pts: np.ndarray) -> np.ndarray:
        return (pts - self.offset) / self.scale

    def denormalise(self, pts: np.ndarray) -> np.ndarray:
        return pts * self.scale + self.offset

    def to_dict(self) -> dict:
        return {"offset": self.offset.tolist(), "scale": self.scale.tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> "Normalisation":
        return cls(np.asarray(d["offset"], float), np.asarray(d["scale"], float))


def check_pairs(cls, src, dst, weights=None):
    """Validate point pairs for ``cls``: shapes, finiteness, count; return float64 arrays."""
    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    if src.ndim != 2 or src.shape[1] != cls.src_dims:
        raise InputError(f"{cls.name}: source points must have shape (N, {cls.src_dims}); got {src.shape}")
    if dst.ndim != 2 or dst.shape[1] != 2 or len(dst) != len(src):
        raise InputError(f"{cls.name}: destination points must have shape ({len(src)}, 2); got {dst.shape}")
    if not (np.isfinite(src).all() and np.isfinite(dst).all()):
        raise InputError(f"{cls.name}: point coordinates contain NaN or infinity; remove those points")
    if len(src) < cls.min_points:
        raise ModelError(f"model {cls.name!r} needs at least {cls.min_points} points; got {len(src)}")
    if weights is None:
        w = np.ones(len(src))
    else:
        w = np.asarray(weights, dtype=np.float64).reshape(-1)
        if len(w) != len(src) or not np.isfinite(w).all() or (w < 0).any():
            raise InputError(f"{cls.name}: weights must be {len(src)} finite non-negative numbers")
        if np.count_nonzero(w) < cls.min_points:
            raise ModelError(f"model {cls.name!r} needs at least {cls.min_points} points with weight > 0")
    return src, dst, w


def weighted_lstsq(A: np.ndarray, b: np.ndarray, w: np.ndarray, name: str) -> np.ndarray:
    """Solve ``min Σ w (A x - b)²``; raise :class:`ModelError` when A is rank deficient."""
    sw = np.sqrt(w)[:, None]
    Aw, bw = A * sw, b * sw if b.ndim == 2 else b * sw[:, 0]
    x, _, rank, _ = np.linalg.lstsq(Aw, bw, rcond=None)
    if rank < A.shape[1]:
        raise ModelError(f"model {name!r}: the points are degenerate (collinear, duplicated or "
                         f"too clustered) — rank {rank} < {A.shape[1]} parameters")
    return x


#: :func:`newton_2d` evaluates a point and its four Jacobian neighbours in one call of ``apply`` up to this many points
#: (a call's fixed cost dominates small sets; larger ones are evaluated in five calls, bounding the temporaries)
NEWTON_BATCH_POINTS = 2 ** 16
_NEWTON_STEPS = np.array([[0.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])


def newton_2d(apply: Callable[[np.ndarray], np.ndarray], d: np.ndarray, s: np.ndarray,
              iterations: int, tol: float, eps: float = 1e-6, extra: np.ndarray | None = None) -> np.ndarray:
    """Solve ``apply(s) = d`` for ``s`` ``(N, 2)`` by Newton's method, starting from ``s``.

    ``apply`` maps ``(M, 2)`` to ``(M, 2)`` (``(M, 2 + k)`` with ``extra``, per-point columns ``(N, k)`` such as
    a fixed height, appended to every evaluation of that point); its 2x2 Jacobian ``J = [jx jy]`` comes from
    central differences with step ``eps``, and each step is ``Δs = J⁻¹ (apply(s) − d)`` by Cramer's
    rule. Stops when every ``|Δs| < tol`` or after ``iterations``; points whose Jacobian is
    singular (``|det J| ≤ 1e-15``) become NaN. Up to :data:`NEWTON_BATCH_POINTS` points, ``s`` and its four
    neighbours ``s ± eps`` go through ``apply`` in one call (the same positions as five calls).
    """
    steps = _NEWTON_STEPS * eps
    for _ in range(iterations):
        if len(s) <= NEWTON_BATCH_POINTS:
            at = (s[None] + steps[:, None]).reshape(-1, 2)
            v = apply(at if extra is None else np.column_stack([at, np.tile(extra, (5, 1))])).reshape(5, len(s), 2)
        else:
            v = [apply(p if extra is None else np.column_stack([p, extra])) for p in s[None] + steps[:, None]]
        f = v[0] - d
        jx = (v[1] - v[2]) / (2 * eps)
        jy = (v[3] - v[4]) / (2 * eps)
        det = jx[:, 0] * jy[:, 1] - jy[:, 0] * jx[:, 1]
        det = np.where(np.abs(det) > 1e-15, det, np.nan)
        ds = np.column_stack([(jy[:, 1] * f[:, 0] - jy[:, 0] * f[:, 1]) / det,
                              (-jx[:, 1] * f[:, 0] + jx[:, 0] * f[:, 1]) / det])
        s = s - ds
        if not np.nanmax(np.abs(ds), initial=0.0) >= tol:
            break
    return s


@dataclass(frozen=True)
class Model:
    """Base of all models: parameters in normalised coordinates plus both normalisations."""

    params: np.ndarray
    src_norm: Normalisation
    dst_norm: Normalisation
    info: dict = field(default_factory=dict, compare=False)

    name: ClassVar[str] = "model"
    n_params: ClassVar[int] = 0
    min_points: ClassVar[int] = 0
    src_dims: ClassVar[int] = 2
    isotropic: ClassVar[bool] = False  # normalise all axes with one scale
    #: keyword options of ``estimate`` that are parameters, not estimated: name -> what it is
    fit_options: ClassVar[dict[str, str]] = {}

    # -- subclasses implement these two, in normalised coordinates -----------------------
    @classmethod
    def _fit(cls, s: np.ndarray, d: np.ndarray, w: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _apply(self, s: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    # -- the protocol ---------------------------------------------------------------------
    @classmethod
    def options_from(cls, **available) -> dict:
        """The ``fit_options`` of this model, taken from ``available`` (others are left out).

        Raises :class:`ModelError` naming an option the model needs that is missing (None).
        """
        for name, what in cls.fit_options.items():
            if available.get(name) is None:
                raise ModelError(f"model {cls.name!r} needs {what}")
        return {name: available[name] for name in cls.fit_options}

    @classmethod
    def estimate(cls, src, dst, weights=None):
        """Weighted least-squares estimate from ``src`` -> ``dst`` pairs."""
        src, dst, w = check_pairs(cls, src, dst, weights)
        sn = Normalisation.of(src[w > 0], cls.isotropic)
        dn = Normalisation.of(dst[w > 0], cls.isotropic)
        with blas_threads_for(2 * len(src), cls.n_params):  # small fits: one BLAS thread (models/threads.py)
            params = cls._fit(sn.normalise(src), dn.normalise(dst), w)
        return cls(np.asarray(params, dtype=np.float64), sn, dn)

    def forward(self, src) -> np.ndarray:
        """Map source points ``(N, src_dims)`` to destination points ``(N, 2)``."""
        src = np.asarray(src, dtype=np.float64)
        if src.ndim != 2 or src.shape[1] != self.src_dims:
            raise InputError(f"{self.name}: points must have shape (N, {self.src_dims}); got {src.shape}")
        return self.dst_norm.denormalise(self._apply(self.src_norm.normalise(src)))

    def inverse(self, dst, heights=None, *, iterations: int = 20, tol: float = 1e-10) -> np.ndarray:
        """Map destination points back to source points (2-D models; Newton iteration).

        ``heights`` is ignored by 2-D models (see the module docstring). Subclasses with a
        closed-form inverse, and the 3-D models, override this.
        """
        if self.src_dims != 2:
            raise ModelError(f"{self.name}: the inverse of a 3-D model needs heights; use its own method")
        d = self.dst_norm.normalise(np.asarray(dst, dtype=np.float64))
        # normalised source and destination both span about [-1, 1]: start at s = d
        return self.src_norm.denormalise(newton_2d(self._apply, d, d.copy(), iterations, tol))

    def folds(self, points) -> bool:
        """True when the mapping folds over ``points`` (source coordinates, e.g. an image outline).

        The Jacobian determinant of the destination with respect to the first two source axes
        (central differences in normalised coordinates) must keep one sign and stay finite
        and non-zero at every point; otherwise the map of the region is not one-to-one.
        """
        s = self.src_norm.normalise(np.asarray(points, dtype=np.float64))
        eps, e0, e1 = 1e-6, np.zeros(s.shape[1]), np.zeros(s.shape[1])
        e0[0], e1[1] = eps, eps
        jx = (self._apply(s + e0) - self._apply(s - e0)) / (2 * eps)
        jy = (self._apply(s + e1) - self._apply(s - e1)) / (2 * eps)
        det = jx[:, 0] * jy[:, 1] - jy[:, 0] * jx[:, 1]
        return not (np.all(det > 0) or np.all(det < 0))

    def residuals(self, src, dst) -> np.ndarray:
        """Euclidean distance between ``forward(src)`` and ``dst``, per pair (destination units)."""
        return np.hypot(*(self.forward(src) - np.asarray(dst, dtype=np.float64)).T)

    def to_dict(self) -> dict:
        return {"model": self.name, "params": self.params.tolist(),
                "src_norm": self.src_norm.to_dict(), "dst_norm": self.dst_norm.to_dict()}


def model_from_dict(d: dict) -> Model:
    """Rebuild a model serialised with ``to_dict``."""
    cls = get_model(d["model"])
    return cls(np.asarray(d["params"], float), Normalisation.from_dict(d["src_norm"]),
               Normalisation.from_dict(d["dst_norm"]))
