"""Least-squares matching (LSM, Gruen 1985; Büyüksalih; the 'Görüntü Eşleme' study) — affine + radiometric, vectorised.

Model. ``f`` is the reference template: the ``(2h+1)²`` pixels centred on the pixel that
contains ``ref_xy``, taken as they are (never resampled); ``(dx, dy)`` are their centres'
offsets from ``ref_xy``. ``g`` is the search image. The search window moves and
deforms affinely, and the grey values are related by an offset and a gain:

    f(dx, dy) + v = r0 + r1 · g(x', y'),
    x' = a0 + a1·dx + a2·dy,    y' = b0 + b1·dx + b2·dy,

so ``(a0, b0)`` is the point of ``search`` homologous to ``ref_xy`` (GDAL corner convention).
Linearised about the current parameters (Gauss-Markov model, ``l + v = A·δ``, ``P = I``):

    l = f − r0 − r1·g⁰
    A = [r1·gx, r1·gx·dx, r1·gx·dy, r1·gy, r1·gy·dx, r1·gy·dy, 1, g⁰]
    δ = (AᵀPA)⁻¹ AᵀPl,   parameters += δ, iterate until the geometric step < ``tolerance`` px.

A geometric step that reverses the previous one (negative scalar product, affine terms
scaled to pixels at the window edge) is halved: Gauss-Newton overshoots and oscillates when
the linearisation is poor, e.g. when the window is resampled at a scale > 1.

``g⁰`` is the search image resampled on the deformed grid (bilinear or bicubic, see
:func:`fotogeo.matching.interpolation.sample`); ``(gx, gy)`` are the gradients of ``g`` in
search-image coordinates, obtained from central differences of the resampled window
(computed on a grid one pixel larger than the window) mapped through the inverse affine
Jacobian:
``(gx, gy)ᵀ = J⁻ᵀ (∂g⁰/∂dx, ∂g⁰/∂dy)ᵀ`` with ``J = [[a1, a2], [b1, b2]]``.

Precision. With ``n = (2h+1)²`` observations and ``u = 8`` unknowns,

    σ0² = vᵀPv / (n − u),   Σ_δδ = σ0² · (AᵀPA)⁻¹,   σx = sqrt(Σ[a0,a0]),  σy = sqrt(Σ[b0,b0]),

from the last iteration (u = 4 for ``model="shift"``). Like every Gauss-Markov σ it assumes
uncorrelated grey-value noise and a correct model: it does not see interpolation error,
the noise carried into the gradients of ``g``, or the smoothing of resampled noise, and is
optimistic in weak texture (measured in benchmarks/matching_bench.py).

Resampling is done in numpy at full float64 precision (:mod:`fotogeo.matching.interpolation`).

The computation is split into named steps in :mod:`fotogeo.matching.lsm_steps`.

Rejections are reported in ``status`` (never silent; the words of
:mod:`fotogeo.matching.status`): ``"converged"`` or
``"window outside image"``, ``"nodata in window"``, ``"flat patch"`` (template or first
resampled window without grey-value variation), ``"low signal"`` (σ > ``max_sigma``),
``"singular normal matrix"``, ``"diverged"`` (affine determinant outside
[0.5, 2], gain <= 0 or non-finite), ``"shift beyond window"`` (moved more than ``max_shift``
from the approximation), ``"max iterations"``, ``"low correlation"`` (converged, but the
correlation of template and resampled window is below ``min_correlation``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .lsm_steps import LsmProblem, LsmState, final_status, iterate, prepare_windows
from .ncc import as_image, as_point_pairs, as_xy, check_int, check_range
from .status import CONVERGED

#: Free parameters (indices into :data:`fotogeo.matching.lsm_steps.PARAMETERS`) of each model.
MODELS = {"affine": (0, 1, 2, 3, 4, 5, 6, 7), "shift": (0, 3, 6, 7)}


@dataclass(frozen=True)
class LSMResult:
    """One least-squares match.

    ``xy``: position in ``search`` homologous to ``ref_xy`` (corner convention);
    ``sigma``: (σx, σy) px; ``ncc``: correlation of template and final resampled window;
    ``iterations``; ``status``; ``affine``: 2x3 ``[[a1, a2, a0], [b1, b2, b0]]`` mapping
    ``(dx, dy, 1)`` (offsets from ``ref_xy``) to search coordinates; ``radiometry``:
    ``(r0, r1)`` offset and gain with ``f ≈ r0 + r1·g``; ``sigma0``: a-posteriori σ0 (grey
    values); ``covariance``: 2x2 covariance of ``xy``.
    """

    xy: np.ndarray
    sigma: np.ndarray
    ncc: float
    iterations: int
    status: str
    affine: np.ndarray
    radiometry: tuple
    sigma0: float
    covariance: np.ndarray

    @property
    def ok(self) -> bool:
        return self.status == CONVERGED


@dataclass(frozen=True)
class LSMBatch:
    """Many least-squares matches as arrays (row i = point i); fields as in :class:`LSMResult`.

    ``xy`` (N, 2), ``sigma`` (N, 2), ``ncc`` (N,), ``iterations`` (N,), ``status`` (N,) str,
    ``affine`` (N, 2, 3), ``radiometry`` (N, 2), ``sigma0`` (N,), ``covariance`` (N, 2, 2).
    """

    xy: np.ndarray
    sigma: np.ndarray
    ncc: np.ndarray
    iterations: np.ndarray
    status: np.ndarray
    affine: np.ndarray
    radiometry: np.ndarray
    sigma0: np.ndarray
    covariance: np.ndarray

    @property
    def ok(self) -> np.ndarray:
        return self.status == CONVERGED

    def __len__(self) -> int:
        return len(self.status)

    def __getitem__(self, i: int) -> LSMResult:
        return LSMResult(self.xy[i], self.sigma[i], float(self.ncc[i]), int(self.iterations[i]),
                         str(self.status[i]), self.affine[i], tuple(self.radiometry[i]),
                         float(self.sigma0[i]), self.covariance[i])


def _check_options(half_window, max_iterations, interpolation, tolerance, min_correlation, max_sigma):
    check_int(half_window, "half_window", 2)
    check_int(max_iterations, "max_iterations", 1)
    if interpolation not in ("bilinear", "bicubic"):
        raise InputError(f"interpolation must be 'bilinear' or 'bicubic'; got {interpolation!r}")
    if not float(tolerance) > 0:
        raise InputError(f"tolerance must be > 0 px; got {tolerance!r}")
    check_range(min_correlation, "min_correlation", -1.0, 1.0)
    if not float(max_sigma) > 0:
        raise InputError(f"max_sigma must be > 0 px; got {max_sigma!r}")


def _jacobians(approx_jacobian, n: int) -> np.ndarray:
    if approx_jacobian is None:
        return np.broadcast_to(np.eye(2), (n, 2, 2)).copy()
    J = np.asarray(approx_jacobian, dtype=np.float64)
    if J.shape == (2, 2):
        J = np.broadcast_to(J, (n, 2, 2)).copy()
    if J.shape != (n, 2, 2) or not np.isfinite(J).all():
        raise InputError(f"approx_jacobian must be a finite (2, 2) or ({n}, 2, 2) array; got {J.shape}")
    return J


def lsm_many(reference, search, ref_xy, approx_xy, *, half_window: int = 10, max_iterations: int = 15,
             interpolation: str = "bicubic", tolerance: float = 1e-3, min_correlation: float = 0.5,
             max_sigma: float = 0.5, max_shift: float | None = None, approx_jacobian=None,
             reference_mask=None, search_mask=None, model: str = "affine") -> LSMBatch:
    """Least-squares matching of many points at once (vectorised over points).

    ``ref_xy``, ``approx_xy``: (N, 2) corner-convention points in ``reference`` and
    approximate homologues in ``search``. ``approx_jacobian``: optional (2, 2) or (N, 2, 2)
    approximate ``∂(x', y')/∂(dx, dy)`` (rotation/scale between the images; default
    identity). ``max_shift``: largest allowed move from the approximation (default
    ``half_window``). ``model``: ``"affine"`` (a0..b2, r0, r1) or ``"shift"`` (a0, b0, r0,
    r1 with the Jacobian held at ``approx_jacobian``). Other options: see :func:`lsm`.
    """
    f_img = as_image(reference, "reference", reference_mask, "reference_mask")
    g_img = as_image(search, "search", search_mask, "search_mask")
    P, Q = as_point_pairs(ref_xy, approx_xy)
    _check_options(half_window, max_iterations, interpolation, tolerance, min_correlation, max_sigma)
    if model not in MODELS:
        raise InputError(f"model must be one of {sorted(MODELS)}; got {model!r}")
    free = np.array(MODELS[model])
    h = int(half_window)
    J0 = _jacobians(approx_jacobian, P.shape[0])
    status = np.full(P.shape[0], "", dtype=object)
    win = prepare_windows(f_img, P, h, status)
    pb = LsmProblem(g_img, win, Q, J0, free, ia=int(np.nonzero(free == 0)[0][0]), ib=int(np.nonzero(free == 3)[0][0]),
                    n_obs=(2 * h + 1) ** 2, step_scale=np.array([1.0, h, h, 1.0, h, h, 0.0, 0.0]),
                    interpolation=interpolation, tolerance=float(tolerance),
                    max_shift=float(h if max_shift is None else max_shift))
    s = LsmState.start(Q, J0, status)
    for it in range(1, int(max_iterations) + 1):
        if not iterate(pb, s, it):
            break
    sig = final_status(status, s.rho, s.covariance, min_correlation, max_sigma)
    par = s.par
    xy = np.where((status == CONVERGED)[:, None], par[:, [0, 3]], np.nan)
    affine = np.stack([par[:, [1, 2, 0]], par[:, [4, 5, 3]]], axis=1)
    return LSMBatch(xy, sig, s.rho, s.iterations, status.astype(str), affine, par[:, 6:8].copy(), s.sigma0,
                    s.covariance)


def lsm(reference, search, ref_xy, approx_xy, *, half_window: int = 10, max_iterations: int = 15,
        interpolation: str = "bicubic", tolerance: float = 1e-3, min_correlation: float = 0.5,
        max_sigma: float = 0.5, max_shift: float | None = None, approx_jacobian=None,
        reference_mask=None, search_mask=None, model: str = "affine") -> LSMResult:
    """Least-squares match of the window of ``reference`` around ``ref_xy`` into ``search``.

    Parameters
    ----------
    reference, search : 2-D arrays (any real dtype, NaN = nodata)
    ref_xy : (x, y) in ``reference``, GDAL corner convention (centre of pixel [0, 0] is (0.5, 0.5))
    approx_xy : approximate homologous (x, y) in ``search`` (within about 1–2 px; use
        :func:`fotogeo.matching.pyramid_match` or :func:`ncc` first when it is poorer)
    half_window : the window is ``(2h+1)²`` pixels
    max_iterations, tolerance : stop when the geometric step (shift, and affine terms times
        ``h``) is below ``tolerance`` px; not converged after ``max_iterations`` -> status
        ``"max iterations"``. From a good approximation the iteration converges in 5–10
        steps; slow convergence means a flat, ill-conditioned cost surface (weak texture
        under noise), where the matches that do converge late are often wrong by > 0.5 px
        (benchmarks/matching_bench.py), hence the default of 15.
    interpolation : ``"bilinear"`` or ``"bicubic"`` (Keys, a = −0.5) resampling of the moving window
    min_correlation : converged matches whose final correlation is lower -> ``"low correlation"``
    max_sigma : converged matches with σx or σy above this (px) -> ``"low signal"``
    model : ``"affine"`` (6 geometric + 2 radiometric parameters) or ``"shift"`` (2 + 2)
    max_shift, approx_jacobian, reference_mask, search_mask : see :func:`lsm_many`

    Returns :class:`LSMResult` (``xy`` is NaN unless ``status == "converged"``; ``sigma``,
    ``ncc`` and the parameters of the last iteration are kept for diagnosis).
    """
    p = as_xy(ref_xy, "ref_xy")
    q = as_xy(approx_xy, "approx_xy")
    J = None
    if approx_jacobian is not None:
        J = np.asarray(approx_jacobian, dtype=np.float64)
        if J.shape != (2, 2):
            raise InputError(f"approx_jacobian must be a (2, 2) array for one point; got {J.shape}")
        J = J[None]
    batch = lsm_many(reference, search, p[None], q[None], half_window=half_window,
                     max_iterations=max_iterations, interpolation=interpolation, tolerance=tolerance,
                     min_correlation=min_correlation, max_sigma=max_sigma, max_shift=max_shift,
                     approx_jacobian=J, reference_mask=reference_mask, search_mask=search_mask,
                     model=model)
    return batch[0]
