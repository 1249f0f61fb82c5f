"""Coarse similarity between two images of unknown rotation, scale and offset (Fourier–Mellin).

For an unreferenced target: the similarity ``x_ref = s·R(θ)·x_tgt + t`` (pixels, corner
convention) that brings the target onto the reference, found area-based when feature matching
fails, so that the windows of :mod:`fotogeo.coreg` can then measure tie points on the target
pre-aligned by it.

Fourier–Mellin (Reddy & Chatterji 1996). With ``g(x) = f(A x + t)`` and ``A = s R(θ)``, the
Fourier transforms satisfy ``|G(u)| ∝ |F(A⁻ᵀ u)| = |F(R(θ) u / s)|``: the magnitude spectra do
not depend on ``t``, and in log-polar coordinates ``(ρ, φ) = (log |u|, arg u)``

    |G|(ρ, φ) = |F|(ρ − log s, φ + θ),

a pure shift, measured by phase correlation (:func:`fotogeo.coreg.phase.phase_correlate`). The
spectra are of images tapered by a circular Hann window (a taper whose spectrum is itself
rotation-invariant), their logarithm weighted by Reddy & Chatterji's high-pass
``H(ξ, η) = (1 − X)(2 − X)``, ``X = cos(πξ)·cos(πη)`` (ξ, η in [−½, ½]). A real image's magnitude
spectrum is point-symmetric, so only ``φ ∈ [0, π)`` is sampled and θ is known modulo 180°: both
θ and θ + 180° are tried, and the one whose translation correlation peaks higher is kept.

Translation: the target resampled by ``A`` onto the reference window, both turned into the
gradient-orientation representation (:mod:`fotogeo.coreg.representation`: blind to contrast
inversion and gain), phase correlation gives ``t``. Its *peak ratio* (highest peak over the
highest beyond 3 px) is the estimate's confidence: a rotation, scale or offset that is wrong
leaves no coherent peak.

Pyramid: the search runs on images decimated so that the target is about ``COARSE_SIDE`` px,
on square windows of the reference of the target's size laid every half window (a target that
is a chip of a larger reference); the best candidate is then refined at ``FINE_SIDE`` px by
the same steps on the reference pre-aligned to it (residual rotation and scale near zero).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import MatchingError
from .phase import hann, phase_correlate
from .representation import represent

#: longer side (px) of the target at the search level and at the refinement level
COARSE_SIDE = 256
FINE_SIDE = 512
#: log-polar samples (angle and log-radius alike) per image side
POLAR_SAMPLES = 256
#: the lowest radius of the log-polar sampling (frequency bins): lower frequencies are dominated
#: by the taper and the illumination
MIN_RADIUS = 3.0
#: peak ratio of the translation correlation below which the similarity is refused
MIN_CONFIDENCE = 3.0
#: scales outside this range (target px in reference px) are not searched
SCALE_RANGE = (0.4, 2.5)
#: the refinement's residual rotation (degrees) and scale beyond which it is not trusted (the search's kept)
REFINE_MAX_ANGLE = 20.0
REFINE_SCALES = (0.8, 1.25)


@dataclass(frozen=True)
class Similarity:
    """``matrix`` (3, 3): target pixel -> reference pixel (corner convention), ``scale`` (target px
    in reference px), ``angle`` (degrees, counter-clockwise in the image's x right / y down axes as
    ``R(θ) = [[cos, −sin], [sin, cos]]``), ``shift`` = t; ``confidence`` the translation's peak ratio,
    ``rotation_ratio`` the log-polar correlation's, ``level`` the pixel factor of the final step."""

    matrix: np.ndarray
    scale: float
    angle: float
    shift: np.ndarray
    confidence: float
    rotation_ratio: float
    level: float

    def apply(self, xy) -> np.ndarray:
        """Reference pixels of target pixels ``xy`` (N, 2)."""
        xy = np.asarray(xy, float).reshape(-1, 2)
        return xy @ self.matrix[:2, :2].T + self.matrix[:2, 2]


def similarity_matrix(scale: float, angle_deg: float, shift) -> np.ndarray:
    """``[[s·cos θ, −s·sin θ, tx], [s·sin θ, s·cos θ, ty], [0, 0, 1]]``."""
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    return np.array([[scale * c, -scale * s, shift[0]], [scale * s, scale * c, shift[1]], [0.0, 0.0, 1.0]])


