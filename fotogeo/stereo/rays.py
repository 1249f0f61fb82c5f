"""Triangulation of two rays: their closest point and how far they miss each other.

Rays ``P1(s) = C1 + s·d1`` and ``P2(t) = C2 + t·d2``; with ``w = C1 − C2``, ``a = d1·d1``, ``b = d1·d2``,
``c = d2·d2``, ``d = d1·w``, ``e = d2·w`` the closest points are at (Hartley & Sturm 1997, the mid-point method)::

    s = (b·e − c·d) / (a·c − b²),   t = (a·e − b·d) / (a·c − b²)

the point is their mid-point and the miss distance ``|P1(s) − P2(t)|``. Rays that are parallel, or meet behind
either centre (``s ≤ 0`` or ``t ≤ 0``), give NaN.

:func:`intersection_angles` gives the angle γ under which the rays of a point meet (at the point, between its
directions to the two centres). A height's standard deviation grows like ``σ_parallax / sin γ`` (Kraus 2007: the
normal case's ``σ_Z = Z² σ_px / (B f)``, ``B / Z ≈ γ``): rays meeting under a few degrees give heights several
times noisier than those of a wide pair.
"""
from __future__ import annotations

import numpy as np


def closest_points(c1, d1, c2, d2) -> tuple:
    """``(points (N, 3), miss distances (N,))`` of rays from ``c1`` along ``d1`` ``(N, 3)`` and from ``c2`` along
    ``d2`` (module docstring); ``c1``, ``c2`` one centre ``(3,)`` each or one per ray."""
    d1, d2 = np.asarray(d1, float), np.asarray(d2, float)
    c1, c2 = np.broadcast_to(np.asarray(c1, float), d1.shape), np.broadcast_to(np.asarray(c2, float), d2.shape)
    w = c1 - c2
    a, b, c = (d1 * d1).sum(1), (d1 * d2).sum(1), (d2 * d2).sum(1)
    d, e = (d1 * w).sum(1), (d2 * w).sum(1)
    den = a * c - b * b
    with np.errstate(invalid="ignore", divide="ignore"):
        s = (b * e - c * d) / den
        t = (a * e - b * d) / den
    p1 = c1 + s[:, None] * d1
    p2 = c2 + t[:, None] * d2
    P = 0.5 * (p1 + p2)
    miss = np.linalg.norm(p1 - p2, axis=1)
    bad = ~(np.abs(den) > 1e-12 * a * c) | ~(s > 0) | ~(t > 0)
    P[bad] = np.nan
    miss[bad] = np.nan
    return P, miss


def intersection_angles(P, c1, c2) -> np.ndarray:
    """The angle γ (degrees) at each point ``P`` ``(N, 3)`` between its directions to the centres ``c1`` and ``c2``
    ``(3,)`` (module docstring); NaN where a point is NaN or on a centre."""
    P = np.asarray(P, float)
    a, b = np.asarray(c1, float) - P, np.asarray(c2, float) - P
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = (a * b).sum(1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
