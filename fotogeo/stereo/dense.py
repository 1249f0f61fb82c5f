"""Dense matching of a rectified pair: semi-global matching and its filters.

:func:`disparity` runs OpenCV's ``StereoSGBM`` (Hirschmüller 2008: a pixel-wise Birchfield–Tomasi cost on a
small block, aggregated along several image paths with penalties ``P1`` for disparity steps of one pixel and
``P2`` for larger ones; the sub-pixel disparity from a parabola through the costs of the best disparity and its
neighbours, in 1/16 px) twice — left → right and, on the mirrored images, right → left — and keeps a disparity
only where:

* both matchers found one (OpenCV's own filters: the best aggregated cost ``C(d*)`` is unique — every ``C(d)``
  with ``|d − d*| > 1`` reaches ``C(d*) · 100 / (100 − uniqueness)``; speckles — connected regions smaller than
  ``speckle_window`` pixels whose disparities vary by at most ``speckle_range`` — removed). The ratio is
  ``UNIQUENESS``, stricter than OpenCV's suggested 5–15: on a raised surface narrower than its disparity step to
  the ground around it (a small roof), SGM's paths carry the ground's disparity and the smoothness penalties onto
  it, its aggregated costs have no clear minimum, and the one picked, between roof and ground, passes both
  matching directions and every check below; such a pixel must be a hole, not a height between the two;
* the two agree within ``lr_tolerance`` px (left–right consistency: ``|d_L(x) − d_R(x − d_L(x))| ≤ tol``);
* both the pixel and its match lie inside their source images (``valid`` masks, eroded by the block size: a
  block that reaches outside an image matches its border, not the scene);
* the pixels outside the images (beyond a frame's edge, outside the other image of the pair) do not take part:
  they are filled with independent noise in each image (:func:`_outside_as_noise`) before matching. Filled with one
  constant in both, they match each other perfectly at the disparity that lines up the two images' edges, and SGM's
  paths carry that disparity into the valid pixels along the edge, where it passes the left–right check (both
  directions see the same empty area): a band of consistent, wrong heights along the overlap's border;
* a pixel without a partner does not meet another without one (``partner``, :func:`_partner_fill`): where the
  two images' valid areas do not overlap at the surface's disparity (the rows both images reach at an oblique
  pair's top or bottom, ground only one of them sees), the left pixels whose partner lies outside the right image
  and the right pixels whose partner lies outside the left one match each other: real texture against real texture
  costs less than against noise, SGM's paths line the two areas up at one disparity (the range's end, or where
  their edges meet), the left–right check passes it (both directions see the same two areas) and it is tens of
  metres wrong. Given the disparity each left pixel is expected at (from the pair's sparse matches), each image's
  outside pixels are filled with the other image's valid pixels they would meet there instead of noise, blurred: a
  pixel without a partner then finds its own texture outside the other image, near its true disparity, and is
  refused as matched outside the image (the partner check below); a pixel with a partner still prefers it (the
  blurred copy costs more), so an expected disparity some pixels off costs no heights at the overlap's edge;
* the disparity lies inside the requested range ``[lo, hi]`` by at least ``RANGE_EDGE`` px (callers pad it): SGBM
  searches ``numDisparities`` (a multiple of 16) from ``minDisparity``, and where the true disparity lies beyond the
  range the cost's minimum is cut off at the range's end, a plausible disparity that the left–right check passes (both
  directions are cut off alike). A range from sparse matches or heights can miss a pixel's disparity; the pixel
  is then a hole, not a height at the range's end (as the coarse-to-fine band's ends in
  :mod:`fotogeo.stereo.pyramid`);
* the left pixel has texture: the grey values' standard deviation over its ``TEXTURE_WINDOW`` neighbourhood
  reaches ``min_texture`` levels (of the 8-bit stretch) and, given the images' ``noise``, a signal above it, as
  does its match in the right image (:func:`fotogeo.stereo.texture.textured`: an area uniform in one view only, a
  cloud or a reflection, is a hole too). SGM's paths carry costs from textured places into flat ones, where
  they would give a smooth, plausible and unmeasured surface or islands of wrong heights; there a hole is the
  honest answer.

**Sub-pixel error cancellation** (Shimizu & Okutomi 2005): the parabola through three costs is biased
towards whole disparities ("pixel-locking": the fractional parts of the disparities pile up at 0); the bias is
periodic in the true sub-pixel disparity and changes sign when that moves by half a pixel. With ``half_shift`` the
left image is also matched resampled a quarter pixel to the right and the right image a quarter pixel to the
left (bicubic, ``L'(x) = L(x + ¼)``, ``R'(x) = R(x − ¼)``: the disparity becomes ``d − ½``), and where that
disparity plus ½ agrees with the first within ``lr_tolerance`` the two are averaged: their biases, half a period
apart, cancel to first order. The second matching is checked against the first, not left–right again.

**Penalties scaled to the contrast.** SGBM's matching cost of a pixel grows with the grey-value gradients of
the images (its Birchfield–Tomasi cost is taken on the row derivative clipped to ``preFilterCap``), while the
penalties ``P1``, ``P2`` are constants: on images of strong local contrast the data term outweighs the
smoothness term and the disparities turn rough and fail the left–right check where the cost is ambiguous (steep
slopes, shadows). The penalties are OpenCV's suggested ``8·block²`` and ``32·block²`` times
``max(1, c / CONTRAST_REF)``, ``c`` the median clipped row gradient (3 x 3 Sobel, as SGBM's pre-filter) of the
left image's valid pixels: the ratio of smoothness to data term stays that of images of ``CONTRAST_REF``
(the gradient of the rendered test blocks the defaults were chosen on) and is never weaker than OpenCV's. A pair
matched in pieces (strips) takes one factor for all of them (:func:`penalty_scale`, over rows spread across its
left image): a piece's own would change the penalties from piece to piece with what the piece shows.

**Median filter** (as Pandora/CARS filter their disparity maps, CNES 2020–2024): each kept disparity becomes
the median of the kept disparities in its ``median`` x ``median`` neighbourhood (pixels without one ignored,
none added: a hole stays a hole). SGM's sub-pixel disparities scatter from pixel to pixel by a fraction of a
pixel with occasional larger errors; the median removes both without blurring a step of the surface by more
than the window's half width (a median preserves edges that a mean smears).

Disparities follow :mod:`fotogeo.stereo.rectify`: ``d = u_left − u_right`` (float32, NaN where none).
Grey values are stretched to 8 bits between the 0.5 and 99.5 percentiles of each image's valid pixels.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from .texture import TEXTURE_WINDOW, texture, textured  # noqa: F401  (TEXTURE_WINDOW, texture: re-exported)


def to_uint8(img, valid, bounds=None) -> np.ndarray:
    """``img`` stretched to 1..255 between the 0.5 and 99.5 percentiles of its ``valid`` pixels (or ``bounds``
    ``(low, high)``), 0 outside."""
    img = np.asarray(img, np.float32)
    v = img[valid]
    if v.size == 0:
        return np.zeros(img.shape, np.uint8)
    lo, hi = np.percentile(v, [0.5, 99.5]) if bounds is None else bounds
    out = np.clip(1 + 254 * (img - lo) / max(float(hi - lo), 1e-6), 1, 255)
    out[~valid] = 0
    return out.astype(np.uint8)


#: SGBM's pre-filter clips the row derivative to this (``preFilterCap``)
PREFILTER_CAP = 63
#: the median clipped row gradient (grey levels, 3 x 3 Sobel of the 8-bit stretch) at which OpenCV's suggested
#: penalties hold (module docstring)
CONTRAST_REF = 32.0


def _gradients(img8, valid) -> np.ndarray:
    """``|∂x|`` (3 x 3 Sobel, clipped at ``PREFILTER_CAP``) at the ``valid`` pixels of ``img8``."""
    return np.minimum(np.abs(cv2.Sobel(img8, cv2.CV_32F, 1, 0, ksize=3))[valid], PREFILTER_CAP)


def contrast(img8, valid) -> float:
    """The median of ``|∂x|`` (3 x 3 Sobel, clipped at ``PREFILTER_CAP``) over the ``valid`` pixels of ``img8``."""
    if not valid.any():
        return CONTRAST_REF
    return float(np.median(_gradients(img8, valid)))


def _eroded(valid, block: int) -> np.ndarray:
    """``valid`` without the pixels whose matching block reaches outside it."""
    k = np.ones((block + 2, block + 2), np.uint8)
    return cv2.erode(np.asarray(valid).astype(np.uint8), k).astype(bool)


def penalty_scale(lefts, valids, block: int = 5) -> float:
    """The penalties' factor ``max(1, c / CONTRAST_REF)`` (module docstring) of one pair, ``c`` the median clipped
    row gradient over pieces of its rectified left image (``lefts``, ``valids``: e.g. rows spread over it) stretched
    together to 8 bits: one factor for all the pair's strips, so that P1 and P2 do not change from strip to strip
    with the strips' contents."""
    valids = [_eroded(v, block) for v in valids]
    values = np.concatenate([np.asarray(g, np.float32)[v] for g, v in zip(lefts, valids)])
    if not values.size:
        return 1.0
    bounds = tuple(np.percentile(values, [0.5, 99.5]))
    grads = np.concatenate([_gradients(to_uint8(g, v, bounds), v) for g, v in zip(lefts, valids)])
    return max(1.0, float(np.median(grads)) / CONTRAST_REF)


