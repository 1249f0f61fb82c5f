"""Interpolation of an image at sub-pixel positions, in numpy at full float64 precision.

``cv2.remap`` quantises sub-pixel positions to 1/32 pixel, which would cap least-squares
matching at about 0.01 px; these kernels do not. Bicubic is Keys (1981) cubic convolution
with a = −0.5 (third-order accurate).
"""
from __future__ import annotations

import numpy as np

_KEYS_A = -0.5  # Keys (1981) cubic convolution, third-order accurate


def _cubic_weights(t):
    """The four Keys weights of the samples at offsets −1, 0, 1, 2 for a fraction ``t``."""
    a = _KEYS_A
    s = t + 1.0
    w0 = ((a * s - 5 * a) * s + 8 * a) * s - 4 * a
    w1 = ((a + 2) * t - (a + 3)) * t * t + 1
    u = 1.0 - t
    w2 = ((a + 2) * u - (a + 3)) * u * u + 1
    return w0, w1, w2, 1.0 - w0 - w1 - w2


def sample(image: np.ndarray, xy_centre_x, xy_centre_y, method: str = "bilinear"):
    """Interpolate ``image`` at centre-convention coordinates (array indices ``x=col, y=row``).

    Returns ``(values, inside)``: values float64 (NaN where outside or touching nodata),
    ``inside`` True where the whole interpolation support lies in the image.
    """
    H, W = image.shape
    x = np.asarray(xy_centre_x, dtype=np.float64)
    y = np.asarray(xy_centre_y, dtype=np.float64)
    x0 = np.floor(x)
    y0 = np.floor(y)
    tx, ty = x - x0, y - y0
    lo, hi = (0, 1) if method == "bilinear" else (1, 2)
    ok = np.isfinite(x) & np.isfinite(y)
    inside = ok & (x0 - lo >= 0) & (y0 - lo >= 0) & (x0 + hi <= W - 1) & (y0 + hi <= H - 1)
    xi = np.where(inside, x0, lo).astype(np.intp)
    yi = np.where(inside, y0, lo).astype(np.intp)
    if method == "bilinear":
        v = ((1 - tx) * (1 - ty) * image[yi, xi] + tx * (1 - ty) * image[yi, xi + 1]
             + (1 - tx) * ty * image[yi + 1, xi] + tx * ty * image[yi + 1, xi + 1])
    else:
        wx = _cubic_weights(tx)
        wy = _cubic_weights(ty)
        v = 0.0
        for j in range(4):
            row = 0.0
            for i in range(4):
                row = row + wx[i] * image[yi + j - 1, xi + i - 1]
            v = v + wy[j] * row
    v = np.where(inside, v, np.nan)
    return v, inside
