"""Brown's lens distortion: the one forward model (and its inverse) of fotogeo's frame cameras.

Brown (1971, "Close-range camera calibration") with the radial polynomial to r⁶ and the decentring (tangential)
terms of the first order, in the form and sign convention OpenCV, OpenSfM (``brown``), COLMAP (``OPENCV``) and
DJI's ``DewarpData`` write (Fraser 1997, "Digital camera self-calibration", eq. 5, has the same terms, there as
corrections of the measured image coordinates, the opposite direction). On the focal-length-normalised coordinates
of the OpenCV camera axes (x right, y down), ``x = (col − ppx)/fx``, ``y = (row − ppy)/fy`` — not pixels, so the
coefficients are dimensionless and independent of the image size::

    r² = x² + y²
    ρ  = 1 + k1 r² + k2 r⁴ + k3 r⁶                              (radial)
    x' = x ρ + 2 p1 x y + p2 (r² + 2x²)
    y' = y ρ + p1 (r² + 2y²) + 2 p2 x y                         (decentring)

``(x, y)`` is the ideal (pinhole) position of a ray, ``(x', y')`` where the lens puts it: the distorted pixel is
``(fx x' + ppx, fy y' + ppy)``. The coefficients are always given in the order ``(k1, k2, k3, p1, p2)``
(:data:`TERMS`; DJI's ``DewarpData`` writes ``k1, k2, p1, p2, k3``, its reader reorders).

:func:`distort` evaluates the forward model (in place into given arrays when asked: the orthophoto's grids),
:func:`undistort` inverts it by the fixed-point iteration ``(x, y) ← ((x', y') − δ(x, y)) / ρ(x, y)`` (δ the
decentring terms), which converges for the moderate distortion of mapping cameras.
"""
from __future__ import annotations

import numpy as np

#: the order of the coefficients every function here takes
TERMS = ("k1", "k2", "k3", "p1", "p2")


def coefficients(distortion) -> tuple:
    """``(k1, k2, k3, p1, p2)`` as floats from a mapping (missing or None terms 0) or a sequence in that order."""
    if hasattr(distortion, "get"):
        return tuple(float(distortion.get(k, 0.0) or 0.0) for k in TERMS)
    return tuple(float(c) for c in distortion)


def _add_decentring(xd, yd, x, y, r2, p1, p2) -> None:
    """Add the decentring terms (module docstring) to ``xd``, ``yd`` in place, ``p1``'s term first, then ``p2``'s;
    a term whose coefficient is 0 is not added."""
    if p1:
        t = np.multiply(x, 2 * p1)  # 2 p1 x y
        t *= y
        xd += t
        np.multiply(y, y, out=t)  # p1 (r² + 2y²)
        t *= 2.0
        t += r2
        t *= p1
        yd += t
    if p2:
        t = np.multiply(x, x)  # p2 (r² + 2x²)
        t *= 2.0
        t += r2
        t *= p2
        xd += t
        np.multiply(x, 2 * p2, out=t)  # 2 p2 x y
        t *= y
        yd += t


def _radial(x, y, k1, k2, k3) -> tuple:
    """``(r², ρ)`` of the module docstring."""
    r2 = np.multiply(x, x)
    r2 += y * y
    rho = np.multiply(r2, k3)  # 1 + r² (k1 + r² (k2 + r² k3))
    rho += k2
    rho *= r2
    rho += k1
    rho *= r2
    rho += 1.0
    return r2, rho


def distort(x, y, coeffs, out=None) -> tuple:
    """``(r², ρ, x', y')`` of the ideal normalised coordinates ``x``, ``y`` (arrays of one shape) under Brown's
    model with ``coeffs`` ``(k1, k2, k3, p1, p2)`` (module docstring). ``out``: two arrays to hold ``x'``, ``y'``
    (they must not be ``x`` or ``y``)."""
    k1, k2, k3, p1, p2 = coeffs
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    r2, rho = _radial(x, y, k1, k2, k3)
    xd, yd = (np.empty_like(x), np.empty_like(y)) if out is None else out
    np.multiply(x, rho, out=xd)
    np.multiply(y, rho, out=yd)
    _add_decentring(xd, yd, x, y, r2, p1, p2)
    return r2, rho, xd, yd


def undistort(xd, yd, coeffs, iterations: int = 8) -> tuple:
    """The ideal normalised coordinates ``(x, y)`` whose :func:`distort` is ``(xd, yd)``, by ``iterations`` steps
    of the fixed-point iteration of the module docstring, starting from ``(xd, yd)``."""
    k1, k2, k3, p1, p2 = coeffs
    xd, yd = np.asarray(xd, dtype=np.float64), np.asarray(yd, dtype=np.float64)
    x, y = xd.copy(), yd.copy()
    for _ in range(iterations):
        r2, rho = _radial(x, y, k1, k2, k3)
        dx, dy = np.zeros_like(x), np.zeros_like(y)
        _add_decentring(dx, dy, x, y, r2, p1, p2)
        x, y = (xd - dx) / rho, (yd - dy) / rho
    return x, y
