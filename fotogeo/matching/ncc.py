"""Normalised cross-correlation (NCC) matching with a sub-pixel peak fit.

The template is the ``(2h+1) x (2h+1)`` window of ``reference`` centred on the pixel that
contains ``ref_xy``; it is slid over ``search`` around ``approx_xy`` by
``cv2.matchTemplate(TM_CCOEFF_NORMED)``, i.e. for every candidate offset ``(u, v)``

    ρ(u, v) = Σ (f − f̄)(g_uv − ḡ_uv) / sqrt(Σ (f − f̄)² · Σ (g_uv − ḡ_uv)²)

and the integer peak is refined by fitting a parabola (or a Gaussian, i.e. a parabola to
``ln ρ``) through the peak and its two neighbours in x and in y separately:

    δ = (ρ₋ − ρ₊) / (2 (ρ₋ − 2ρ₀ + ρ₊)).

All coordinates are GDAL corner-convention ``(x, y)`` (see :mod:`fotogeo.pixels`); the
fractional part of ``ref_xy`` relative to its pixel centre is carried over to the result, so
the returned ``xy`` is the position in ``search`` homologous to ``ref_xy`` itself.

Quality measures (the 'Görüntü Eşleme' study: ρ < 0.5 is a weak match): ``ncc`` (peak ρ) and ``ambiguity``
(the second-highest local maximum of ρ, at least two pixels from the peak, divided by the
peak). Failures are reported in ``status``, never raised.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..pixels import as_points, from_centre
from .status import AMBIGUOUS, FLAT, LOW_CORRELATION, NODATA, OK, PEAK_AT_BORDER, WINDOW_OUTSIDE

# -- shared input helpers (used by lsm, pyramid and targets too) ---------------------------


def as_image(image, name: str, mask=None, mask_name: str | None = None) -> np.ndarray:
    """Return ``image`` as a 2-D float64 array with NaN where it is nodata.

    ``image``: any real numeric 2-D array (NaN = nodata). ``mask``: optional boolean array
    of the same shape, True where the pixel is valid. Raises :class:`InputError` naming the
    offending argument.
    """
    a = np.asarray(image)
    if a.ndim == 3 and a.shape[0] == 1:
        a = a[0]
    if a.ndim != 2:
        raise InputError(f"{name} must be a 2-D array (rows, cols); got shape {a.shape}. "
                         "Pass one band, e.g. image[0] or the first principal component.")
    if a.dtype == bool or not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
        raise InputError(f"{name} must be a real numeric array; got dtype {a.dtype}")
    if min(a.shape) < 3:
        raise InputError(f"{name} is too small ({a.shape}); at least 3x3 pixels are needed")
    out = a.astype(np.float64, copy=True)
    if np.isinf(out).any():
        out[np.isinf(out)] = np.nan
    if mask is not None:
        m = np.asarray(mask)
        mname = mask_name or f"{name}_mask"
        if m.shape != out.shape:
            raise InputError(f"{mname} must have the shape of {name} {out.shape}; got {m.shape}")
        out[~m.astype(bool)] = np.nan
    return out


def as_xy(xy, name: str) -> np.ndarray:
    """One point ``(x, y)`` as a float64 array of shape (2,), or :class:`InputError`."""
    p = as_points(xy, name=name)
    if p.shape[0] != 1:
        raise InputError(f"{name} must be one point (x, y); got {p.shape[0]} points")
    if not np.isfinite(p).all():
        raise InputError(f"{name} must be finite; got {p[0].tolist()}")
    return p[0]


def check_int(value, name: str, minimum: int) -> int:
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def check_range(value, name: str, lo: float, hi: float) -> float:
    v = float(value)
    if not (lo <= v <= hi):
        raise InputError(f"{name} must lie in [{lo}, {hi}]; got {value!r}")
    return v


# -- NCC ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class NCCResult:
    """Result of :func:`ncc`.

    ``xy``: sub-pixel position in ``search`` (corner convention; NaN when failed);
    ``ncc``: peak correlation ρ; ``ambiguity``: second peak / first peak (0 if none);
    ``status``: ``"ok"`` or the reason of failure; ``surface``: the correlation surface
    (rows = y offsets, cols = x offsets), kept for diagnostics.
    """

    xy: np.ndarray
    ncc: float
    ambiguity: float
    status: str
    surface: np.ndarray | None = None

    @property
    def ok(self) -> bool:
        return self.status == OK


def _fail(status: str, rho: float = np.nan, amb: float = np.nan, surface=None) -> NCCResult:
    return NCCResult(np.array([np.nan, np.nan]), float(rho), float(amb), status, surface)


def _subpixel(cm: float, c0: float, cp: float, method: str) -> float:
    if method == "gaussian":
        if min(cm, c0, cp) <= 0:
            method = "quadratic"
        else:
            cm, c0, cp = np.log(cm), np.log(c0), np.log(cp)
    den = cm - 2.0 * c0 + cp
    if not den < 0:  # not a maximum (flat or convex): keep the integer peak
        return 0.0
    return float(np.clip(0.5 * (cm - cp) / den, -0.5, 0.5))


def correlation_surface(template: np.ndarray, window: np.ndarray, min_std: float = 1e-6) -> np.ndarray:
    """TM_CCOEFF_NORMED of ``template`` over ``window`` (float64 arrays, NaN = nodata).

    Positions where the window under the template contains nodata or is flat get ``-inf``.
    """
    th, tw = template.shape
    bad = np.isnan(window)
    fill = np.nanmean(window) if (~bad).any() else 0.0
    w = np.where(bad, fill, window) - fill
    t = template - template.mean()
    rho = cv2.matchTemplate(w.astype(np.float32), t.astype(np.float32), cv2.TM_CCOEFF_NORMED).astype(np.float64)
    # local variance of the window under the template: flat windows give spurious +-1
    box = np.ones((th, tw), np.float32)
    s1 = cv2.matchTemplate(w.astype(np.float32), box, cv2.TM_CCORR).astype(np.float64)
    s2 = cv2.matchTemplate((w * w).astype(np.float32), box, cv2.TM_CCORR).astype(np.float64)
    var = s2 / box.size - (s1 / box.size) ** 2
    scale = max(float(np.abs(w).max()), 1.0)
    rho[var <= (min_std * scale) ** 2] = -np.inf
    if bad.any():
        nb = cv2.matchTemplate(bad.astype(np.float32), box, cv2.TM_CCORR)
        rho[nb > 0.5] = -np.inf
    return rho


def second_peak(rho: np.ndarray, peak: tuple[int, int], exclusion: float = 2.0) -> float:
    """Highest local maximum of ``rho`` farther than ``exclusion`` px from ``peak`` (or 0)."""
    r = np.where(np.isfinite(rho), rho, -1.0).astype(np.float32)
    dil = cv2.dilate(r, np.ones((3, 3), np.uint8))
    yy, xx = np.nonzero((r >= dil) & (r > -1.0))
    far = (yy - peak[0]) ** 2 + (xx - peak[1]) ** 2 > exclusion ** 2
    if not far.any():
        return 0.0
    return float(max(r[yy[far], xx[far]].max(), 0.0))


def ncc(reference, search, ref_xy, approx_xy, *, half_window: int = 10, search_radius: int = 16,
        min_correlation: float = 0.5, max_ambiguity: float = 0.9, subpixel: str = "quadratic",
        reference_mask=None, search_mask=None, keep_surface: bool = False) -> NCCResult:
    """Match the template of ``reference`` around ``ref_xy`` in ``search`` near ``approx_xy``.

    Parameters
    ----------
    reference, search : 2-D arrays (any real dtype, NaN = nodata)
    ref_xy, approx_xy : (x, y) in GDAL corner convention (pixel centre of [0, 0] = (0.5, 0.5))
    half_window : template is ``(2h+1)²`` pixels (the 'Görüntü Eşleme' study: at least 5x5, i.e. h >= 2)
    search_radius : integer offsets ``|u|, |v| <= r`` around ``approx_xy`` are tested
    min_correlation : peak ρ below this -> ``"low correlation"``
    max_ambiguity : second/first peak above this -> ``"ambiguous"`` (repetitive texture)
    subpixel : ``"quadratic"`` or ``"gaussian"`` peak fit
    reference_mask, search_mask : optional boolean arrays, True = valid pixel

    Returns :class:`NCCResult`; ``status`` (:mod:`fotogeo.matching.status`) is ``"ok"`` or
    one of ``"window outside image"``, ``"nodata in window"``, ``"flat patch"``,
    ``"low correlation"``, ``"ambiguous"``, ``"peak at search border"`` (the approximation
    is probably too far off).
    """
    f_img = as_image(reference, "reference", reference_mask, "reference_mask")
    g_img = as_image(search, "search", search_mask, "search_mask")
    p = as_xy(ref_xy, "ref_xy")
    q = as_xy(approx_xy, "approx_xy")
    h = check_int(half_window, "half_window", 2)
    r = check_int(search_radius, "search_radius", 1)
    check_range(min_correlation, "min_correlation", -1.0, 1.0)
    check_range(max_ambiguity, "max_ambiguity", 0.0, 1.0)
    if subpixel not in ("quadratic", "gaussian"):
        raise InputError(f"subpixel must be 'quadratic' or 'gaussian'; got {subpixel!r}")

    return match_prepared(f_img, g_img, p, q, h, r, min_correlation, max_ambiguity, subpixel, keep_surface)


def square_window(img: np.ndarray, col: int, row: int, h: int):
    """``(window, None)``: the ``(2h+1)²`` pixels of ``img`` centred on array index
    ``[row, col]``; ``(None, status)`` when it leaves the image (:data:`WINDOW_OUTSIDE`) or
    holds nodata (:data:`NODATA`, NaN pixels)."""
    H, W = img.shape
    if row - h < 0 or col - h < 0 or row + h >= H or col + h >= W:
        return None, WINDOW_OUTSIDE
    win = img[row - h:row + h + 1, col - h:col + h + 1]
    return (None, NODATA) if np.isnan(win).any() else (win, None)


def match_prepared(f_img: np.ndarray, g_img: np.ndarray, p: np.ndarray, q: np.ndarray, h: int, r: int,
                   min_correlation: float = 0.5, max_ambiguity: float = 0.9, subpixel: str = "quadratic",
                   keep_surface: bool = False) -> NCCResult:
    """:func:`ncc` on already validated float64 images (NaN = nodata) and (2,) points."""
    # template: pixel containing ref_xy, carry the fractional offset from its centre
    pc, pr = int(np.floor(p[0])), int(np.floor(p[1]))
    frac = p - from_centre([pc, pr])
    tpl, status = square_window(f_img, pc, pr, h)
    if tpl is None:
        return _fail(status)
    scale = max(float(np.abs(tpl).max()), 1.0)
    if tpl.std() <= 1e-6 * scale:
        return _fail(FLAT)

    # search region, clipped to the image
    qc, qr = int(np.floor(q[0] - frac[0])), int(np.floor(q[1] - frac[1]))
    Hs, Ws = g_img.shape
    r0, r1 = max(qr - r - h, 0), min(qr + r + h + 1, Hs)
    c0, c1 = max(qc - r - h, 0), min(qc + r + h + 1, Ws)
    if r1 - r0 < 2 * h + 3 or c1 - c0 < 2 * h + 3:
        return _fail(WINDOW_OUTSIDE)
    win = g_img[r0:r1, c0:c1]
    rho = correlation_surface(tpl, win)
    surf = rho if keep_surface else None
    if not np.isfinite(rho).any():
        return _fail(NODATA if np.isnan(win).any() else FLAT, surface=surf)
    iy, ix = np.unravel_index(int(np.argmax(rho)), rho.shape)
    best = float(rho[iy, ix])
    amb = second_peak(rho, (iy, ix)) / best if best > 0 else np.nan
    if best < min_correlation:
        return _fail(LOW_CORRELATION, best, amb, surf)
    if iy == 0 or ix == 0 or iy == rho.shape[0] - 1 or ix == rho.shape[1] - 1:
        return _fail(PEAK_AT_BORDER, best, amb, surf)
    nb = rho[iy - 1:iy + 2, ix - 1:ix + 2]
    if not np.isfinite(nb).all():
        return _fail(NODATA, best, amb, surf)
    if amb > max_ambiguity:
        return _fail(AMBIGUOUS, best, amb, surf)
    dx = _subpixel(nb[1, 0], nb[1, 1], nb[1, 2], subpixel)
    dy = _subpixel(nb[0, 1], nb[1, 1], nb[2, 1], subpixel)
    # template centre pixel lands on search pixel (r0 + iy + h, c0 + ix + h)
    xy = from_centre([c0 + ix + h + dx, r0 + iy + h + dy]) + frac
    return NCCResult(xy, best, float(amb), OK, surf)


def as_point_pairs(ref_xy, approx_xy):
    """``ref_xy`` and ``approx_xy`` as finite float64 (N, 2) arrays of equal shape, or InputError."""
    P = as_points(ref_xy, name="ref_xy")
    Q = as_points(approx_xy, name="approx_xy")
    if P.shape != Q.shape:
        raise InputError(f"ref_xy and approx_xy must have the same shape; got {P.shape} and {Q.shape}")
    if not (np.isfinite(P).all() and np.isfinite(Q).all()):
        raise InputError("ref_xy and approx_xy must be finite")
    return P, Q