def _decimated(img: np.ndarray, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """``img`` (NaN = nodata) reduced by ``factor`` ≥ 1 (area average; NaN where mostly invalid) and
    the matrix from its pixels to ``img``'s (corner convention)."""
    if factor <= 1.0 + 1e-9:
        return img.astype(np.float32), np.eye(3)
    valid = np.isfinite(img).astype(np.float32)
    filled = np.where(valid > 0, img, 0).astype(np.float32)
    size = (max(8, int(round(img.shape[1] / factor))), max(8, int(round(img.shape[0] / factor))))
    s = cv2.resize(filled, size, interpolation=cv2.INTER_AREA)
    w = cv2.resize(valid, size, interpolation=cv2.INTER_AREA)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(w > 0.5, s / w, np.nan).astype(np.float32)
    return out, np.diag([img.shape[1] / size[0], img.shape[0] / size[1], 1.0])


def opencv_matrix(M: np.ndarray) -> np.ndarray:
    """The 2x3 matrix OpenCV's warps take (pixel centres at integers) for the corner-convention
    ``M`` ``x' = A x + t``: ``[A, t + (A − I)·½]``."""
    A = M[:2, :2]
    return np.hstack([A, (M[:2, 2] + (A - np.eye(2)) @ [0.5, 0.5])[:, None]])


def _circular_taper(n: int) -> np.ndarray:
    """``cos²(π r / 2R)`` inside the circle ``r < R = n / 2`` of an ``n x n`` array."""
    c = (np.arange(n) + 0.5) - n / 2
    r = np.hypot(*np.meshgrid(c, c)) / (n / 2)
    return np.where(r < 1, np.cos(0.5 * np.pi * r) ** 2, 0.0).astype(np.float32)


def _tapered(img: np.ndarray, n: int) -> np.ndarray:
    """``img`` centred in an ``n x n`` array, minus its valid mean, times the circular taper."""
    out = np.zeros((n, n), np.float32)
    h, w = img.shape
    r0, c0 = (n - h) // 2, (n - w) // 2
    valid = np.isfinite(img)
    mean = float(img[valid].mean()) if valid.any() else 0.0
    out[max(r0, 0):r0 + h, max(c0, 0):c0 + w] = np.where(valid, img - mean, 0)[max(-r0, 0):n - r0, max(-c0, 0):n - c0]
    return out * _circular_taper(n)


def log_polar_spectrum(img: np.ndarray, n: int, samples: int = POLAR_SAMPLES) -> tuple[np.ndarray, float]:
    """The high-passed log magnitude spectrum of ``img`` (tapered into ``n x n``) in log-polar
    coordinates: rows φ = π·k / samples, columns ρ = log r_min + j·Δ, and Δ (module docstring)."""
    F = np.fft.fftshift(np.abs(np.fft.fft2(_tapered(img, n))))
    f = (np.arange(n) - n // 2) / n
    X = np.outer(np.cos(np.pi * f), np.cos(np.pi * f))
    mag = (np.log1p(F) * (1.0 - X) * (2.0 - X)).astype(np.float32)
    r_max = n / 2 - 1
    step = np.log(r_max / MIN_RADIUS) / samples
    phi = np.pi * np.arange(samples) / samples
    rho = np.exp(np.log(MIN_RADIUS) + step * np.arange(samples))
    mx = (n // 2 + np.outer(np.cos(phi), rho)).astype(np.float32)
    my = (n // 2 + np.outer(np.sin(phi), rho)).astype(np.float32)
    return cv2.remap(mag, mx, my, cv2.INTER_LINEAR, borderValue=0.0), float(step)


def rotation_scale(ref: np.ndarray, tgt: np.ndarray) -> tuple[float, float, float]:
    """``(scale, angle mod 180°, peak ratio)`` of ``tgt`` relative to ``ref`` (module docstring)."""
    n = int(2 ** np.ceil(np.log2(max(*ref.shape, *tgt.shape))))
    lp_r, step = log_polar_spectrum(ref, n)
    lp_t, _ = log_polar_spectrum(tgt, n)
    taper = np.outer(np.ones(POLAR_SAMPLES), hann(POLAR_SAMPLES)[0] / hann(POLAR_SAMPLES)[0].max()).astype(np.float32)
    p = phase_correlate(lp_r[None], lp_t[None], taper)
    d_rho, d_phi = p.shift[0]
    scale = float(np.exp(d_rho * step))
    angle = float(-d_phi * 180.0 / POLAR_SAMPLES)
    return scale, angle, float(p.ratio[0])


def _pad_square(rep: np.ndarray, n: int) -> np.ndarray:
    out = np.zeros((n, n), rep.dtype)
    h, w = rep.shape
    out[:min(h, n), :min(w, n)] = rep[:n, :n]
    return out


def translation(ref: np.ndarray, tgt: np.ndarray, matrix: np.ndarray) -> tuple[np.ndarray, float]:
    """``(t, peak ratio)``: the target resampled by ``matrix`` (target px -> reference px, its
    translation ignored but for the window's placement) onto the reference's grid and phase
    correlated there; ``t`` completes ``matrix``'s linear part."""
    h, w = ref.shape
    A = matrix[:2, :2]
    centre_t = np.array([tgt.shape[1] / 2, tgt.shape[0] / 2])
    centre_r = np.array([w / 2, h / 2])
    M = np.vstack([np.hstack([A, (centre_r - A @ centre_t)[:, None]]), [0, 0, 1]])  # centre on centre
    M = cv2.invertAffineTransform(opencv_matrix(np.linalg.inv(M)))
    valid = cv2.warpAffine(np.isfinite(tgt).astype(np.float32), M, (w, h), flags=cv2.INTER_LINEAR)
    warped = cv2.warpAffine(np.nan_to_num(tgt), M, (w, h), flags=cv2.INTER_LINEAR)
    warped[valid < 0.99] = np.nan
    n = int(2 ** np.ceil(np.log2(max(h, w))))
    zr = _pad_square(represent(ref), n)
    zt = _pad_square(represent(warped), n)
    p = phase_correlate(zr[None], zt[None], np.ones((n, n), np.float32))
    d = p.shift[0]  # reference(x) = warped(x + d): warped pixel x + d <-> reference pixel x
    return centre_r - A @ centre_t - d, float(p.ratio[0]) if not p.at_border[0] else 1.0


def _candidates(ref: np.ndarray, side: int) -> list[tuple[int, int]]:
    """Top-left corners of ``side``-px square windows of ``ref`` every half window (one window when
    the reference is not much larger)."""
    h, w = ref.shape
    def starts(length):
        if length <= 1.5 * side:
            return [max(0, (length - side) // 2)]
        step = max(1, side // 2)
        s = list(range(0, length - side + 1, step))
        return s if s[-1] == length - side else s + [length - side]
    return [(r, c) for r in starts(h) for c in starts(w)]


def _solve(ref: np.ndarray, tgt: np.ndarray, side: int):
    """The best ``(confidence, matrix, rotation ratio)`` over reference windows and the 180° ambiguity."""
    best = (0.0, None, 0.0)
    for r0, c0 in _candidates(ref, side):
        win = ref[r0:r0 + side, c0:c0 + side]
        if np.isfinite(win).mean() < 0.3:
            continue
        scale, angle, ratio = rotation_scale(win, tgt)
        if not SCALE_RANGE[0] <= scale <= SCALE_RANGE[1]:
            continue
        for a in (angle, angle + 180.0):
            M = similarity_matrix(scale, a, (0.0, 0.0))
            t, conf = translation(win, tgt, M)
            if conf > best[0]:
                best = (conf, similarity_matrix(scale, a, t + (c0, r0)), ratio)
    return best


def estimate_similarity(reference: np.ndarray, target: np.ndarray, *, min_confidence: float = MIN_CONFIDENCE,
                        name: str = "the target") -> Similarity:
    """The similarity target -> reference of two 2-D images (NaN = nodata), module docstring.

    Raises :class:`MatchingError` when its confidence is below ``min_confidence``.
    """
    reference = np.asarray(reference, np.float32)
    target = np.asarray(target, np.float32)
    k = max(1.0, max(target.shape) / COARSE_SIDE)
    (ref_c, K_r), (tgt_c, K_t) = _decimated(reference, k), _decimated(target, k)
    conf, M, ratio = _solve(ref_c, tgt_c, max(tgt_c.shape))
    if M is None or conf < min_confidence:
        raise MatchingError(f"no rotation/scale/offset of {name} matches the reference (Fourier–Mellin: best peak "
                            f"ratio {conf:.2f} < {min_confidence}); the images may not show the same area")
    M = K_r @ M @ np.linalg.inv(K_t)  # full-resolution pixels
    M, conf, ratio, level = _refine(reference, target, M, conf, ratio, k)
    scale = float(np.sqrt(abs(np.linalg.det(M[:2, :2]))))
    angle = float(np.degrees(np.arctan2(M[1, 0], M[0, 0])))
    return Similarity(M, scale, angle, M[:2, 2].copy(), conf, ratio, level)


def _refine(reference, target, M, conf, ratio, k_coarse):
    """The similarity ``M`` again at the finer level: the reference window under the target resampled
    onto the target's grid by ``M``, whose residual rotation, scale and offset are measured."""
    k = max(1.0, max(target.shape) / FINE_SIDE)
    if k >= k_coarse - 1e-9:
        return M, conf, ratio, k_coarse
    (tgt, K_t), (ref, K_r) = _decimated(target, k), _decimated(reference, k)
    Mk = np.linalg.inv(K_r) @ M @ K_t  # target px (level) -> reference px (level)
    h, w = tgt.shape
    cv_m = opencv_matrix(Mk)
    on_tgt = cv2.warpAffine(np.nan_to_num(ref, nan=0), cv_m, (w, h), flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR)
    ok = cv2.warpAffine(np.isfinite(ref).astype(np.float32), cv_m, (w, h),
                        flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR)
    on_tgt[ok < 0.99] = np.nan
    scale, angle, r2 = rotation_scale(on_tgt, tgt)
    best = (0.0, None)
    for a in (angle, angle + 180.0):
        if abs(((a + 180) % 360) - 180) > REFINE_MAX_ANGLE or not REFINE_SCALES[0] < scale < REFINE_SCALES[1]:
            continue
        D = similarity_matrix(scale, a, (0.0, 0.0))
        t, c = translation(on_tgt, tgt, D)
        if c > best[0]:
            best = (c, similarity_matrix(scale, a, t))
    if best[1] is None or best[0] < conf:
        return M, conf, ratio, k_coarse
    return K_r @ Mk @ best[1] @ np.linalg.inv(K_t), best[0], r2, k
