"""SURF orientation and descriptor from Haar wavelet responses on an integral image.

All positions are in the centre convention (pixel ``[r, c]`` centred at ``(c, r)``), the
integral image is the padded one of :func:`fotogeo.features.hessian.integral`. Every
keypoint is processed at once (in chunks), by gathering integral-image corners with
fancy indexing; nothing loops over pixels or samples.

Haar wavelets of side ``h`` (even) centred on a sample point (corner coordinates
``X, Y``), with the box's left/top edge at ``x0 = floor(X - h/2 + 1/2)``, ``y0 = floor(Y - h/2 + 1/2)``::

    dx = box(right half) - box(left half),     dy = box(bottom half) - box(top half)

(rows go down, so ``dy > 0`` means brighter below). Angles are measured from +x (columns)
towards +y (rows), i.e. clockwise on screen, like OpenCV's ``KeyPoint.angle``.

Orientation (after Bay et al. 2008, sec. 4.1): gradients in the disc of radius 6s, weighted
by a Gaussian of sigma 2s; a window of :data:`ORI_WINDOW` degrees slides around the circle
(1-degree steps, on a 360-bin histogram of the gradient angles); the longest summed vector
(sum dx, sum dy) gives the angle theta. Unlike Bay et al.'s Haar wavelets of side 4s at the
109 integer points ``(i, j) s``, the gradients are central differences (baseline s, like a
Haar wavelet of side 2s) of bilinear samples of the keypoint's octave image on a grid of
spacing s/2 (437 samples): axis-aligned 4s boxes on an axis-aligned grid see a 45-degree
rotated patch differently, and the angle error of corresponding keypoints (NGI orthophoto,
rotation 45 deg x scale 1.3) had a median of 4.0 deg, 18 % beyond 10 deg; now 1.8 deg and
5 %. A window of 90 instead of 60 degrees averages more of the gradients (4.0 -> 3.8 deg
alone, 2.0 -> 1.8 with the dense samples); Gaussian sigma 1.5s or 2.5s, radius 5s or a
spacing of 2s/3 did worse. Same cost (0.37 s vs 0.39 s for 9832 keypoints at 4 Mpx).

Descriptor (sec. 4.2): a 20s square rotated by theta, 20 x 20 sample points at spacing s
(offsets ``u, v = -9.5 .. 9.5``), position ``(x, y) + s R(theta) (u, v)``; Haar side 2s;
responses rotated into the keypoint frame ``du = dx cos + dy sin``, ``dv = -dx sin + dy cos``
and weighted by a Gaussian of sigma 3.3s; per 4x4 sub-region of 5x5 samples the vector
``(sum du, sum dv, sum |du|, sum |dv|)`` -> 64 values, normalised to unit length. The
extended variant splits ``sum du`` and ``sum |du|`` by the sign of ``dv`` and vice versa
(128 values).
"""
from __future__ import annotations

import cv2
import numpy as np

#: Haar wavelets of the descriptor at exact (bilinear) positions rather than rounded ones.
#: Measured (benchmarks/surf_bench.py cases, rotations and scales): matching score +0.005,
#: ratio-test score +0.015 for +0.12 s per 1000 keypoints (4 gathers instead of 1); with
#: the orientation of this module +0.0017 (0.7793 -> 0.7810 over 3 images x 14 rotations
#: and scales). A descriptor from bilinear samples of the octave image on the rotated grid
#: (spacing s/2, central differences smoothed [1 2 1] across) gave 0.7777 for 10 % more
#: time. So neither is used.
SUBPIXEL = False

#: Keypoints per chunk (bounds the (chunk, 400, 8) gathers to ~25 MB).
CHUNK = 1024

#: Orientation: samples on a grid of spacing s/2 (units of s) out to the disc of radius 6s
#: plus one sample for the central differences, Gaussian weights of sigma 2s, window 90 deg.
ORI_WINDOW = 90
_r = np.arange(-13, 14) * 0.5
ORI_GRID = np.broadcast_to(_r, (27, 27))                 # [row, col] -> u = col offset
_U, _V = np.meshgrid(_r[1:-1], _r[1:-1], indexing="xy")
ORI_DISC = (_U ** 2 + _V ** 2) < 36                     # 437 gradient samples
ORI_W = np.exp(-(_U[ORI_DISC] ** 2 + _V[ORI_DISC] ** 2) / (2 * 2.0 ** 2)).astype(np.float32)

