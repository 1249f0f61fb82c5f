"""Ebner's (1976) 12 additional parameters of the bundle adjustment (array layer).

Ebner's set models the systematic image errors left after the physical interior orientation
as a bi-quadratic polynomial, orthogonal over a 3 × 3 grid of image points (the Gruber
positions, at ``−b, 0, b``). fotogeo takes the image coordinates from the principal point in
units of the half image size, ``ξ = x / (w/2)``, ``η = y / (h/2)`` (``x, y`` in pixels, the
camera convention's axes: x right, y down), so the grid is ``ξ, η ∈ {−1, 0, 1}`` and its mean
square ``c = 2/3``. With ``X₂ = ξ² − c`` and ``Y₂ = η² − c`` the corrections, in pixels, are::

    Δx =  b1 ξ + b2 η − 2 b3 X₂ + b4 ξη + b5 Y₂ + b7 ξ Y₂ + b9 η X₂ + b11 X₂ Y₂
    Δy = −b1 η + b2 ξ + b3 ξη − 2 b4 Y₂ + b6 X₂ + b8 η X₂ + b10 ξ Y₂ + b12 X₂ Y₂

(b1 an affinity, b2 a shear, b3–b6 quadratic, b7–b12 higher terms; each ``b`` is the size of its
error pattern at the image edge, in px). The terms that a conformal change of the image would
make (a scale, a rotation, a shift) are left out: the focal length, κ and the principal point
take them. The corrections are added after Brown's distortion,
``col = x + ppx + Δx``, ``row = y + ppy + Δy``.
"""
from __future__ import annotations

import numpy as np

from ..options import EBNER_PARAMETERS

C_GRID = 2.0 / 3.0  # mean of ξ² over the grid −1, 0, 1


def terms(xi: np.ndarray, eta: np.ndarray):
    """``(gx, gy)`` ``(n, 12)``: ``∂Δx/∂b_k`` and ``∂Δy/∂b_k`` at ``(ξ, η)`` (module docstring)."""
    X2, Y2 = xi * xi - C_GRID, eta * eta - C_GRID
    z = np.zeros_like(xi)
    gx = np.stack([xi, eta, -2 * X2, xi * eta, Y2, z, xi * Y2, z, eta * X2, z, X2 * Y2, z], axis=1)
    gy = np.stack([-eta, xi, xi * eta, -2 * Y2, z, X2, z, eta * X2, z, xi * Y2, z, X2 * Y2], axis=1)
    return gx, gy


def corrections(b: np.ndarray, xi: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(Δx, Δy)`` in pixels for the parameters ``b`` ``(12,)``."""
    gx, gy = terms(xi, eta)
    return gx @ b, gy @ b


def derivatives(b: np.ndarray, xi: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """``∂(Δx, Δy)/∂(ξ, η)`` ``(n, 2, 2)`` for the parameters ``b``."""
    b1, b2, b3, b4, b5, b6, b7, b8, b9, b10, b11, b12 = b
    X2, Y2 = xi * xi - C_GRID, eta * eta - C_GRID
    D = np.empty((len(xi), 2, 2))
    D[:, 0, 0] = b1 - 4 * b3 * xi + b4 * eta + b7 * Y2 + 2 * b9 * xi * eta + 2 * b11 * xi * Y2
    D[:, 0, 1] = b2 + b4 * xi + 2 * b5 * eta + 2 * b7 * xi * eta + b9 * X2 + 2 * b11 * eta * X2
    D[:, 1, 0] = b2 + b3 * eta + 2 * b6 * xi + 2 * b8 * xi * eta + b10 * Y2 + 2 * b12 * xi * Y2
    D[:, 1, 1] = -b1 + b3 * xi - 4 * b4 * eta + b8 * X2 + 2 * b10 * xi * eta + 2 * b12 * eta * X2
    return D


def remove(x: np.ndarray, y: np.ndarray, b: np.ndarray, half: np.ndarray, iterations: int = 6):
    """``(x, y)`` freed of the corrections: the fixed point of ``x = x_measured − Δx(x, y)`` (the
    corrections are a few pixels and vary slowly, so a few iterations converge)."""
    xm, ym = x, y
    for _ in range(iterations):
        dx, dy = corrections(b, x / half[0], y / half[1])
        x, y = xm - dx, ym - dy
    return x, y


NAMES = EBNER_PARAMETERS
