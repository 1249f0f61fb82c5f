"""Where a rectified image shows a signal above its noise: the texture rule of dense matching.

A uniform area (water, a saturated roof, fresh snow, a shadow without detail) shows only the sensor's noise. SGM
(Hirschmüller 2008) still gives it disparities: its paths carry the costs of the textured surroundings into it,
the noise decides between near-equal costs, and the left-right check passes whatever both directions settle on
alike — islands of consistent, wrong heights. A fixed threshold on the grey values' local spread does not tell
noise from texture: the noise of an 8-bit stretch depends on the sensor and the stretch.

:func:`noise_sigma` estimates the image's noise (Immerkær 1996: the image convolved with the difference of two
Laplacians ``N = [[1, -2, 1], [-2, 4, -2], [1, -2, 1]]``, which cancels any surface up to second order and
multiplies white noise of standard deviation ``σ`` by ``‖N‖ = 6``; the median of ``|I * N|`` over the valid
pixels is ``0.6745 · 6 σ``, robust to the edges of the texture, which a mean is not). :func:`signal_mask` keeps
a pixel where the grey values' standard deviation ``s`` over its neighbourhood shows a
signal of at least ``snr`` times the noise beyond the noise itself: ``s² ≥ (1 + snr²) σ²`` (noise and signal add
in variance), and at least ``floor`` levels. A peer's rules: s2p's local-variance ("texture") filter, OpenCV's
uniqueness ratio, CARS/Pandora's ambiguity (a flat cost curve), MicMac's correlation threshold.

:func:`matched_signal` applies the rule to both images of a pair, the left pixel and its match in the right one:
an area uniform in one image only (a specular reflection, a saturated or clipped roof, a cloud in one frame)
gives no height either. It also refuses the pixels within ``FLAT_REACH`` px of a signal-less area ``FLAT_WIDTH`` px
wide or more: their blocks take part of their cost from the uniform area, and SGM's paths carry the area's
arbitrary disparities a few pixels into its textured border (as a foreground object "fattens" across an
occlusion edge), where they pass the left-right check: thin lines of wrong heights along the area's edges.
"""
from __future__ import annotations

import cv2
import numpy as np

#: the window (pixels) of the texture test
TEXTURE_WINDOW = 7
#: Immerkær's (1996) noise kernel: the difference of two discrete Laplacians, ``‖N‖₂ = 6``
NOISE_KERNEL = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
#: the median of ``|x|`` for a standard normal ``x``
HALF_NORMAL_MEDIAN = 0.6745
#: the signal a pixel's neighbourhood must show, in units of the image's noise (module docstring)
SIGNAL_TO_NOISE = 1.0
#: pixels this close (px) to a signal-less one are refused too (module docstring)
FLAT_REACH = 6
#: signal-less places narrower than about this (px: specks, low-contrast spots) keep their border
FLAT_WIDTH = 31


def noise_sigma(img, valid) -> float:
    """The standard deviation of ``img``'s white noise (module docstring) over the ``valid`` pixels whose 3 x 3
    neighbourhood lies inside ``valid``; 0 when there are none."""
    inner = cv2.erode(np.asarray(valid, np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    if not inner.any():
        return 0.0
    r = cv2.filter2D(np.asarray(img, np.float32), cv2.CV_32F, NOISE_KERNEL, borderType=cv2.BORDER_REPLICATE)
    return float(np.median(np.abs(r[inner]))) / (6.0 * HALF_NORMAL_MEDIAN)


def texture(img8) -> np.ndarray:
    """The grey values' local standard deviation over ``TEXTURE_WINDOW`` x ``TEXTURE_WINDOW`` pixels."""
    g = img8.astype(np.float32)
    k = (TEXTURE_WINDOW, TEXTURE_WINDOW)
    m = cv2.blur(g, k)
    return np.sqrt(np.maximum(cv2.blur(g * g, k) - m * m, 0.0))


def signal_mask(img, valid, floor: float, snr: float = SIGNAL_TO_NOISE) -> np.ndarray:
    """Boolean mask of the pixels of ``img`` whose neighbourhood's grey-value standard deviation (:func:`texture`)
    shows a signal above the noise of ``img``'s ``valid`` pixels (``s² ≥ (1 + snr²) · noise_sigma²``) and is at
    least ``floor`` grey levels."""
    s = texture(img)
    sigma = noise_sigma(img, valid)
    return (s >= floor) & (s * s >= (1.0 + snr * snr) * sigma * sigma)


def _away_from_flat(mask, reach: int) -> np.ndarray:
    """``mask`` without the pixels within ``reach`` pixels (a square) of a signal-less area: the pixels outside
    ``mask`` within ``FLAT_WIDTH / 2`` of a place where most of a ``FLAT_WIDTH`` x ``FLAT_WIDTH`` window lies outside
    it (narrower spots, and the few pixels of a uniform area whose noise passes by chance, do not count)."""
    if reach <= 0:
        return mask
    k = (FLAT_WIDTH, FLAT_WIDTH)
    core = (cv2.blur((~mask).astype(np.float32), k, borderType=cv2.BORDER_REPLICATE) > 0.5).astype(np.uint8)
    area = cv2.dilate(core, np.ones(k, np.uint8)).astype(bool) & ~mask  # the area's own pixels out to its edge
    near = cv2.dilate(area.astype(np.uint8), np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)).astype(bool)
    return mask & ~near


def matched_signal(left, right, valid_left, valid_right, xr, floor: float, reach: int = FLAT_REACH) -> np.ndarray:
    """Boolean mask of the ``left`` pixels that show a signal (:func:`signal_mask`), lie ``reach`` px or more from
    a valid pixel without one, and whose match, the pixel ``xr`` (integer columns, ``left``'s shape) of the same
    row of ``right``, does too (module docstring)."""
    theirs = _away_from_flat(signal_mask(right, valid_right, floor) | ~np.asarray(valid_right, bool), reach)
    mine = _away_from_flat(signal_mask(left, valid_left, floor) | ~np.asarray(valid_left, bool), reach)
    return mine & np.take_along_axis(theirs, np.asarray(xr, np.intp), axis=1)

