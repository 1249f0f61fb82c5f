"""Occlusion: is a ground point seen by the image, or hidden behind a higher part of the surface?

A point ``P = (X, Y, Z)`` on a surface model ``S`` (a DSM: terrain, buildings, trees) is *seen* when
its line of sight towards the sensor stays above ``S``. The line of sight of any ground → image
model ``m`` is the set of ground points with ``P``'s image position, so its direction ``d`` is the
null vector of the model's 2×3 Jacobian ``J = ∂m/∂(X, Y, Z)`` at ``P``: ``d = J₁ × J₂`` (the cross
product of the two rows), turned so that ``d_Z > 0``. A frame camera's line of sight is exactly the
ray to its projection centre ``C`` (``d = C − P``, used when the model has ``projection_centre``); an RPC's is
its local view direction (``J`` by forward differences of 0.5 map units).

The ray is marched upwards in horizontal steps ``s`` (half a DSM cell by default)::

    Q_k = P + k·s · (d_X, d_Y, d_Z) / |d_XY|,   k = 1, 2, …

and ``P`` is hidden as soon as ``S(Q_k) > Q_k,Z + tol``; the march of a point stops when its ray
rises above the highest surface height (then nothing can hide it). Near-vertical rays
(``|d_XY| < 10⁻⁶ d_Z``) are seen. Off the DSM (NaN) the ray is taken as free. A :class:`MaxPyramid` (block
maxima of the DSM) lets a ray skip a block-sized stretch at once wherever it is already above everything
within that distance, so the cost follows the number of samples near the surface rather than the ray's length.
This is the ray-tracing visibility test of true-orthophoto production (Amhar, Jansa & Ries 1998; Habib, Kim &
Kim 2007 discuss it against the z-buffer method); every point is independent of the others, so an output
window can be tested alone.
"""
from __future__ import annotations

import numpy as np

from ..pixels import as_points

#: forward-difference step (map units) of the line-of-sight Jacobian of a model without a centre
JACOBIAN_STEP = 0.5


def line_of_sight(model, XYZ) -> np.ndarray:
    """Directions ``(N, 3)`` from ground points ``XYZ`` towards the sensor (module docstring), not
    normalised, ``d_Z >= 0``; NaN where the model gives no image position."""
    P = as_points(XYZ, 3, "ground points")
    centre = getattr(model, "projection_centre", None)
    if centre is not None:
        return np.asarray(centre, float)[None, :] - P
    p0 = model.forward(P)
    J = np.empty((len(P), 2, 3))
    for k in range(3):
        step = np.zeros(3)
        step[k] = JACOBIAN_STEP
        J[:, :, k] = (model.forward(P + step) - p0) / JACOBIAN_STEP
    d = np.cross(J[:, 0, :], J[:, 1, :])
    return np.where(d[:, 2:3] < 0, -d, d)


class MaxPyramid:
    """Upper bounds of a DEM's bilinear heights for skipping empty stretches of a ray.

    ``bound(XY)`` is the highest DEM cell within one block of ``factor`` x ``factor`` cells around the block of
    ``XY`` (each block's maximum taken over its cells and their neighbours, then over the 3 x 3 blocks around it):
    no bilinear height within ``reach = factor`` cells of ``XY`` exceeds it. Nodata and off-DEM: −inf (free)."""

    def __init__(self, dem, factor: int = 8):
        from scipy.ndimage import maximum_filter
        z = np.where(np.isfinite(dem.data), dem.data, -np.inf)
        z = maximum_filter(z, size=3, mode="nearest")  # a bilinear value never exceeds its neighbours
        r, c = z.shape
        R, C = -(-r // factor), -(-c // factor)
        pad = np.full((R * factor, C * factor), -np.inf)
        pad[:r, :c] = z
        blocks = pad.reshape(R, factor, C, factor).max(axis=(1, 3))
        self.bounds = maximum_filter(blocks, size=3, mode="constant", cval=-np.inf)
        self.factor, self.dem = factor, dem
        self.reach = factor * min(abs(dem.transform.a), abs(dem.transform.e))  # map units

    def bound(self, XY) -> np.ndarray:
        inv = ~self.dem.transform
        c, r = inv * (XY[:, 0], XY[:, 1])
        i, j = np.floor(r / self.factor).astype(np.int64), np.floor(c / self.factor).astype(np.int64)
        R, C = self.bounds.shape
        inside = (i >= 0) & (i < R) & (j >= 0) & (j < C)
        out = np.full(len(XY), -np.inf)
        out[inside] = self.bounds[i[inside], j[inside]]
        return out


def hidden(surface, XYZ, directions, *, step: float, tol: float = 0.05, z_top: float | None = None,
           pyramid: MaxPyramid | None = None) -> np.ndarray:
    """``(N,)`` True where the ray from ``XYZ`` along ``directions`` meets ``surface`` (module docstring).

    ``surface`` has ``heights(XY)`` (NaN off the surface) and, unless ``z_top`` is given, ``z_range``;
    ``step`` is the horizontal step in map units, ``tol`` the height margin in map units. With ``pyramid`` (a
    :class:`MaxPyramid` of the same surface) a ray whose height at ``Q_k`` exceeds the bound there jumps
    ``reach`` map units at once: no surface within that distance can reach it (the ray only rises)."""
    P = as_points(XYZ, 3, "ground points")
    d = np.asarray(directions, float)
    top = float(surface.z_range[1]) if z_top is None else float(z_top)
    out = np.zeros(len(P), bool)
    horiz = np.hypot(d[:, 0], d[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        tilted = np.isfinite(P).all(axis=1) & np.isfinite(horiz) & (horiz > 1e-6 * np.abs(d[:, 2])) & (P[:, 2] < top)
        unit = d[:, :2] / horiz[:, None]
        rise = d[:, 2] / horiz  # height gained per horizontal map unit
    idx = np.flatnonzero(tilted)
    k = np.ones(len(P), np.int64)  # the next sample of each ray
    jump = max(1, int(pyramid.reach // step)) if pyramid is not None else 0
    while idx.size:
        s = (k[idx] * step)[:, None]
        Q = P[idx, :2] + s * unit[idx]
        zr = P[idx, 2] + s[:, 0] * rise[idx]
        if jump:
            free = zr > pyramid.bound(Q) + tol
            k[idx[free]] += jump
            test = ~free
        else:
            test = np.ones(len(idx), bool)
        blocked = np.zeros(len(idx), bool)
        if test.any():
            with np.errstate(invalid="ignore"):
                blocked[test] = surface.heights(Q[test]) > zr[test] + tol
            k[idx[test]] += 1
        out[idx[blocked]] = True
        idx = idx[~blocked & (zr <= top)]
    return out


def visible_pixels(model, surface, XYZ, pixels, *, step: float, tol: float = 0.05, pyramid=None) -> np.ndarray:
    """``pixels`` ``(N, 2)`` with NaN where the ground point ``XYZ`` is hidden from ``model``'s sensor;
    only points with a finite pixel are tested."""
    px = np.array(pixels, dtype=np.float64)
    tested = np.isfinite(px).all(axis=1)
    if tested.any():
        P = np.asarray(XYZ, float)[tested]
        hid = hidden(surface, P, line_of_sight(model, P), step=step, tol=tol, pyramid=pyramid)
        rows = np.flatnonzero(tested)[hid]
        px[rows] = np.nan
    return px