#: OpenCV's ``uniquenessRatio`` (%) of :func:`disparity` (module docstring)
UNIQUENESS = 30


def _matcher(dmin: int, ndisp: int, block: int, uniqueness: int, speckle_window: int, speckle_range: int,
             scale: float = 1.0):
    return cv2.StereoSGBM_create(minDisparity=dmin, numDisparities=ndisp, blockSize=block,
                                 P1=int(round(8 * block * block * scale)), P2=int(round(32 * block * block * scale)),
                                 disp12MaxDiff=-1,
                                 uniquenessRatio=uniqueness, speckleWindowSize=speckle_window,
                                 speckleRange=speckle_range, preFilterCap=PREFILTER_CAP, mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)


#: disparities closer than this (px) to the searched range's ends are dropped (module docstring)
RANGE_EDGE = 1.0


def _sgbm(matcher, left, right, dmin: int, ndisp: int) -> np.ndarray:
    """Disparities of ``left`` (float32, NaN where none); both images padded on the left so that every column
    has its full disparity range."""
    pad = max(0, dmin + ndisp)
    lp = cv2.copyMakeBorder(left, 0, 0, pad, 0, cv2.BORDER_CONSTANT, value=0)
    rp = cv2.copyMakeBorder(right, 0, 0, pad, 0, cv2.BORDER_CONSTANT, value=0)
    d = matcher.compute(lp, rp)[:, pad:].astype(np.float32) / 16.0
    d[d < dmin] = np.nan
    return d


