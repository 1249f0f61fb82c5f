"""SURF's fine octave on the image upsampled 2x, strip by strip (bounded memory at any size).

SIFT doubles its input (Lowe 2004, sec. 3.3); fotogeo's SURF adds one octave (box filters
9-27, sampling step 1) on the image upsampled 2x (bilinear, pixel areas aligned) for blobs
finer than its usual octaves see (:func:`fotogeo.features.surf.surf`, ``upscale``). The
doubled image is never held whole: strips of about :data:`STRIP_PIXELS` image pixels, each
with :data:`MARGIN` image rows of context above and below, are upsampled, smoothed,
filtered and described one at a time. A keypoint belongs to the strip whose interior rows
hold its position, and the margin exceeds everything a keypoint there depends on (the
smoothing kernel, the largest fine filter with its 3x3x3 neighbourhood, the rotated
descriptor window of the fine octave's largest scale), so the keypoints do not depend on
the strip layout -- nor on the image's size, which decides only how many strips there are.

Coordinates: centre convention (pixel ``[r, c]`` centred at ``(c, r)``). Image row ``y`` is
row ``2 (y - a0) + 0.5`` of the doubled strip that starts at image row ``a0``
(the corner convention scales by 2); columns likewise with ``a0 = 0``.
"""
from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from . import hessian

#: Image pixels per strip (its doubled copy holds 4x; with the integral image and the
#: response maps about 100 MB at this size). Images of up to this size are one strip.
STRIP_PIXELS = 1 << 21

#: Image rows of context on each side of a strip's interior: more than the reach of a fine
#: keypoint's inputs (in doubled pixels: smoothing kernel 5, largest filter 27 plus one sample,
#: descriptor window 14.5 s at s < 3.2, i.e. 47), halved, plus the Newton offset.
MARGIN = 32


def strips(rows: int, cols: int) -> list[tuple[int, int, int, int]]:
    """``(r0, r1, a0, a1)`` per strip: interior rows ``[r0, r1)``, rows ``[a0, a1)`` upsampled."""
    step = max(4 * MARGIN, STRIP_PIXELS // max(cols, 1))
    return [(r0, min(rows, r0 + step), max(0, r0 - MARGIN), min(rows, r0 + step + MARGIN))
            for r0 in range(0, rows, step)]


def doubled(filled: np.ndarray, a0: int, a1: int, presmooth: float) -> np.ndarray:
    """Rows ``[a0, a1)`` of ``filled`` (float32, no nodata) upsampled 2x, smoothed by ``presmooth``."""
    strip = filled[a0:a1]
    up = cv2.resize(strip, (2 * strip.shape[1], 2 * strip.shape[0]), interpolation=cv2.INTER_LINEAR)
    if presmooth > 0:
        up = cv2.GaussianBlur(up, (0, 0), presmooth, borderType=cv2.BORDER_REFLECT_101)
    return up


def _to_strip(v, a0):
    return 2.0 * (v - a0) + 0.5


def _from_strip(v, a0):
    return (v - 0.5) / 2.0 + a0


def _interior(y, r0, r1):
    return (y >= r0 - 0.5) & (y < r1 - 0.5)


def detect(filled: np.ndarray, threshold: float, presmooth: float, gaussian: bool = False) -> dict:
    """Octave 0 of :func:`hessian.detect` (``gaussian`` as there) on the doubled image, in image
    coordinates: ``x``, ``y`` (centre convention), ``size`` (filter size / 2, image pixels) and the
    other fields as there."""
    parts = []
    for r0, r1, a0, a1 in strips(*filled.shape):
        kf = hessian.detect(doubled(filled, a0, a1, presmooth), threshold, 1, blur=presmooth,
                            gaussian=gaussian)
        y = _from_strip(kf["y"], a0)
        keep = _interior(y, r0, r1)
        kf = {k: v[keep] for k, v in kf.items()}
        kf["x"], kf["y"], kf["size"] = _from_strip(kf["x"], 0), y[keep], kf["size"] / 2
        parts.append(kf)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def describe(filled: np.ndarray, x, y, s, presmooth: float, fn: Callable, dim: int):
    """Orientation, descriptors and positions of fine keypoints at image ``(x, y)``, scale ``s``:
    ``fn(doubled strip, xs, ys, 2 s) -> (theta, descriptors, xs, ys)`` on each strip's keypoints
    (strip coordinates); the positions come back in image coordinates."""
    theta, desc = np.zeros(len(x)), np.zeros((len(x), dim), np.float32)
    rx, ry = np.array(x, float), np.array(y, float)
    for r0, r1, a0, a1 in strips(*filled.shape):
        sel = np.nonzero(_interior(y, r0, r1))[0]
        if len(sel):
            t, d, xs, ys = fn(doubled(filled, a0, a1, presmooth), _to_strip(x[sel], 0), _to_strip(y[sel], a0),
                              2.0 * s[sel])
            theta[sel], desc[sel], rx[sel], ry[sel] = t, d, _from_strip(xs, 0), _from_strip(ys, a0)
    return theta, desc, rx, ry