_g = np.arange(20) - 9.5
DESC_V, DESC_U = np.meshgrid(_g, _g, indexing="ij")   # row index = v (sub-rows), col = u
DESC_U = DESC_U.ravel()
DESC_V = DESC_V.ravel()
DESC_W = np.exp(-(DESC_U ** 2 + DESC_V ** 2) / (2 * 3.3 ** 2))
#: (400, 16) 0/1 matrix summing the 20 x 20 samples into 4 x 4 sub-regions (row-major)
DESC_SUB = np.zeros((400, 16), np.float32)
DESC_SUB[np.arange(400), (np.arange(400) // 100) * 4 + (np.arange(400) % 20) // 5] = 1.0


def haar(ii, pad, x, y, side, subpixel=False):
    """Haar responses (dx, dy) of even ``side`` at centre-convention points (x, y).

    ``x``, ``y``: float arrays (any equal shapes); ``side``: int array broadcastable to them.
    Box corners are clamped into the integral image (pixels beyond the padding count as 0).
    With ``subpixel`` the box edges sit at the exact fractional positions: the integral
    image of a piecewise-constant image is bilinear between its nodes, so the response is
    the bilinear blend of the four responses at the neighbouring integer positions.
    """
    hh = side // 2
    if not subpixel:
        # round half up (not to even): integral column/row of the box's left/top edge
        x0 = np.floor(x + 1.0 - hh).astype(np.int64) + pad
        y0 = np.floor(y + 1.0 - hh).astype(np.int64) + pad
        return _haar_int(ii, x0, y0, side, hh)
    fx0 = x + 0.5 - hh + pad
    fy0 = y + 0.5 - hh + pad
    x0, y0 = np.floor(fx0), np.floor(fy0)
    wx, wy = fx0 - x0, fy0 - y0
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    dx = np.zeros(np.shape(x))
    dy = np.zeros(np.shape(x))
    for ox, oy, w in ((0, 0, (1 - wx) * (1 - wy)), (1, 0, wx * (1 - wy)),
                      (0, 1, (1 - wx) * wy), (1, 1, wx * wy)):
        a, b = _haar_int(ii, x0 + ox, y0 + oy, side, hh)
        dx += w * a
        dy += w * b
    return dx, dy


def _haar_int(ii, x0, y0, side, hh):
    """Haar responses of boxes with integral-image left/top edges (x0, y0)."""
    nrow, ncol = ii.shape
    flat = ii.ravel()

    inside = (x0.min() >= 0 and y0.min() >= 0 and (x0 + side).max() < ncol
              and (y0 + side).max() < nrow)   # the usual case: the padding covers the window

    def cx(a):
        return a if inside else np.clip(a, 0, ncol - 1)

    def cy(a):
        return (a if inside else np.clip(a, 0, nrow - 1)) * ncol

    xa, xm, xb = cx(x0), cx(x0 + hh), cx(x0 + side)
    ya, ym, yb = cy(y0), cy(y0 + hh), cy(y0 + side)
    aa, ab = flat.take(ya + xa), flat.take(ya + xb)
    ba, bb = flat.take(yb + xa), flat.take(yb + xb)
    am, bm = flat.take(ya + xm), flat.take(yb + xm)
    ma, mb = flat.take(ym + xa), flat.take(ym + xb)
    # right - left = [bb - ab - bm + am] - [bm - am - ba + aa]
    dx = (bb - ab) - 2.0 * (bm - am) + (ba - aa)
    # bottom - top = [bb - mb - ba + ma] - [mb - ab - ma + aa]
    dy = (bb - ba) - 2.0 * (mb - ma) + (ab - aa)
    return dx, dy


def orientation(img, x, y, s):
    """Dominant orientation (radians, in [0, 2 pi)) of keypoints at (x, y) with scale s.

    ``img`` is the smoothed image the keypoints were detected on (float32, centre
    convention). See the module docstring: gradients by central differences of bilinear
    samples on a grid of spacing s/2, so that they rotate with the image.
    """
    n = len(x)
    out = np.zeros(n)
    k = ORI_GRID.shape[0]
    for a in range(0, n, CHUNK):
        b = min(n, a + CHUNK)
        m = b - a
        sc = s[a:b, None]
        px = (x[a:b, None] + ORI_GRID.ravel()[None] * sc).astype(np.float32)
        py = (y[a:b, None] + ORI_GRID.T.ravel()[None] * sc).astype(np.float32)
        p = cv2.remap(img, px, py, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101).reshape(m, k, k)
        dx = (p[:, 1:-1, 2:] - p[:, 1:-1, :-2])[:, ORI_DISC] * ORI_W
        dy = (p[:, 2:, 1:-1] - p[:, :-2, 1:-1])[:, ORI_DISC] * ORI_W
        out[a:b] = _dominant(dx.astype(np.float64), dy.astype(np.float64))
    return out


def _dominant(dx, dy):
    """Angle of the longest sum of (dx, dy) over a sliding window of ORI_WINDOW degrees
    (a 360-bin histogram of the response angles, summed circularly from every bin)."""
    m, w = dx.shape[0], ORI_WINDOW
    bins = (np.floor(np.degrees(np.arctan2(dy, dx))).astype(np.int64)) % 360
    idx = (np.arange(m)[:, None] * 360 + bins).ravel()
    hx = np.bincount(idx, dx.ravel(), minlength=m * 360).reshape(m, 360)
    hy = np.bincount(idx, dy.ravel(), minlength=m * 360).reshape(m, 360)
    cx = np.concatenate([np.zeros((m, 1)), np.cumsum(np.concatenate([hx, hx[:, :w - 1]], 1), 1)], 1)
    cy = np.concatenate([np.zeros((m, 1)), np.cumsum(np.concatenate([hy, hy[:, :w - 1]], 1), 1)], 1)
    wx = cx[:, w:w + 360] - cx[:, :360]
    wy = cy[:, w:w + 360] - cy[:, :360]
    best = np.argmax(wx * wx + wy * wy, axis=1)
    r = np.arange(m)
    return np.arctan2(wy[r, best], wx[r, best]) % (2 * np.pi)


def descriptors(ii, pad, x, y, s, theta, extended=False, subpixel=None):
    """SURF descriptors (N x 64 or N x 128 float32, unit length) at (x, y, s, theta)."""
    subpixel = SUBPIXEL if subpixel is None else subpixel
    n = len(x)
    dim = 128 if extended else 64
    out = np.zeros((n, dim), np.float32)
    for a in range(0, n, CHUNK):
        b = min(n, a + CHUNK)
        sc = s[a:b, None]
        c, si = np.cos(theta[a:b, None]), np.sin(theta[a:b, None])
        side = np.maximum(2, 2 * np.rint(sc).astype(np.int64))
        px = x[a:b, None] + sc * (c * DESC_U - si * DESC_V)
        py = y[a:b, None] + sc * (si * DESC_U + c * DESC_V)
        dx, dy = haar(ii, pad, px, py, side, subpixel)
        dx, dy = dx.astype(np.float32), dy.astype(np.float32)
        c, si = c.astype(np.float32), si.astype(np.float32)
        du = (dx * c + dy * si) * DESC_W.astype(np.float32)
        dv = (dy * c - dx * si) * DESC_W.astype(np.float32)
        m = b - a
        if not extended:
            parts = [du, dv, np.abs(du), np.abs(dv)]
        else:
            pu, pv = dv >= 0, du >= 0
            z = np.float32(0)
            parts = [np.where(pu, du, z), np.where(pu, z, du),
                     np.where(pu, np.abs(du), z), np.where(pu, z, np.abs(du)),
                     np.where(pv, dv, z), np.where(pv, z, dv),
                     np.where(pv, np.abs(dv), z), np.where(pv, z, np.abs(dv))]
        # sub-region sums as one matrix product: (k, m, 400) @ (400, 16) -> (k, m, 16)
        sums = np.stack(parts) @ DESC_SUB
        d = sums.transpose(1, 2, 0).reshape(m, dim)
        norm = np.sqrt((d * d).sum(1, keepdims=True))
        d /= np.where(norm > 0, norm, 1.0)
        out[a:b] = d
    return out

