"""Phase correlation of many windows at once (Kuglin & Hines 1975).

Windows ``f`` (reference) and ``g`` (target) of ``w x w`` pixels, real or complex, are
tapered by a Hann window ``h`` and Fourier transformed. If ``g(x) = f(x − d)`` then
``G = F · exp(−2πi u·d)``, and the normalised cross-power spectrum

    C(u) = G(u) · F*(u) / |G(u) · F*(u)|

is a pure phase ramp whose inverse transform ``r = F⁻¹{C}`` is a Dirac at ``x = d``: the
position of the highest peak of ``Re r`` (``fftshift``-ed, so that zero shift is at the centre)
is the integer shift, found whatever the brightness and contrast of the two windows.
Convention: ``d`` is the shift of the target, ``f(x) = g(x + d)`` (target pixel = reference
pixel + d), in pixels, ``(dx, dy)``.

Sub-pixel: a parabola through the peak and its two neighbours along each axis (a first
estimate; :mod:`fotogeo.coreg.refine` improves it by least squares).

Reliability: the *peak ratio* — the highest peak over the highest value farther than
``EXCLUSION`` px from it (1 = ambiguous; phase correlation of unrelated windows gives
about 1.1–1.3 for 128² windows, good matches above 2) — and the *peak height* (the fraction of
the spectral energy that is coherent: 1 for identical windows, about 1/w for noise).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft

#: peaks closer than this (px) to the highest count as the same peak
EXCLUSION = 3


@dataclass(frozen=True)
class PhasePeaks:
    """Phase-correlation results of N windows: ``shift`` (N, 2) ``(dx, dy)`` px with
    ``f(x) = g(x + shift)``; ``peak`` (N,) height of the highest peak; ``ratio`` (N,) highest
    over second-highest peak; ``at_border`` (N,) the peak is within one pixel of the
    surface's edge (shift ≈ ±w/2: not measurable)."""

    shift: np.ndarray
    peak: np.ndarray
    ratio: np.ndarray
    at_border: np.ndarray


def hann(w: int) -> np.ndarray:
    """The ``w x w`` Hann taper ``h(i, j) = s(i)·s(j)``, ``s(k) = sin²(π (k + ½) / w)``,
    symmetric about the window centre (float32).

    >>> h = hann(4); bool(np.allclose(h, h[::-1, ::-1])), round(float(h.max()), 3)
    (True, 0.729)
    """
    s = np.sin(np.pi * (np.arange(w) + 0.5) / w) ** 2
    return np.outer(s, s).astype(np.float32)


def _parabola(cm, c0, cp):
    den = cm - 2.0 * c0 + cp
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(den < 0, 0.5 * (cm - cp) / den, 0.0)
    return np.clip(t, -0.5, 0.5)


def _second_peak(surf: np.ndarray, iy: np.ndarray, ix: np.ndarray) -> np.ndarray:
    n, H, W = surf.shape
    yy = np.arange(H)[None, :, None] - iy[:, None, None]
    xx = np.arange(W)[None, None, :] - ix[:, None, None]
    near = (np.abs(yy) <= EXCLUSION) & (np.abs(xx) <= EXCLUSION)
    return np.where(near, -np.inf, surf).reshape(n, -1).max(axis=1)


def correlation_surfaces(f: np.ndarray, g: np.ndarray, taper: np.ndarray, workers: int = 1) -> np.ndarray:
    """``Re r`` of each window pair (N, w, w), zero shift at index ``[w//2, w//2]``."""
    F = scipy.fft.fft2(f * taper, workers=workers)
    G = scipy.fft.fft2(g * taper, workers=workers)
    C = G * np.conj(F)
    mag = np.abs(C)
    floor = 1e-12 * mag.reshape(len(C), -1).max(axis=1)[:, None, None] + 1e-30
    r = scipy.fft.ifft2(C / np.maximum(mag, floor), workers=workers)
    return scipy.fft.fftshift(r.real, axes=(-2, -1)).astype(np.float32)


def phase_correlate(f: np.ndarray, g: np.ndarray, taper: np.ndarray | None = None, *,
                    workers: int = 1) -> PhasePeaks:
    """Phase correlation of window stacks ``f``, ``g`` (N, w, w); see the module docstring.

    >>> rng = np.random.default_rng(0); img = rng.normal(size=(80, 80))
    >>> f = img[8:72, 8:72][None]; g = img[5:69, 10:74][None]   # g(x) = f(x − (−2, 3))
    >>> p = phase_correlate(f, g); p.shift.round(2).tolist(), bool(p.ratio[0] > 3)
    ([[-2.0, 3.0]], True)
    """
    f = np.asarray(f)
    g = np.asarray(g)
    n, w = f.shape[0], f.shape[-1]
    taper = hann(w) if taper is None else taper
    surf = correlation_surfaces(f, g, taper, workers)
    flat = surf.reshape(n, -1)
    k = flat.argmax(axis=1)
    iy, ix = np.unravel_index(k, (w, w))
    peak = flat[np.arange(n), k].astype(np.float64)
    second = _second_peak(surf, iy, ix)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(second > 0, peak / second, np.inf)
    border = (iy <= 0) | (ix <= 0) | (iy >= w - 1) | (ix >= w - 1)
    cy, cx = np.clip(iy, 1, w - 2), np.clip(ix, 1, w - 2)
    a = np.arange(n)
    sx = _parabola(surf[a, cy, cx - 1], surf[a, cy, cx], surf[a, cy, cx + 1])
    sy = _parabola(surf[a, cy - 1, cx], surf[a, cy, cx], surf[a, cy + 1, cx])
    shift = np.stack([ix - w // 2 + sx, iy - w // 2 + sy], axis=1).astype(np.float64)
    return PhasePeaks(shift, peak, ratio, border)