def disparity_range(lo: float, hi: float) -> tuple:
    """``(minDisparity, numDisparities)`` covering ``[lo, hi]`` px (``numDisparities`` a multiple of 16)."""
    dmin = int(math.floor(lo))
    n = int(math.ceil((math.ceil(hi) - dmin + 1) / 16.0)) * 16
    return dmin, max(16, n)


def _shifted(img8, t: float) -> np.ndarray:
    """``out(x) = img8(x + t)`` (bicubic, borders replicated)."""
    M = np.float32([[1, 0, -t], [0, 1, 0]])
    return cv2.warpAffine(img8, M, (img8.shape[1], img8.shape[0]), flags=cv2.INTER_CUBIC,
                          borderMode=cv2.BORDER_REPLICATE)


def _cancel_subpixel_error(m, L, R, dl, dmin: int, ndisp: int, tolerance: float) -> np.ndarray:
    """``dl`` averaged with the disparities of the pair shifted by half a pixel (module docstring)."""
    ds = _sgbm(m, _shifted(L, 0.25), _shifted(R, -0.25), dmin, ndisp) + 0.5
    with np.errstate(invalid="ignore"):
        both = np.isfinite(dl) & (np.abs(ds - dl) <= tolerance)
    return np.where(both, 0.5 * (dl + ds), dl)


#: rows of disparities median-filtered at once (bounds the filter's stack of ``median²`` shifted copies)
MEDIAN_ROWS = 128


