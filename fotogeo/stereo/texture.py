"""The texture rule of dense matching: a disparity only where the left image shows a signal above its noise.

A uniform area (water, a bare grey field, a cloud, a patch uniform in one view) shows only the sensor's noise.
SGM (Hirschmüller 2008) still gives it disparities: its paths carry the costs of the textured surroundings into
it, the noise decides between near-equal costs, and the left-right check passes whatever both directions settle
on alike — islands of consistent, wrong heights. A threshold in grey levels of the 8-bit stretch
(``min_texture``) does not tell noise from texture: the noise in those levels depends on the sensor and on the
stretch. :func:`textured` keeps a pixel where the grey values' standard deviation over its ``TEXTURE_WINDOW``
neighbourhood (:func:`texture`) reaches ``SIGNAL_TO_NOISE`` times the image's noise ``σ(I)`` at the
neighbourhood's mean grey ``I`` (and ``min_texture``
levels of the stretch, as before); :func:`fotogeo.stereo.dense.disparity` asks it of the left pixel and of its
match in the right image (an area uniform in one view only). The standard deviation leaves out the pixels within
``EDGE_REACH`` of an image's edge (:func:`clean_texture`): the resampling mixed the black beyond it into them.

**The noise, once per image** (:func:`noise_sigma`; Tai & Yang 2008, "Fast and reliable image-noise estimation
using a hybrid approach"): the pixels whose Sobel gradient ``|Gx| + |Gy|`` lies below its ``LOW_GRADIENT``
percentile (the homogeneous ones), and on them Immerkær's (1996) estimate: the image convolved with
``N = [[1, -2, 1], [-2, 4, -2], [1, -2, 1]]`` (the difference of two discrete Laplacians: it cancels any surface
up to second order and turns white noise of ``σ`` into noise of ``6σ``),
``σ = √(π/2) · mean|I * N| / 6``. The pixels at the image's lowest or highest grey and those of a constant
3 x 3 neighbourhood are not candidates: clipped (a cloud, snow, a white roof at 255) they have neither gradient
nor noise, and made σ 0 (the NGI frame 0182 with its top 5 % rows at 255: 1.729 → 0.005). The noise grows with
the brightness (photon noise): one σ per image, set by the bright pixels, removed a dark shadow's correct
matches; the same estimate is made in ``NOISE_BINS`` brightness bins and ``σ²(I) = a + b·I`` fitted to them
(Foi et al. 2008, :class:`NoiseLevel`). Selecting by gradient does not bias the estimate on noise: ``N`` is even in
both axes and each Sobel kernel odd in one, so their responses to white noise are uncorrelated (independent if
Gaussian). It leaves out the texture's edges, which pass ``N`` and, counted, raise the estimate with the
texture's share (an estimate over every pixel of one piece gave 6.9 for a true 1.2 where 60 % of it was busy
texture, and removed real low-contrast ground beside it). The estimate is made once per image, over pieces
spread across it (:func:`fotogeo.tools.dsm.frames.pair_noise`; an RPC pair's
:class:`~fotogeo.tools.dsm.rpc_pairs.RpcPairMatch`), not per matched piece: a piece that is all
uniform area or all busy texture does not set its own threshold. It is made on the source image's pixels
(:meth:`fotogeo.tools.dsm.inputs.SourceImage.noise`), where the noise is white: resampling to the rectified
geometry only lowers it, and a rectified image smaller than its source folds the scene's finest texture into the
high frequencies the estimate takes for noise. (Where a rectification magnifies, the resampling lowers the
noise's spread over the window further and the threshold is too high for real faint texture: measured, not
mended — the frame pipeline's rectification scale is at most 1, an RPC pair's left tile is its source's pixels.)
"""
from __future__ import annotations

import math

import cv2
import numpy as np

#: the window (pixels) of the texture test
TEXTURE_WINDOW = 7
#: Immerkær's (1996) noise kernel: the difference of two discrete Laplacians; white noise of σ → 6σ
NOISE_KERNEL = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
#: the percentile of the Sobel gradient below which pixels count as homogeneous (Tai & Yang 2008 take the 90th:
#: all but the edges; the 10th keeps the estimate off fine real texture — the eBee snow frames: 0.43 grey levels,
#: 0.59 at the 50th; rendered frames with noise 2: 1.84, 1.98)
LOW_GRADIENT = 10.0
#: the local standard deviation a pixel needs, in units of its image's noise: the rendered lake's pixels (noise
#: only, resampled) reach about 1.1 σ; 1.1 and 1.2 left no cell of it more than 5 m off, the eBee snow pair kept
#: all its pixels (``benchmarks/dsm_uniform_bench.py``)
SIGNAL_TO_NOISE = 1.3


