"""The texture rule of dense matching: a disparity only where the left image shows a signal above its noise.

A uniform area (water, a bare grey field, a cloud, a patch uniform in one view) shows only the sensor's noise.
SGM (Hirschmüller 2008) still gives it disparities: its paths carry the costs of the textured surroundings into
it, the noise decides between near-equal costs, and the left-right check passes whatever both directions settle
on alike — islands of consistent, wrong heights. A threshold in grey levels of the 8-bit stretch
(``min_texture``) does not tell noise from texture: the noise in those levels depends on the sensor and on the
stretch. :func:`textured` keeps a pixel where the grey values' standard deviation over its ``TEXTURE_WINDOW``
neighbourhood (:func:`texture`) reaches ``SIGNAL_TO_NOISE`` times the image's noise ``σ`` (and ``min_texture``
levels of the stretch, as before); :func:`fotogeo.stereo.dense.disparity` asks it of the left pixel and of its
match in the right image (an area uniform in one view only). The standard deviation leaves out the pixels within
``EDGE_REACH`` of an image's edge (:func:`clean_texture`): the resampling mixed the black beyond it into them.

**The noise, once per image** (:func:`noise_sigma`; Tai & Yang 2008, "Fast and reliable image-noise estimation
using a hybrid approach"): the pixels whose Sobel gradient ``|Gx| + |Gy|`` lies below its ``LOW_GRADIENT``
percentile (the homogeneous ones), and on them Immerkær's (1996) estimate: the image convolved with
``N = [[1, -2, 1], [-2, 4, -2], [1, -2, 1]]`` (the difference of two discrete Laplacians: it cancels any surface
up to second order and turns white noise of ``σ`` into noise of ``6σ``),
``σ = √(π/2) · mean|I * N| / 6``. Selecting by gradient does not bias the estimate on noise: ``N`` is even in
both axes and each Sobel kernel odd in one, so their responses to white noise are uncorrelated (independent if
Gaussian). It leaves out the texture's edges, which pass ``N`` and, counted, raise the estimate with the
texture's share (an estimate over every pixel of one piece gave 6.9 for a true 1.2 where 60 % of it was busy
texture, and removed real low-contrast ground beside it). The estimate is made once per image, over pieces
spread across it (:func:`fotogeo.tools.dsm.frames.pair_noise`; an RPC pair's
:class:`~fotogeo.tools.dsm.rpc_pairs.RpcPairMatch`), not per matched piece: a piece that is all
uniform area or all busy texture does not set its own threshold. It is made on the source image's pixels
(:meth:`fotogeo.tools.dsm.inputs.SourceImage.noise`), where the noise is white: resampling to the rectified
geometry only lowers it, and a rectified image smaller than its source folds the scene's finest texture into the
high frequencies the estimate takes for noise.
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


def _responses(img, valid) -> tuple:
    """``(|I * N|, |Gx| + |Gy|)`` at the ``valid`` pixels of ``img`` whose 3 x 3 neighbourhood lies in ``valid``."""
    inner = cv2.erode(np.asarray(valid, np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    g = np.asarray(img, np.float32)
    n = np.abs(cv2.filter2D(g, cv2.CV_32F, NOISE_KERNEL, borderType=cv2.BORDER_REPLICATE))
    grad = np.abs(cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)) + np.abs(cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3))
    return n[inner], grad[inner]


def noise_sigma(imgs, valids, low_gradient: float | None = None) -> float:
    """The standard deviation of the white noise of an image given as pieces ``imgs`` (float, any grey units)
    with their ``valids`` masks (module docstring: Immerkær's estimate on the pixels below the ``low_gradient``
    percentile of the Sobel gradient, default ``LOW_GRADIENT``); 0 without pixels."""
    parts = [_responses(g, v) for g, v in zip(imgs, valids)]
    n = np.concatenate([p[0] for p in parts]) if parts else np.zeros(0)
    grad = np.concatenate([p[1] for p in parts]) if parts else np.zeros(0)
    if not n.size:
        return 0.0
    low = grad <= np.percentile(grad, LOW_GRADIENT if low_gradient is None else low_gradient)
    return float(math.sqrt(math.pi / 2) * np.mean(n[low]) / 6.0)


#: pixels this close (px) to an image's invalid ones are left out of the texture: a resampling kernel (bicubic:
#: 2 px) mixes the grey beyond the image's edge (0) into them, an edge that is not the scene's texture
EDGE_REACH = 2


def clean_texture(img, valid) -> np.ndarray:
    """:func:`texture` of ``img`` over its pixels ``EDGE_REACH`` px or more inside ``valid`` only (a masked
    standard deviation); 0 where fewer than half the window's pixels are such."""
    core = cv2.erode(np.asarray(valid, np.uint8), np.ones((2 * EDGE_REACH + 1,) * 2, np.uint8)).astype(np.float32)
    g = np.asarray(img, np.float32) * core
    k = (TEXTURE_WINDOW, TEXTURE_WINDOW)
    n = cv2.blur(core, k)
    m = cv2.blur(g, k) / np.maximum(n, 1e-6)
    s = np.sqrt(np.maximum(cv2.blur(g * g, k) / np.maximum(n, 1e-6) - m * m, 0.0))
    return np.where(n >= 0.5, s, 0.0)


def textured(left, left8, valid, min_texture: float, noise: float | None = None,
             snr: float | None = None) -> np.ndarray:
    """Boolean mask of the pixels with texture: the local standard deviation (:func:`texture`) of the 8-bit
    stretch ``left8`` reaches ``min_texture`` levels and, with ``noise`` (the image's σ in ``left``'s grey units,
    :func:`noise_sigma`), that of ``left`` away from the edges of its ``valid`` pixels (:func:`clean_texture`)
    reaches ``snr`` (default ``SIGNAL_TO_NOISE``) times it."""
    ok = texture(left8) >= min_texture if min_texture > 0 else np.ones(np.shape(left), bool)
    if noise:
        ok &= clean_texture(left, valid) >= (SIGNAL_TO_NOISE if snr is None else snr) * noise
    return ok
