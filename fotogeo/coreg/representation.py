"""Radiometry-robust representations of an image for area-based co-registration.

Two dates or two sensors of one scene differ in brightness, contrast, even in the sign of
contrast (a field darker than the road in June, brighter in November; shadows of another
sun). Matching the grey values themselves (AROSICS, Scheffler et al. 2017) needs them to
be related by one gain and offset per window; these representations keep the geometry and
drop most of the radiometry. Each maps a float image ``I`` (NaN = nodata) to an array of the
same shape, zero where ``I`` is invalid or within ``margin`` pixels of an invalid pixel (a
nodata border must not look like an edge).

``"orientation"`` (default) — the doubled-angle gradient orientation, weighted by the
locally normalised gradient magnitude (Fitch et al. 2002 use the single angle; the doubled
angle makes it blind to contrast inversion):

    g = ∇(G_σ * I) = (gx, gy),   m = |g|,   s = sqrt(G_S * m²)  (local RMS magnitude),
    z = (gx + i·gy)² / (m · (s + ε)) = (m / (s + ε)) · exp(2iθ),     θ = atan2(gy, gx).

An edge keeps its weight whether it lies in bright sunlight or in a shadow (the division by
``s``) and whether it is brighter or darker on its left (θ and θ + π give the same 2θ).

``"gradient"`` — the same without the doubled angle, ``z = (gx + i·gy) / (s + ε)``: keeps the
contrast sign (for pairs of one sensor where contrast never inverts).

``"rank"`` — the rank transform (Zabih & Woodfill 1994): the fraction of the
``(2r+1)²`` neighbours darker than the pixel, minus ½: invariant to any monotone change of
the grey values, not to inversion.

``"intensity"`` — the grey values themselves minus their local mean (what AROSICS matches).

Complex representations are ``complex64``, real ones ``float32``.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..errors import InputError
from ..options import COREG_REPRESENTATIONS

#: the representations, the first being the default
REPRESENTATIONS = COREG_REPRESENTATIONS
#: Gaussian σ (px) before the gradients: suppresses noise and aliasing, keeps 1-px detail
GRADIENT_SIGMA = 1.0
#: σ (px) of the local RMS magnitude ``s`` that normalises the gradient weights
NORMALISE_SIGMA = 8.0
#: radius of the rank-transform neighbourhood
RANK_RADIUS = 3


def valid_core(valid: np.ndarray, margin: int) -> np.ndarray:
    """``valid`` eroded by ``margin`` pixels (a square structuring element)."""
    if margin <= 0 or valid.all():
        return valid.copy()
    k = np.ones((2 * margin + 1, 2 * margin + 1), np.uint8)
    return cv2.erode(valid.astype(np.uint8), k, borderType=cv2.BORDER_REPLICATE).astype(bool)


def _filled(image: np.ndarray):
    """float32 image with invalid pixels set to the valid mean, and the validity mask."""
    img = np.asarray(image, dtype=np.float32)
    valid = np.isfinite(img)
    if valid.all():
        return img, valid
    fill = float(img[valid].mean()) if valid.any() else 0.0
    return np.where(valid, img, np.float32(fill)), valid


def _gradients(img: np.ndarray, sigma: float):
    sm = cv2.GaussianBlur(img, (0, 0), sigma, borderType=cv2.BORDER_REFLECT) if sigma > 0 else img
    gx = cv2.Sobel(sm, cv2.CV_32F, 1, 0, ksize=3, scale=0.125, borderType=cv2.BORDER_REFLECT)
    gy = cv2.Sobel(sm, cv2.CV_32F, 0, 1, ksize=3, scale=0.125, borderType=cv2.BORDER_REFLECT)
    return gx, gy


def _local_rms(m2: np.ndarray, sigma: float, eps: float) -> np.ndarray:
    return np.sqrt(cv2.GaussianBlur(m2, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)) + np.float32(eps)


def _oriented(img: np.ndarray, doubled: bool, sigma: float) -> np.ndarray:
    gx, gy = _gradients(img, sigma)
    m2 = gx * gx + gy * gy
    eps = 1e-3 * float(np.sqrt(m2.mean())) + 1e-12
    s = _local_rms(m2, NORMALISE_SIGMA, eps)
    z = np.empty(img.shape, np.complex64)
    if doubled:
        m = np.sqrt(m2) + np.float32(1e-30)
        z.real = (gx * gx - gy * gy) / (m * s)
        z.imag = 2.0 * gx * gy / (m * s)
    else:
        z.real = gx / s
        z.imag = gy / s
    return z


def _rank(img: np.ndarray, radius: int) -> np.ndarray:
    sm = cv2.GaussianBlur(img, (0, 0), 0.7, borderType=cv2.BORDER_REFLECT)
    pad = cv2.copyMakeBorder(sm, radius, radius, radius, radius, cv2.BORDER_REFLECT)
    H, W = img.shape
    count = np.zeros(img.shape, np.float32)
    for dy in range(2 * radius + 1):
        for dx in range(2 * radius + 1):
            count += pad[dy:dy + H, dx:dx + W] < sm
    return count / np.float32((2 * radius + 1) ** 2 - 1) - np.float32(0.5)


def _intensity(img: np.ndarray) -> np.ndarray:
    return img - cv2.GaussianBlur(img, (0, 0), 4 * NORMALISE_SIGMA, borderType=cv2.BORDER_REFLECT)


def represent(image: np.ndarray, kind: str = "orientation", *, sigma: float = GRADIENT_SIGMA,
              margin: int | None = None, with_valid: bool = False):
    """The representation ``kind`` of ``image`` (2-D, NaN = nodata); see the module docstring.

    ``margin`` (default: 2 px, ``RANK_RADIUS`` + 1 for the rank) — pixels this close to nodata
    get 0. Invalid pixels are 0 too, so they add nothing to a correlation or a fit. With
    ``with_valid``, returns ``(representation, valid)``, ``valid`` the pixels not set to 0 for
    that reason (a valid pixel may be 0 too: no gradient in a flat area).

    >>> z = represent(np.tile(np.arange(16.0), (16, 1)))
    >>> bool(z[8, 8].real > 0.5 and abs(z[8, 8].imag) < 1e-3)  # vertical edges: 2θ = 0
    True
    >>> zi = represent(-np.tile(np.arange(16.0), (16, 1)))  # contrast inverted: the same
    >>> bool(np.allclose(z, zi, atol=1e-5))
    True
    """
    if kind not in REPRESENTATIONS:
        raise InputError(f"representation {kind!r} unknown; choose one of {', '.join(REPRESENTATIONS)}")
    img = np.asarray(image)
    if img.ndim != 2:
        raise InputError(f"image must be 2-D; got shape {img.shape}")
    img, valid = _filled(img)
    if kind in ("orientation", "gradient"):
        out = _oriented(img, kind == "orientation", sigma)
        default_margin = 2
    elif kind == "rank":
        out = _rank(img, RANK_RADIUS)
        default_margin = RANK_RADIUS + 1
    else:
        out = _intensity(img)
        default_margin = 1
    ok = valid_core(valid, default_margin if margin is None else int(margin))
    out[~ok] = 0
    return (out, ok) if with_valid else out