def texture(img) -> np.ndarray:
    """The grey values' local standard deviation over ``TEXTURE_WINDOW`` x ``TEXTURE_WINDOW`` pixels."""
    g = np.asarray(img, np.float32)
    k = (TEXTURE_WINDOW, TEXTURE_WINDOW)
    m = cv2.blur(g, k)
    return np.sqrt(np.maximum(cv2.blur(g * g, k) - m * m, 0.0))


#: the brightness bins of the noise model (equal counts of homogeneous pixels; Foi et al. 2008 fit their
#: level sets the same way)
NOISE_BINS = 8


class NoiseLevel(float):
    """An image's noise: as a float its σ over all its homogeneous pixels (grey units); :meth:`at` its σ at a
    brightness, ``σ(I) = √(a + b·I)`` (Foi et al. 2008, "Practical Poissonian-Gaussian noise modeling": the
    read-out noise ``a`` and the photon noise ``b·I``, ``a, b ≥ 0``). A float alone is a noise that does not
    depend on the brightness."""

    def __new__(cls, sigma: float, a: float | None = None, b: float = 0.0):
        self = super().__new__(cls, sigma)
        self.a, self.b = (float(sigma) ** 2 if a is None else float(a)), float(b)
        return self

    def __reduce__(self):
        return NoiseLevel, (float(self), self.a, self.b)

    def at(self, brightness) -> np.ndarray:
        """σ at the grey values ``brightness`` (an array)."""
        return np.sqrt(np.maximum(self.a + self.b * np.maximum(np.asarray(brightness, np.float32), 0.0), 0.0))


def noise_at(noise, brightness) -> np.ndarray:
    """σ of ``noise`` (a :class:`NoiseLevel` or a float: the same σ everywhere) at the grey values ``brightness``."""
    if isinstance(noise, NoiseLevel):
        return noise.at(brightness)
    return np.full(np.shape(brightness), float(noise), np.float32)


def _responses(img, valid, lo: float, hi: float) -> tuple:
    """``(|I * N|, |Gx| + |Gy|, local mean)`` at the ``valid`` pixels of ``img`` whose 3 x 3 neighbourhood lies
    in ``valid``, is not constant and holds neither ``lo`` nor ``hi`` (the image's extremes: a sensor's or a
    stretch's clipping — a cloud, snow, a white roof at 255 — has neither gradient nor noise, and would make the
    homogeneous pixels' estimate 0)."""
    g = np.asarray(img, np.float32)
    box = np.ones((3, 3), np.uint8)
    top, bottom = cv2.dilate(g, box), cv2.erode(g, box)
    inner = cv2.erode(np.asarray(valid, np.uint8), box).astype(bool) & (top > bottom) & (top < hi) & (bottom > lo)
    n = np.abs(cv2.filter2D(g, cv2.CV_32F, NOISE_KERNEL, borderType=cv2.BORDER_REPLICATE))
    grad = np.abs(cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)) + np.abs(cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3))
    return n[inner], grad[inner], cv2.blur(g, (3, 3))[inner]


def _immerkaer(n) -> float:
    return float(math.sqrt(math.pi / 2) * np.mean(n) / 6.0)


def _fit_level(sigmas, means) -> tuple:
    """``(a, b)`` of ``σ² = a + b·I`` (:class:`NoiseLevel`) by least squares with ``a, b ≥ 0``, refit once without
    the bins more than 3 robust deviations off (a bin of fine real texture everywhere: its σ too high)."""
    from scipy.optimize import nnls
    A, y = np.column_stack([np.ones_like(means), means]), np.asarray(sigmas) ** 2
    ab = nnls(A, y)[0]
    r = y - A @ ab
    keep = np.abs(r - np.median(r)) <= 3 * 1.4826 * np.median(np.abs(r - np.median(r))) + 1e-12
    if keep.sum() >= 2 and not keep.all():
        ab = nnls(A[keep], y[keep])[0]
    return float(ab[0]), float(ab[1])