def median_filter(d, size: int) -> np.ndarray:
    """``d`` (float32, NaN where none) with each finite value replaced by the median of the finite values in its
    ``size`` x ``size`` neighbourhood (the even count's two middle values averaged); NaN stays NaN."""
    if size <= 1:
        return d
    r = size // 2
    rows = d.shape[0]
    pad = np.pad(np.asarray(d, np.float32), r, constant_values=np.nan)
    out = np.array(d, np.float32, copy=True)
    for a in range(0, rows, MEDIAN_ROWS):
        b = min(rows, a + MEDIAN_ROWS)
        stack = np.stack([pad[a + i:b + i, j:j + d.shape[1]] for i in range(size) for j in range(size)])
        stack.sort(axis=0)  # NaN sorts last
        n = np.isfinite(stack).sum(axis=0)
        lo = np.take_along_axis(stack, np.maximum(n - 1, 0)[None] // 2, axis=0)[0]
        hi = np.take_along_axis(stack, (n // 2)[None], axis=0)[0]
        keep = np.isfinite(d[a:b])
        out[a:b][keep] = (0.5 * (lo + hi))[keep]
    return out


def _outside_as_noise(img8, valid, seed: int) -> np.ndarray:
    """``img8`` with its pixels outside ``valid`` set to uniform noise in 1..255 (``seed``: reproducible, and
    independent between the two images of a pair; module docstring)."""
    out = np.array(img8, copy=True)
    bad = ~np.asarray(valid, bool)
    out[bad] = np.random.default_rng(seed).integers(1, 256, int(bad.sum()), dtype=np.uint8)
    return out


def _matched_grey(img, valid, block: int, seed: int) -> np.ndarray:
    """The 8-bit image SGBM matches: ``img`` stretched over the pixels whose ``block`` lies inside ``valid``
    (:func:`to_uint8`), kept on all ``valid`` pixels, noise outside (:func:`_outside_as_noise`)."""
    inner = np.asarray(img, np.float32)[_eroded(valid, block)]
    bounds = tuple(np.percentile(inner, [0.5, 99.5])) if inner.size else None
    return _outside_as_noise(to_uint8(img, valid, bounds), valid, seed)


#: the outside pixels' fill (:func:`_partner_fill`) is blurred by a Gaussian of this sigma (px): a copy costs more
#: than a true partner (which then wins where the expected disparity errs and both lie in the range) and still
#: far less than texture it does not show
PARTNER_BLUR = 2.0


def right_expected(partner) -> np.ndarray:
    """The disparity each right pixel is expected at, from the left pixels' ``partner`` (float32 ``(rows, cols)``,
    NaN: unknown): the right pixel ``x`` meets the left pixel ``x + g(x + g(x))`` (one step of the fixed point
    ``u = x + g(u)``, ``x + g(x)`` rounded); NaN where that left pixel lies outside the image or has none. What
    the right image's own matching (images mirrored) is given as its ``partner``."""
    g = np.asarray(partner, np.float32)
    cols = g.shape[1]
    x = np.arange(cols, dtype=np.float32)[None, :]
    first = np.rint(x + np.nan_to_num(g, nan=-1e6))
    inside = (first >= 0) & (first < cols)
    gx = np.take_along_axis(g, np.where(inside, first, 0).astype(np.intp), axis=1)
    return np.where(inside, gx, np.nan).astype(np.float32)


def _partner_fill(L, R, valid_left, valid_right, partner) -> tuple:
    """``(L', R')``: the 8-bit images with each one's pixels outside its ``valid`` area set to the grey of the
    other image's valid pixel they meet at the expected disparity ``partner`` (of the left pixels, NaN: none;
    module docstring): a left pixel ``u`` meets the right pixel ``u − g(u)``, a right pixel ``x`` the left pixel
    ``x + g(x + g(x))`` (:func:`right_expected`), blurred (``PARTNER_BLUR``); the others keep their noise. ``L'``
    serves the right-to-left matching, ``R'`` the left-to-right one."""
    rows, cols = L.shape
    g = np.asarray(partner, np.float32)
    x = np.broadcast_to(np.arange(cols, dtype=np.float32)[None, :], (rows, cols))
    y = np.broadcast_to(np.arange(rows, dtype=np.float32)[:, None], (rows, cols))

    def read(img, valid, at):
        at = np.where(np.isfinite(at), at, -1.0).astype(np.float32)
        seen = cv2.remap(np.asarray(valid, np.uint8), at, y.astype(np.float32), cv2.INTER_NEAREST,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=0).astype(bool)
        return cv2.remap(img, at, y.astype(np.float32), cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT), seen

    rl, sl = read(R, valid_right, x - g)
    lr, sr = read(L, valid_left, x + right_expected(g))
    rl, lr = (cv2.GaussianBlur(c, (0, 0), PARTNER_BLUR) for c in (rl, lr))
    return np.where(~valid_left & sl, rl, L), np.where(~valid_right & sr, lr, R)


def disparity(left, right, valid_left, valid_right, lo: float, hi: float, *, block: int = 5,
              uniqueness: int = UNIQUENESS, speckle_window: int = 100, speckle_range: int = 2,
              lr_tolerance: float = 1.0, min_texture: float = 2.0, half_shift: bool = True,
              median: int = 5, scale_penalties: bool = True, penalty: float | None = None,
              partner=None, noise: tuple | None = None) -> np.ndarray:
    """Filtered disparities ``(rows, cols)`` of the rectified ``left`` image within ``[lo, hi]`` px (module
    docstring; ``half_shift``: the sub-pixel error cancellation; ``median``: the median filter's window, 1 =
    none; ``scale_penalties``: P1, P2 scaled to the contrast — the pair's factor ``penalty``
    (:func:`penalty_scale`) when given, else this image's; ``partner``: the disparity each left pixel is expected
    at (``left``'s shape, NaN where unknown), the outside pixels filled from the other image there
    (:func:`_partner_fill`) instead of noise only; ``noise``: the two images' noise σ ``(left, right)`` in their
    grey units (:func:`fotogeo.stereo.texture.noise_sigma`, once per image), None: the texture test in levels of
    the stretch only)."""
    L, R = _matched_grey(left, valid_left, block, 1), _matched_grey(right, valid_right, block, 2)
    Lf, Rf = (L, R) if partner is None else _partner_fill(L, R, np.asarray(valid_left, bool),
                                                          np.asarray(valid_right, bool), partner)
    has_texture = textured(left, L, valid_left, min_texture, None if noise is None else noise[0])
    theirs = None if noise is None else textured(right, R, valid_right, 0.0, noise[1])
    valid_left = _eroded(valid_left, block)  # no match whose block reaches outside an image
    valid_right = _eroded(valid_right, block)
    dmin, ndisp = disparity_range(lo, hi)
    if not scale_penalties:
        scale = 1.0
    else:
        scale = penalty if penalty is not None else max(1.0, contrast(L, valid_left) / CONTRAST_REF)
    m = _matcher(dmin, ndisp, block, uniqueness, speckle_window, speckle_range, scale)
    dl = _sgbm(m, L, Rf, dmin, ndisp)
    dr = _sgbm(m, R[:, ::-1].copy(), Lf[:, ::-1].copy(), dmin, ndisp)[:, ::-1]
    rows, cols = dl.shape
    x = np.arange(cols, dtype=np.float32)[None, :]
    with np.errstate(invalid="ignore"):
        xr = np.rint(x - dl)
        inside = (xr >= 0) & (xr < cols)
        xi = np.where(inside, xr, 0).astype(np.intp)
        back = np.take_along_axis(dr, xi, axis=1)
        vr = np.take_along_axis(valid_right, xi, axis=1)
        ok = inside & (np.abs(back - dl) <= lr_tolerance) & valid_left & vr
        ok &= has_texture if theirs is None else has_texture & np.take_along_axis(theirs, xi, axis=1)
    with np.errstate(invalid="ignore"):
        ok &= (dl >= lo + RANGE_EDGE) & (dl <= hi - RANGE_EDGE)  # not cut off at the range's ends
    dl[~ok] = np.nan
    if half_shift:
        dl = _cancel_subpixel_error(m, L, Rf, dl, dmin, ndisp, lr_tolerance)
    return median_filter(dl, median)
