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

Orientation (Bay et al. 2008, sec. 4.1): responses of side 4s at the 109 points
``(i, j) s`` with ``i^2 + j^2 < 36``, weighted by a Gaussian of sigma 2s; a window of
pi/3 slides around the circle (1-degree steps, on a 360-bin histogram of the response
angles); the longest summed vector (sum dx, sum dy) gives the angle theta.

Descriptor (sec. 4.2): a 20s square rotated by theta, 20 x 20 sample points at spacing s
(offsets ``u, v = -9.5 .. 9.5``), position ``(x, y) + s R(theta) (u, v)``; Haar side 2s;
responses rotated into the keypoint frame ``du = dx cos + dy sin``, ``dv = -dx sin + dy cos``
and weighted by a Gaussian of sigma 3.3s; per 4x4 sub-region of 5x5 samples the vector
``(sum du, sum dv, sum |du|, sum |dv|)`` -> 64 values, normalised to unit length. The
extended variant splits ``sum du`` and ``sum |du|`` by the sign of ``dv`` and vice versa
(128 values).
"""
from __future__ import annotations

import numpy as np

#: Haar wavelets at exact (bilinear) positions rather than rounded ones, for the descriptor
#: and the orientation. Measured (benchmarks/surf_bench.py cases, rotations and scales):
#: orientation matching score +0.03 for +0.3 s at 4 Mpx; descriptor: matching score +0.005,
#: ratio-test score +0.015 for +0.12 s per 1000 keypoints (4 gathers instead of 1), so only
#: the orientation uses it by default.
SUBPIXEL = False
ORI_SUBPIXEL = True

#: Keypoints per chunk (bounds the (chunk, 400, 8) gathers to ~25 MB).
CHUNK = 1024

_I, _J = np.meshgrid(np.arange(-6, 7), np.arange(-6, 7), indexing="xy")
_DISC = (_I ** 2 + _J ** 2) < 36
ORI_U = _I[_DISC].astype(np.float64)         # 109 sample offsets (units of s)
ORI_V = _J[_DISC].astype(np.float64)
ORI_W = np.exp(-(ORI_U ** 2 + ORI_V ** 2) / (2 * 2.0 ** 2))

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


def orientation(ii, pad, x, y, s, subpixel=None):
    """Dominant orientation (radians, in [0, 2 pi)) of keypoints at (x, y) with scale s."""
    subpixel = ORI_SUBPIXEL if subpixel is None else subpixel
    n = len(x)
    out = np.zeros(n)
    for a in range(0, n, CHUNK):
        b = min(n, a + CHUNK)
        sc = s[a:b, None]
        side = np.maximum(2, 2 * np.rint(2 * sc).astype(np.int64))
        px = x[a:b, None] + ORI_U * sc
        py = y[a:b, None] + ORI_V * sc
        dx, dy = haar(ii, pad, px, py, side, subpixel)
        dx *= ORI_W
        dy *= ORI_W
        ang = np.arctan2(dy, dx)
        bins = (np.floor(np.degrees(ang)).astype(np.int64)) % 360
        m = b - a
        idx = (np.arange(m)[:, None] * 360 + bins).ravel()
        hx = np.bincount(idx, dx.ravel(), minlength=m * 360).reshape(m, 360)
        hy = np.bincount(idx, dy.ravel(), minlength=m * 360).reshape(m, 360)
        # circular window of 60 bins starting at every bin
        cx_ = np.concatenate([np.zeros((m, 1)), np.cumsum(np.concatenate([hx, hx[:, :59]], 1), 1)], 1)
        cy_ = np.concatenate([np.zeros((m, 1)), np.cumsum(np.concatenate([hy, hy[:, :59]], 1), 1)], 1)
        wx = cx_[:, 60:60 + 360] - cx_[:, :360]
        wy = cy_[:, 60:60 + 360] - cy_[:, :360]
        best = np.argmax(wx * wx + wy * wy, axis=1)
        r = np.arange(m)
        out[a:b] = np.arctan2(wy[r, best], wx[r, best]) % (2 * np.pi)
    return out


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