def noise_sigma(imgs, valids, low_gradient: float | None = None) -> NoiseLevel:
    """The noise of an image given as pieces ``imgs`` (float, any grey units) with their ``valids`` masks, a
    :class:`NoiseLevel` (0 without pixels). Its σ: Immerkær's estimate on the pixels below the ``low_gradient``
    percentile (default ``LOW_GRADIENT``) of the Sobel gradient (module docstring); its model ``σ²(I) = a + b·I``:
    the same estimate in ``NOISE_BINS`` bins of the pixels' brightness (the gradient's percentile taken in each:
    the photon noise raises the bright pixels' gradients), fitted (:func:`_fit_level`)."""
    q = LOW_GRADIENT if low_gradient is None else low_gradient
    vals = [np.asarray(g, np.float32)[np.asarray(v, bool)] for g, v in zip(imgs, valids)]
    vals = [v for v in vals if v.size]
    if not vals:
        return NoiseLevel(0.0)
    lo, hi = min(float(v.min()) for v in vals), max(float(v.max()) for v in vals)
    parts = [_responses(g, v, lo, hi) for g, v in zip(imgs, valids)]
    n, grad, mean = (np.concatenate([p[i] for p in parts]) for i in range(3))
    if not n.size:
        return NoiseLevel(0.0)
    sigma = _immerkaer(n[grad <= np.percentile(grad, q)])
    edges = np.unique(np.percentile(mean, np.linspace(0, 100, NOISE_BINS + 1)))
    sigmas, means = [], []
    for b0, b1 in zip(edges[:-1], edges[1:]):
        sel = (mean >= b0) & (mean <= b1)
        if sel.sum() < 200:
            continue
        low = sel & (grad <= np.percentile(grad[sel], q))
        sigmas.append(_immerkaer(n[low]))
        means.append(float(np.median(mean[low])))
    if len(sigmas) < 2:
        return NoiseLevel(sigma)
    return NoiseLevel(sigma, *_fit_level(np.array(sigmas), np.array(means)))


#: pixels this close (px) to an image's invalid ones are left out of the texture: a resampling kernel (bicubic:
#: 2 px) mixes the grey beyond the image's edge (0) into them, an edge that is not the scene's texture
EDGE_REACH = 2


def clean_texture(img, valid, with_mean: bool = False):
    """:func:`texture` of ``img`` over its pixels ``EDGE_REACH`` px or more inside ``valid`` only (a masked
    standard deviation); 0 where fewer than half the window's pixels are such. ``with_mean``: ``(std, mean)``,
    the mean over the same pixels."""
    core = cv2.erode(np.asarray(valid, np.uint8), np.ones((2 * EDGE_REACH + 1,) * 2, np.uint8)).astype(np.float32)
    g = np.asarray(img, np.float32) * core
    k = (TEXTURE_WINDOW, TEXTURE_WINDOW)
    n = cv2.blur(core, k)
    m = cv2.blur(g, k) / np.maximum(n, 1e-6)
    s = np.sqrt(np.maximum(cv2.blur(g * g, k) / np.maximum(n, 1e-6) - m * m, 0.0))
    s = np.where(n >= 0.5, s, 0.0)
    return (s, m) if with_mean else s


def textured(left, left8, valid, min_texture: float, noise=None,
             snr: float | None = None) -> np.ndarray:
    """Boolean mask of the pixels with texture: the local standard deviation (:func:`texture`) of the 8-bit
    stretch ``left8`` reaches ``min_texture`` levels and, with ``noise`` (the image's :class:`NoiseLevel` or σ in
    ``left``'s grey units, :func:`noise_sigma`), that of ``left`` away from the edges of its ``valid`` pixels
    (:func:`clean_texture`) reaches ``snr`` (default ``SIGNAL_TO_NOISE``) times the noise at the window's mean."""
    ok = texture(left8) >= min_texture if min_texture > 0 else np.ones(np.shape(left), bool)
    if noise:
        spread, mean = clean_texture(left, valid, with_mean=True)
        ok &= spread >= (SIGNAL_TO_NOISE if snr is None else snr) * noise_at(noise, mean)
    return ok
