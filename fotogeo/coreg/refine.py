"""Least-squares matching of whole windows on a representation (Ackermann 1984; Gruen 1985).

The window of the reference representation ``f`` (``w x w`` pixels, real or complex) and the
target representation ``g`` (the whole strip, so that the window can move without running
out of data) are related by a shift and a gain:

    f(x) + v(x) = r · g(x + d),        x over the window's pixel centres,

with ``d = (dx, dy)`` the window's shift (target = reference + d, as in
:mod:`fotogeo.coreg.phase`) and ``r`` a real gain whose sign is kept from the start (a
negative gain follows inverted contrast on the grey values). A complex value gives two
observations (real and imaginary part). Linearised about ``(d⁰, r⁰)``, Gauss–Markov with
weights ``p(x)`` — the Hann taper of the phase correlation, times 0 where either window has
no data:

    l = f − r⁰·g⁰,   A = [J_x, J_y, g⁰],   J = (∇f + r⁰ ∇g⁰) / 2,   δ = (AᴴPA)⁻¹ Re(AᴴPl),

``g⁰ = g(x + d⁰)`` resampled by a separable Lanczos-3 kernel at the exact fraction of ``d⁰``
(no 1/32-px quantisation as in ``cv2.remap``), gradients by central differences. ``J`` is
the efficient second-order minimisation of Benhimane & Malis (2004): the mean of the
template's and the moved window's gradients, which converges in 3–5 steps where Gauss–Newton
with ``r ∇g`` alone crawls (the windows of two dates differ). Iterate until
``|δd| <`` ``tolerance``. Precision, from the last iteration,

    σ0² = Σ p|v|² / (n − 3),   Σ_dd = σ0² (AᴴPA)⁻¹,   n = channels · Σ p / max p,

optimistic because the representation is smoothed (neighbouring residuals correlate), but
ordered like the errors (on a seasonal Landsat pair the windows in the top quarter of σ had
4x the error of the bottom quarter).

Local distortions inside a window (the shift is not constant) are not modelled here:
:func:`fotogeo.coreg.pipeline.coregister_strips` measures again on a target deformed by the
field of the previous pass, where the remaining shift is nearly constant. Where the shift
varies inside the window, the estimate is the average of the local shifts weighted by the
information ``p |∇g|²``, i.e. for a linear variation the shift at the information centroid
``Σ p |∇g|² x / Σ p |∇g|²`` (:func:`centroid`), not at the window centre: where texture
gathers in one corner the two differ by tens of pixels. The centroid is returned and the
field is fitted there.

The correlation ``ρ = Re Σ p f ḡ / sqrt(Σ p|f|² · Σ p|g|²)`` (times the sign of the gain) is
given at zero shift (``ncc_before``: the images as they are) and at the solution
(``ncc_after``).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..models.threads import blas_threads_for
from .representation import valid_core

#: half-width of the Lanczos kernel (taps per axis = 2·LANCZOS)
LANCZOS = 3


@dataclass(frozen=True)
class Refined:
    """Per window: ``shift`` (N, 2) px; ``sigma`` (N, 2) px; ``offset`` (N, 2) the information
    centroid (:func:`centroid`) relative to the window centre, px; ``gain`` (N,);
    ``ncc_before``, ``ncc_after`` (N,); ``iterations`` (N,); ``status`` (N,) "converged",
    "max iterations", "diverged", "singular normal matrix", "window outside image" or
    "flat patch"."""

    shift: np.ndarray
    sigma: np.ndarray
    offset: np.ndarray
    gain: np.ndarray
    ncc_before: np.ndarray
    ncc_after: np.ndarray
    iterations: np.ndarray
    status: np.ndarray


def lanczos_weights(t: float, a: int = LANCZOS) -> np.ndarray:
    """Weights of the samples at offsets ``−a+1 … a`` for a fraction ``t`` in [0, 1), summing to 1.

    >>> (lanczos_weights(0.0).round(6) + 0.0).tolist()
    [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    """
    k = np.arange(-a + 1, a + 1, dtype=np.float64)
    x = k - t
    w = np.sinc(x) * np.sinc(x / a)
    return w / w.sum()


def shifted_window(img: np.ndarray, r0: int, c0: int, n: int, shift) -> np.ndarray | None:
    """``img`` sampled at the centres of the ``n x n`` block with top-left array index
    ``(r0, c0)`` moved by ``shift = (dx, dy)`` px (Lanczos-3); None when it leaves ``img``."""
    dx, dy = float(shift[0]), float(shift[1])
    ix, iy = int(np.floor(dx)), int(np.floor(dy))
    tx, ty = dx - ix, dy - iy
    a = LANCZOS
    rr, cc = r0 + iy - a + 1, c0 + ix - a + 1
    if rr < 0 or cc < 0 or rr + n + 2 * a - 1 > img.shape[0] or cc + n + 2 * a - 1 > img.shape[1]:
        return None
    block = np.ascontiguousarray(img[rr:rr + n + 2 * a - 1, cc:cc + n + 2 * a - 1])
    cplx = np.iscomplexobj(block)
    src = block.view(np.float32).reshape(block.shape + (2,)) if cplx else block.astype(np.float32, copy=False)
    out = cv2.sepFilter2D(src, cv2.CV_32F, lanczos_weights(tx), lanczos_weights(ty), anchor=(0, 0),
                          borderType=cv2.BORDER_CONSTANT)[:n, :n]
    return np.ascontiguousarray(out).view(np.complex64)[..., 0] if cplx else out


def _ncc(f, g, p) -> float:
    num = float(np.real(np.sum(p * f * np.conj(g))))
    den = float(np.sqrt(np.sum(p * np.abs(f) ** 2) * np.sum(p * np.abs(g) ** 2)))
    return num / den if den > 0 else np.nan


def _gradients(m):
    """Central differences ``(∂/∂x, ∂/∂y)`` of the inner part of ``m`` (an array with a 1-px margin)."""
    return 0.5 * (m[1:-1, 2:] - m[1:-1, :-2]), 0.5 * (m[2:, 1:-1] - m[:-2, 1:-1])


def _dot(a, b) -> float:
    """``Re Σ ā b`` over all elements (one BLAS call; real arrays too)."""
    return float(np.real(np.vdot(a, b)))


def _step(f, f_grad, gm, p, r):
    """One Gauss–Newton step: ``(δ, N, vᵀPv)`` for the window ``gm`` (with a 1-px margin).

    The Jacobian of the shift is the mean of the template's gradient and the moved window's,
    ``(∇f + r ∇g)/2`` (efficient second-order minimisation, Benhimane & Malis 2004): it
    converges in a few steps where ``r ∇g`` alone crawls (windows of two dates differ). A
    complex value is two real observations (``Re(āb) = a_re b_re + a_im b_im``), so every
    entry of the normal equations is one ``Re Σ ā P b``."""
    g = gm[1:-1, 1:-1]
    gx, gy = _gradients(gm)
    cols = (0.5 * (r * gx + f_grad[0]), 0.5 * (r * gy + f_grad[1]), g)
    v = f - r * g
    pcols = [p * c for c in cols]
    N = np.array([[_dot(a, pb) for pb in pcols] for a in cols])
    b = np.array([_dot(pa, v) for pa in pcols])
    return np.linalg.solve(N, b), N, _dot(v, p * v)


def centroid(gm, p) -> np.ndarray:
    """Offset ``(x, y)`` from the window centre of the information centroid
    ``Σ p |∇g|² x / Σ p |∇g|²`` of the window ``gm`` (with a 1-px margin)."""
    gx, gy = _gradients(gm)
    W = p * (np.abs(gx) ** 2 + np.abs(gy) ** 2)
    s = float(W.sum())
    if not s > 0:
        return np.zeros(2)
    k = np.arange(W.shape[0]) + 0.5 - W.shape[0] / 2
    return np.array([float(W.sum(axis=0) @ k), float(W.sum(axis=1) @ k)]) / s


def _fail(d, status, it, r=np.nan, before=np.nan):
    nan2 = np.full(2, np.nan)
    return d, nan2, nan2, r, before, np.nan, it, status


def _weights(p, f_valid, g_valid, r0: int, c0: int, d) -> np.ndarray | None:
    """``p`` where the template and the moved window are both valid (``g_valid`` eroded by the
    interpolation support: the window at the integer part of ``d`` suffices); None if outside."""
    w = p.shape[0]
    rr, cc = r0 + int(np.floor(d[1])), c0 + int(np.floor(d[0]))
    if rr < 0 or cc < 0 or rr + w + 1 > g_valid.shape[0] or cc + w + 1 > g_valid.shape[1]:
        return None
    gv = g_valid[rr:rr + w, cc:cc + w] & g_valid[rr + 1:rr + w + 1, cc + 1:cc + w + 1]
    return p * (f_valid & gv)


def refine_one(fm, g_img, r0: int, c0: int, start, p, *, f_valid=None, g_valid=None, max_iterations: int = 12,
               tolerance: float = 1e-3, max_move: float = 2.0):
    """LSM of one window: ``fm`` (w + 2, w + 2: the template with a 1-px margin) against
    ``g_img`` whose block ``[r0:r0+w, c0:c0+w]`` is
    the window's position at zero shift; ``f_valid`` (w, w) and ``g_valid`` (like ``g_img``,
    eroded by the interpolation support) exclude nodata from the fit. Returns the fields of
    :class:`Refined` for the window."""
    f, f_grad = fm[1:-1, 1:-1], _gradients(fm)
    w = f.shape[0]
    d = np.asarray(start, dtype=np.float64).copy()
    f_valid = np.ones(f.shape, bool) if f_valid is None else f_valid
    g_valid = np.ones(g_img.shape, bool) if g_valid is None else g_valid
    r, before, chans = 1.0, np.nan, 2 if np.iscomplexobj(f) else 1
    for it in range(1, max_iterations + 1):
        gm = shifted_window(g_img, r0 - 1, c0 - 1, w + 2, d)
        pw = _weights(p, f_valid, g_valid, r0, c0, d)
        if gm is None or pw is None:
            return _fail(d, "window outside image", it, r, before)
        if it == 1:
            p0 = _weights(p, f_valid, g_valid, r0, c0, (0.0, 0.0))
            g0 = shifted_window(g_img, r0, c0, w, (0.0, 0.0))
            before = _ncc(f, g0, p0) if p0 is not None and g0 is not None else np.nan
            gg = float(np.sum(pw * np.abs(gm[1:-1, 1:-1]) ** 2))
            if gg <= 0:
                return _fail(d, "flat patch", it, r, before)
            r = float(np.real(np.sum(pw * f * np.conj(gm[1:-1, 1:-1])))) / gg
            if not abs(r) > 0:
                return _fail(d, "diverged", it, r, before)
            sign = np.sign(r)
        try:
            delta, N, vv = _step(f, f_grad, gm, pw, r)
        except np.linalg.LinAlgError:
            return _fail(d, "singular normal matrix", it, r, before)
        d += delta[:2]
        r += delta[2]
        if not (np.isfinite(d).all() and r * sign > 0 and np.hypot(*(d - start)) <= max_move):
            return _fail(d, "diverged", it, r, before)
        if np.hypot(*delta[:2]) < tolerance:
            break
    else:
        it = max_iterations + 1
    n = chans * float(pw.sum() / max(float(pw.max()), 1e-12))
    cov = vv / max(n - 3.0, 1.0) * np.linalg.inv(N)[:2, :2]
    gf = shifted_window(g_img, r0, c0, w, d)
    after = _ncc(f, gf, pw) if gf is not None else np.nan
    status = "converged" if it <= max_iterations else "max iterations"
    return (d, np.sqrt(np.diag(cov)), centroid(gm, pw), r, before * sign, after * sign, min(it, max_iterations),
            status)


def refine_windows(f_img, g_img, corners, starts, taper, *, f_valid=None, g_valid=None, **options) -> Refined:
    """LSM of each window: ``corners`` (N, 2) top-left ``(col, row)`` array indices of the
    windows in both strips, ``starts`` (N, 2) approximate shifts, ``taper`` (w, w) the weights;
    ``f_valid``, ``g_valid`` validity of the strips (default all valid; ``g_valid`` is eroded
    here by the interpolation support). ``options``: ``max_iterations``, ``tolerance`` (px),
    ``max_move`` (px from the start)."""
    w = taper.shape[0]
    f_valid = np.ones(f_img.shape, bool) if f_valid is None else f_valid
    g_core = valid_core(np.ones(g_img.shape, bool) if g_valid is None else g_valid, LANCZOS + 1)
    out = []
    with blas_threads_for(2 * w * w, 3):  # 3x3 normal equations from (2w², 3) products: one BLAS thread
        for (c0, r0), start in zip(np.asarray(corners, int), np.asarray(starts, float)):
            fm = f_img[r0 - 1:r0 + w + 1, c0 - 1:c0 + w + 1]
            out.append(refine_one(fm, g_img, int(r0), int(c0), start, taper, f_valid=f_valid[r0:r0 + w, c0:c0 + w],
                                  g_valid=g_core, **options))
    cols = list(zip(*out)) if out else [[]] * 8
    return Refined(*(np.array(c, float).reshape(-1, 2) for c in cols[:3]), np.array(cols[3], float),
                   np.array(cols[4], float), np.array(cols[5], float), np.array(cols[6], int),
                   np.array(cols[7], dtype=object).astype(str))
