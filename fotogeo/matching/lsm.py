"""Least-squares matching (LSM, Gruen 1985; seeds 000/001) — affine + radiometric, vectorised.

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
:func:`sample`); ``(gx, gy)`` are the gradients of ``g`` in search-image coordinates,
obtained from central differences of the resampled window (computed on a grid one pixel
larger than the window) mapped through the inverse affine Jacobian:
``(gx, gy)ᵀ = J⁻ᵀ (∂g⁰/∂dx, ∂g⁰/∂dy)ᵀ`` with ``J = [[a1, a2], [b1, b2]]``.

Precision. With ``n = (2h+1)²`` observations and ``u = 8`` unknowns,

    σ0² = vᵀPv / (n − u),   Σ_δδ = σ0² · (AᵀPA)⁻¹,   σx = sqrt(Σ[a0,a0]),  σy = sqrt(Σ[b0,b0]),

from the last iteration (u = 4 for ``model="shift"``). Like every Gauss-Markov σ it assumes
uncorrelated grey-value noise and a correct model: it does not see interpolation error,
the noise carried into the gradients of ``g``, or the smoothing of resampled noise, and is
optimistic in weak texture (measured in benchmarks/matching_bench.py).

Resampling is done in numpy at full float64 precision: ``cv2.remap`` quantises sub-pixel
positions to 1/32 pixel, which would cap LSM at about 0.01 px.

Rejections are reported in ``status`` (never silent): ``"converged"`` or
``"window outside image"``, ``"nodata in window"``, ``"low signal"`` (flat template or
σ > ``max_sigma``), ``"singular normal matrix"``, ``"diverged"`` (affine determinant outside
[0.5, 2], gain <= 0 or non-finite), ``"shift beyond window"`` (moved more than ``max_shift``
from the approximation), ``"max iterations"``, ``"low correlation"`` (converged, but the
correlation of template and resampled window is below ``min_correlation``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..pixels import from_centre, to_centre
from .ncc import as_image, as_point_pairs, as_xy, check_int, check_range

CONVERGED = "converged"
PARAMETERS = ("a0", "a1", "a2", "b0", "b1", "b2", "r0", "r1")
#: Free parameters (indices into PARAMETERS) of each model.
MODELS = {"affine": (0, 1, 2, 3, 4, 5, 6, 7), "shift": (0, 3, 6, 7)}
_KEYS_A = -0.5  # Keys (1981) cubic convolution, third-order accurate


def _cubic_weights(t):
    a = _KEYS_A
    s = t + 1.0
    w0 = ((a * s - 5 * a) * s + 8 * a) * s - 4 * a
    w1 = ((a + 2) * t - (a + 3)) * t * t + 1
    u = 1.0 - t
    w2 = ((a + 2) * u - (a + 3)) * u * u + 1
    return w0, w1, w2, 1.0 - w0 - w1 - w2


def sample(image: np.ndarray, xy_centre_x, xy_centre_y, method: str = "bilinear"):
    """Interpolate ``image`` at centre-convention coordinates (array indices ``x=col, y=row``).

    Returns ``(values, inside)``: values float64 (NaN where outside or touching nodata),
    ``inside`` True where the whole interpolation support lies in the image.
    """
    H, W = image.shape
    x = np.asarray(xy_centre_x, dtype=np.float64)
    y = np.asarray(xy_centre_y, dtype=np.float64)
    x0 = np.floor(x)
    y0 = np.floor(y)
    tx, ty = x - x0, y - y0
    lo, hi = (0, 1) if method == "bilinear" else (1, 2)
    ok = np.isfinite(x) & np.isfinite(y)
    inside = ok & (x0 - lo >= 0) & (y0 - lo >= 0) & (x0 + hi <= W - 1) & (y0 + hi <= H - 1)
    xi = np.where(inside, x0, lo).astype(np.intp)
    yi = np.where(inside, y0, lo).astype(np.intp)
    if method == "bilinear":
        v = ((1 - tx) * (1 - ty) * image[yi, xi] + tx * (1 - ty) * image[yi, xi + 1]
             + (1 - tx) * ty * image[yi + 1, xi] + tx * ty * image[yi + 1, xi + 1])
    else:
        wx = _cubic_weights(tx)
        wy = _cubic_weights(ty)
        v = 0.0
        for j in range(4):
            row = 0.0
            for i in range(4):
                row = row + wx[i] * image[yi + j - 1, xi + i - 1]
            v = v + wy[j] * row
    v = np.where(inside, v, np.nan)
    return v, inside


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
    ia, ib = int(np.nonzero(free == 0)[0][0]), int(np.nonzero(free == 3)[0][0])
    h = int(half_window)
    max_shift = float(h if max_shift is None else max_shift)
    n_pts = P.shape[0]
    J0 = _jacobians(approx_jacobian, n_pts)

    # The template is the (2h+1)² pixels centred on the pixel containing ref_xy, not
    # resampled; (dx, dy) are their centres' offsets from ref_xy itself. The search grid is
    # one pixel larger on each side (for central-difference gradients).
    k = np.arange(-h - 1, h + 2)
    KX, KY = np.meshgrid(k, k)
    pix = np.floor(P).astype(np.int64)          # (col, row) of the pixel containing ref_xy
    frac = P - from_centre(pix)                 # ref_xy relative to that pixel's centre
    DX = KX.ravel()[None, :] - frac[:, :1]      # (N, m²) offsets incl. the margin
    DY = KY.ravel()[None, :] - frac[:, 1:]
    inner = np.zeros(KX.shape, bool)
    inner[1:-1, 1:-1] = True
    inner = inner.ravel()
    dx, dy = DX[:, inner], DY[:, inner]
    n_obs, n_par = int(inner.sum()), len(free)

    status = np.full(n_pts, "", dtype=object)
    Hf, Wf = f_img.shape
    f_in = (pix[:, 0] - h >= 0) & (pix[:, 1] - h >= 0) & (pix[:, 0] + h < Wf) & (pix[:, 1] + h < Hf)
    status[~f_in] = "window outside image"
    cols = np.clip(pix[:, :1] + KX[1:-1, 1:-1].ravel(), 0, Wf - 1)
    rows = np.clip(pix[:, 1:] + KY[1:-1, 1:-1].ravel(), 0, Hf - 1)
    f = f_img[rows, cols]
    status[(status == "") & np.isnan(f).any(axis=1)] = "nodata in window"
    scale = np.maximum(np.nanmax(np.abs(f), axis=1, initial=0.0), 1.0)
    fstd = np.nanstd(f, axis=1)
    status[(status == "") & ~(fstd > 1e-6 * scale)] = "low signal"

    par = np.zeros((n_pts, len(PARAMETERS)))
    par[:, 0], par[:, 3] = Q[:, 0], Q[:, 1]
    par[:, 1], par[:, 2], par[:, 4], par[:, 5] = J0[:, 0, 0], J0[:, 0, 1], J0[:, 1, 0], J0[:, 1, 1]
    par[:, 7] = np.nan  # radiometry initialised from the first resampled window
    iters = np.zeros(n_pts, dtype=np.int64)
    sigma0 = np.full(n_pts, np.nan)
    cov = np.full((n_pts, 2, 2), np.nan)
    rho = np.full(n_pts, np.nan)

    prev_delta = np.zeros_like(par)
    step_scale = np.array([1.0, h, h, 1.0, h, h, 0.0, 0.0])  # parameter -> px at the window edge
    for it in range(1, int(max_iterations) + 1):
        act = np.nonzero(status == "")[0]
        if act.size == 0:
            break
        p = par[act]
        xs = p[:, :1] + p[:, 1:2] * DX[act] + p[:, 2:3] * DY[act]
        ys = p[:, 3:4] + p[:, 4:5] * DX[act] + p[:, 5:6] * DY[act]
        sc = to_centre(np.stack([xs, ys], axis=-1))
        gfull, inside = sample(g_img, sc[..., 0], sc[..., 1], interpolation)
        bad_out = ~inside.all(axis=1)
        bad_nan = ~bad_out & np.isnan(gfull).any(axis=1)
        status[act[bad_out]] = "window outside image"
        status[act[bad_nan]] = "nodata in window"
        keep = ~(bad_out | bad_nan)
        act, p, gfull = act[keep], p[keep], gfull[keep]
        if act.size == 0:
            break
        iters[act] = it
        m = len(k)
        G = gfull.reshape(-1, m, m)
        g = G[:, 1:-1, 1:-1].reshape(-1, n_obs)
        gdx = 0.5 * (G[:, 1:-1, 2:] - G[:, 1:-1, :-2]).reshape(-1, n_obs)
        gdy = 0.5 * (G[:, 2:, 1:-1] - G[:, :-2, 1:-1]).reshape(-1, n_obs)
        fa = f[act]
        # radiometric start values: match mean and standard deviation
        first = np.isnan(p[:, 7])
        if first.any():
            gs = g[first].std(axis=1)
            flat = ~(gs > 1e-6 * np.maximum(np.abs(g[first]).max(axis=1), 1.0))
            gs = np.where(flat, 1.0, gs)
            p[first, 7] = fstd[act[first]] / gs
            p[first, 6] = fa[first].mean(axis=1) - p[first, 7] * g[first].mean(axis=1)
            idx_flat = np.nonzero(first)[0][flat]
            status[act[idx_flat]] = "low signal"
        # gradients in search coordinates: J^-T (d/ddx, d/ddy)
        a1, a2, b1, b2 = p[:, 1:2], p[:, 2:3], p[:, 4:5], p[:, 5:6]
        det = a1 * b2 - a2 * b1
        gx = (b2 * gdx - b1 * gdy) / det
        gy = (-a2 * gdx + a1 * gdy) / det
        r0, r1 = p[:, 6:7], p[:, 7:8]
        ddx, ddy = dx[act], dy[act]
        A = np.stack([r1 * gx, r1 * gx * ddx, r1 * gx * ddy, r1 * gy, r1 * gy * ddx, r1 * gy * ddy,
                      np.ones_like(g), g], axis=-1)[:, :, free]
        ell = fa - r0 - r1 * g
        N = np.einsum("kni,knj->kij", A, A)
        b = np.einsum("kni,kn->ki", A, ell)
        diag = np.sqrt(np.abs(np.einsum("kii->ki", N)))
        with np.errstate(divide="ignore", invalid="ignore"):
            Ns = N / diag[:, :, None] / diag[:, None, :]
            cond = np.linalg.cond(np.where(np.isfinite(Ns), Ns, 0.0))
        sing = ~(np.isfinite(cond) & (cond < 1e12)) | ~(diag > 0).all(axis=1)
        sing &= status[act] == ""
        status[act[sing]] = "singular normal matrix"
        live = status[act] == ""
        act, p, A, ell, N, b = act[live], p[live], A[live], ell[live], N[live], b[live]
        g = g[live]
        if act.size == 0:
            break
        Ninv = np.linalg.inv(N)
        delta = np.zeros_like(p)
        delta[:, free] = np.einsum("kij,kj->ki", Ninv, b)
        v = np.einsum("kni,ki->kn", A, delta[:, free]) - ell  # least-squares residuals
        # damping: a geometric step that reverses the previous one (Gauss-Newton overshoot,
        # e.g. when the window is resampled at a scale > 1) is halved
        osc = np.einsum("ki,ki->k", delta * step_scale, prev_delta[act] * step_scale) < 0
        delta[osc] *= 0.5
        prev_delta[act] = delta
        p = p + delta
        par[act] = p
        s02 = np.einsum("kn,kn->k", v, v) / (n_obs - n_par)
        sigma0[act] = np.sqrt(s02)
        cov[act] = s02[:, None, None] * Ninv[:, [[ia, ia], [ib, ib]], [[ia, ib], [ia, ib]]]
        fc = fa[live] - fa[live].mean(axis=1, keepdims=True)
        gc = g - g.mean(axis=1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            rho[act] = (fc * gc).sum(1) / np.sqrt((fc * fc).sum(1) * (gc * gc).sum(1))
        # checks
        step = np.abs(delta * step_scale).max(axis=1)
        detn = p[:, 1] * p[:, 5] - p[:, 2] * p[:, 4]
        # an affine step must keep a plausible geometry relative to the approximation
        det0 = np.linalg.det(J0[act])
        ratio = detn / det0
        diverged = ~np.isfinite(p).all(axis=1) | ~((ratio > 0.5) & (ratio < 2.0)) | ~(p[:, 7] > 0)
        moved = np.hypot(p[:, 0] - Q[act, 0], p[:, 3] - Q[act, 1]) > max_shift
        done = step < float(tolerance)
        st = np.full(act.size, "", dtype=object)
        st[done] = CONVERGED
        st[moved] = "shift beyond window"
        st[diverged] = "diverged"
        status[act] = st

    status[status == ""] = "max iterations"
    conv = status == CONVERGED
    low_rho = conv & ~(rho >= min_correlation)
    status[low_rho] = "low correlation"
    sig = np.sqrt(np.stack([cov[:, 0, 0], cov[:, 1, 1]], axis=1))
    status[(status == CONVERGED) & ~(sig.max(axis=1) <= max_sigma)] = "low signal"
    ok = status == CONVERGED
    xy = np.where(ok[:, None], par[:, [0, 3]], np.nan)
    affine = np.stack([par[:, [1, 2, 0]], par[:, [4, 5, 3]]], axis=1)
    return LSMBatch(xy, sig, rho, iters, status.astype(str), affine, par[:, 6:8].copy(), sigma0, cov)


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
