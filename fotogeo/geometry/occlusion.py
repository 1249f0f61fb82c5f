"""Occlusion: is a ground point seen by the image, or hidden behind a higher part of the surface?

A point ``P = (X, Y, Z)`` on a surface model ``S`` (a DSM: terrain, buildings, trees) is *seen* when
its line of sight towards the sensor stays above ``S``. The line of sight of any ground → image
model ``m`` is the set of ground points with ``P``'s image position, so its direction ``d`` is the
null vector of the model's 2×3 Jacobian ``J = ∂m/∂(X, Y, Z)`` at ``P``: ``d = J₁ × J₂`` (the cross
product of the two rows), turned so that ``d_Z > 0``. A frame camera's line of sight is exactly the
ray to its projection centre ``C`` (``d = C − P``, used when the model has ``centre``); an RPC's is
its local view direction (``J`` by forward differences of 0.5 map units).

The ray is marched upwards in horizontal steps ``s`` (half a DSM cell by default)::

    Q_k = P + k·s · (d_X, d_Y, d_Z) / |d_XY|,   k = 1, 2, …

and ``P`` is hidden as soon as ``S(Q_k) > Q_k,Z + tol``; the march of a point stops when its ray
rises above the highest surface height (then nothing can hide it). Near-vertical rays
(``|d_XY| < 10⁻⁶ d_Z``) are seen. Off the DSM (NaN) the ray is taken as free. This is the ray-tracing
visibility test of true-orthophoto production (Amhar, Jansa & Ries 1998; Habib, Kim & Kim 2007
discuss it against the z-buffer method); every point is independent of the others, so an output
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
    centre = getattr(model, "centre", None)
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


def hidden(surface, XYZ, directions, *, step: float, tol: float = 0.05, z_top: float | None = None) -> np.ndarray:
    """``(N,)`` True where the ray from ``XYZ`` along ``directions`` meets ``surface`` (module docstring).

    ``surface`` has ``heights(XY)`` (NaN off the surface) and, unless ``z_top`` is given, ``z_range``;
    ``step`` is the horizontal step in map units, ``tol`` the height margin in map units.
    """
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
    k = 1
    while idx.size:
        s = k * step
        Q = P[idx, :2] + s * unit[idx]
        zr = P[idx, 2] + s * rise[idx]
        with np.errstate(invalid="ignore"):
            blocked = surface.heights(Q) > zr + tol
        out[idx[blocked]] = True
        idx = idx[~blocked & (zr <= top)]
        k += 1
    return out


def visible_pixels(model, surface, XYZ, pixels, *, step: float, tol: float = 0.05) -> np.ndarray:
    """``pixels`` ``(N, 2)`` with NaN where the ground point ``XYZ`` is hidden from ``model``'s sensor;
    only points with a finite pixel are tested."""
    px = np.array(pixels, dtype=np.float64)
    tested = np.isfinite(px).all(axis=1)
    if tested.any():
        P = np.asarray(XYZ, float)[tested]
        hid = hidden(surface, P, line_of_sight(model, P), step=step, tol=tol)
        rows = np.flatnonzero(tested)[hid]
        px[rows] = np.nan
    return px
