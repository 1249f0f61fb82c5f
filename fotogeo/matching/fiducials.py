"""Fiducial marks of scanned film frames: templates, NCC search and LSM to sub-pixel (array layer).

The targets paper's method (Büyüksalih; :mod:`fotogeo.matching.targets`) without approximate
positions: each mark is looked for in a search region predicted from the calibration report's
layout (:func:`predict`), by normalised cross-correlation with a synthetic template of the mark
(:func:`mark_template`: X, cross, dot or corner, area-sampled, at the scan's pixel size and
rotation), then measured to sub-pixel by least-squares matching of the same template
(:func:`fotogeo.matching.lsm.lsm_many`: affine + radiometric for X and cross marks, shift +
radiometric for dots and corners, whose shape does not fix a rotation).

Layout prediction for a scan rotation ``θ`` (clockwise on screen, multiples of 90° first) and
pixel size ``p`` (mm): with the photo coordinates ``(x, y)`` (x right, y up) relative to the
centre ``(x̄, ȳ)`` of the layout's bounding box (the film frame's centre) and the scan centre
``(W/2, H/2)``::

    [col, row] = [W/2, H/2] + R(θ) · [(x − x̄) / p, −(y − ȳ) / p]

Coordinates are GDAL corner convention (:mod:`fotogeo.pixels`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .lsm import lsm_many
from .ncc import correlation_surface
from .targets import synthetic_x_target

#: a correlation peak below this is "not found"
MIN_CORRELATION = 0.5


@dataclass(frozen=True)
class MarkShape:
    """A mark in scan pixels: ``kind`` (x, cross, dot, corner), tip-to-tip ``size`` and arm ``width``."""

    kind: str
    size: float
    width: float

    @property
    def half(self) -> int:
        """Half side of the template: the mark and 3 px of background around it."""
        return int(np.ceil(self.size / 2.0)) + 3


@dataclass(frozen=True)
class MarkResult:
    """One mark: ``xy`` (NaN if not found), LSM ``sigma``, NCC peak ``ncc`` and ``status``."""

    xy: np.ndarray
    sigma: np.ndarray
    ncc: float
    status: str

    @property
    def ok(self) -> bool:
        return self.status == "found"


def rotation(theta_deg: float) -> np.ndarray:
    """2x2 rotation by ``theta_deg`` clockwise on screen (x right, y down)."""
    t = np.deg2rad(theta_deg)
    return np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])


def predict(fiducials_mm: np.ndarray, pixel_mm: float, scan_size, theta_deg: float) -> np.ndarray:
    """Predicted scan pixels ``(N, 2)`` of the marks (module docstring)."""
    f = np.asarray(fiducials_mm, float)
    mid = (f.min(axis=0) + f.max(axis=0)) / 2.0
    d = np.column_stack([f[:, 0] - mid[0], -(f[:, 1] - mid[1])]) / pixel_mm
    return np.array(scan_size, float) / 2.0 + d @ rotation(theta_deg).T


def mark_template(shape: MarkShape, theta_deg: float = 0.0, quadrant=(1.0, 1.0), bright: bool = True) -> np.ndarray:
    """Area-sampled template ``(2s+1)²`` (``s`` = :attr:`MarkShape.half`) of the mark, centre at ``(s+½, s+½)``.

    ``quadrant`` (corner marks): the screen directions ``(±1, ±1)`` the filled corner opens to,
    before the rotation. Values 1 on the mark and 0 around it (``bright=False``: inverted).
    """
    s = shape.half
    n = 2 * s + 1
    if shape.kind in ("x", "cross"):
        base = 45.0 if shape.kind == "x" else 0.0
        t = synthetic_x_target((n, n), (s + 0.5, s + 0.5), shape.width, (base + theta_deg, base + 90 + theta_deg),
                               1.0, 0.0, radius=shape.size / 2.0)
    else:
        t = _area_sampled(n, lambda u, v: _dot_or_corner(u, v, shape, theta_deg, quadrant))
    return t if bright else 1.0 - t


def _dot_or_corner(u, v, shape, theta_deg, quadrant):
    """Inside test of a dot (disc of diameter ``size``) or a corner (filled quadrant within ``size / 2``)."""
    if shape.kind == "dot":
        return u * u + v * v <= (shape.size / 2.0) ** 2
    a, b = np.tensordot(rotation(-theta_deg), np.stack([u, v]), axes=1)
    return (a * quadrant[0] >= 0) & (b * quadrant[1] >= 0) & (u * u + v * v <= (shape.size / 2.0) ** 2)


def _area_sampled(n: int, inside, supersample: int = 8) -> np.ndarray:
    """Mean of ``inside(u, v)`` over ``supersample²`` samples per pixel of an ``n x n`` template
    (``u`` right, ``v`` down, relative to the template centre ``n / 2``)."""
    sub = (np.arange(supersample) + 0.5) / supersample
    coords = (np.arange(n)[:, None] + sub[None, :]).reshape(-1) - n / 2.0
    V, U = np.meshgrid(coords, coords, indexing="ij")
    return inside(U, V).reshape(n, supersample, n, supersample).mean(axis=(1, 3)).astype(np.float64)


def search_mark(img: np.ndarray, predicted, template: np.ndarray, search_px: int):
    """NCC peak of ``template`` within ``search_px`` of ``predicted`` (the region clipped to the scan):
    ``(xy, ρ)``, xy NaN when the region holds no whole template or the peak lies on its border."""
    s = template.shape[0] // 2
    c, r = int(round(predicted[0])), int(round(predicted[1]))
    c0, r0 = max(0, c - search_px - s), max(0, r - search_px - s)
    c1, r1 = min(img.shape[1], c + search_px + s + 1), min(img.shape[0], r + search_px + s + 1)
    if c1 - c0 < 2 * s + 3 or r1 - r0 < 2 * s + 3:
        return np.array([np.nan, np.nan]), np.nan
    rho = correlation_surface(template, img[r0:r1, c0:c1])
    if not np.isfinite(rho).any():
        return np.array([np.nan, np.nan]), np.nan
    i, j = np.unravel_index(int(np.nanargmax(np.where(np.isfinite(rho), rho, -2))), rho.shape)
    if i in (0, rho.shape[0] - 1) or j in (0, rho.shape[1] - 1):
        return np.array([np.nan, np.nan]), float(rho[i, j])
    di = _vertex(rho[i - 1, j], rho[i, j], rho[i + 1, j])
    dj = _vertex(rho[i, j - 1], rho[i, j], rho[i, j + 1])
    return np.array([c0 + j + dj + s + 0.5, r0 + i + di + s + 0.5]), float(rho[i, j])


def _vertex(a, b, c) -> float:
    den = a - 2 * b + c
    return float(np.clip(0.5 * (a - c) / den, -0.5, 0.5)) if den < 0 else 0.0


def measure_marks(img, predicted, templates, search_px: int, kind: str, min_correlation: float = MIN_CORRELATION):
    """:class:`MarkResult` per mark: NCC in the search region of its predicted position, then LSM of
    its template (one per mark, or a list of candidates — e.g. both polarities — of which the best
    correlating is used)."""
    out = []
    for q, cands in zip(np.asarray(predicted, float), templates):
        cands = cands if isinstance(cands, (list, tuple)) else [cands]
        found = [search_mark(img, q, t, search_px) for t in cands]
        k = int(np.nanargmax([r if np.isfinite(r) else -2 for _, r in found]))
        xy, rho = found[k]
        if not np.isfinite(xy).all():
            out.append(MarkResult(xy, np.array([np.nan, np.nan]), rho,
                                  "search region outside the scan" if not np.isfinite(rho) else "peak at the border"))
            continue
        if rho < min_correlation:
            out.append(MarkResult(np.array([np.nan, np.nan]), np.array([np.nan, np.nan]), rho, "low correlation"))
            continue
        t = cands[k]
        s = t.shape[0] // 2
        b = lsm_many(t, img, [[s + 0.5, s + 0.5]], xy[None], half_window=max(4, s - 1), max_shift=2.0,
                     model="affine" if kind in ("x", "cross") else "shift", min_correlation=min_correlation)
        r = b[0]
        status = "found" if r.status == "converged" else f"sub-pixel measurement failed: {r.status}"
        out.append(MarkResult(r.xy if r.status == "converged" else np.array([np.nan, np.nan]), r.sigma, rho, status))
    return out
