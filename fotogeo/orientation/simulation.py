"""Ground control / check points generated from a known (true) frame geometry, for tests.

:func:`make_gcps` draws pixel positions in a frame, intersects their rays with a DEM
(:meth:`fotogeo.geometry.camera.OrientedFrame.pixel_to_world`) to get exact ground coordinates, and
splits them into GCPs (whose pixel coordinates get Gaussian measurement noise of ``noise``
px per axis) and check points (kept exact), following the two spreads of Öztürk et al.:

* ``"homogeneous"`` — spatially stratified: the frame is divided into a grid of about
  ``n_gcp + n_check`` cells of equal size (aspect ratio kept), ``n_gcp + n_check`` cells are
  drawn at random and one uniformly random point is taken in each; the points are then
  randomly split into GCPs and check points;
* ``"clustered"`` (heterogeneous) — the GCPs lie in ``n_clusters`` discs of radius
  ``cluster_radius`` × the frame's shorter side around random centres, while the check points
  are stratified over the whole frame (so the check measures extrapolation too).

Pixel coordinates follow the GDAL corner convention; ``margin`` (px) keeps points off the
frame border. Everything is seeded (``seed``: int or ``numpy.random.Generator``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class GcpSet:
    """GCPs (noisy pixels, exact ground) and check points (exact pixels and ground)."""

    gcp_ground: np.ndarray  # (N, 3) X, Y, Z
    gcp_pixel: np.ndarray  # (N, 2) measured (with noise)
    gcp_pixel_true: np.ndarray  # (N, 2) exact
    check_ground: np.ndarray  # (M, 3)
    check_pixel: np.ndarray  # (M, 2) exact


def stratified_pixels(n: int, image_size, rng, margin: float = 2.0) -> np.ndarray:
    """``n`` points, one in each of ``n`` random cells of a near-square grid over the image."""
    w, h = (float(v) - 2 * margin for v in image_size)
    cols = max(1, round(math.sqrt(n * w / h)))
    rows = max(1, math.ceil(n / cols))
    while rows * cols < n:
        cols += 1
    cells = rng.choice(rows * cols, n, replace=False)
    r, c = np.divmod(cells, cols)
    u = rng.random((n, 2))
    return np.column_stack([margin + (c + u[:, 0]) * w / cols, margin + (r + u[:, 1]) * h / rows])


def clustered_pixels(n: int, image_size, rng, n_clusters: int = 3, cluster_radius: float = 0.1,
                     margin: float = 2.0) -> np.ndarray:
    """``n`` points uniformly in ``n_clusters`` discs (radius ``cluster_radius`` × shorter side)."""
    w, h = (float(v) for v in image_size)
    rad = cluster_radius * min(w, h)
    lo, hi = np.array([margin + rad, margin + rad]), np.array([w - margin - rad, h - margin - rad])
    centres = lo + rng.random((n_clusters, 2)) * (hi - lo)
    which = np.arange(n) % n_clusters
    rr = rad * np.sqrt(rng.random(n))
    th = rng.random(n) * 2 * np.pi
    return centres[which] + np.column_stack([rr * np.cos(th), rr * np.sin(th)])


def make_gcps(frame, dem, n_gcp: int = 40, n_check: int = 20, spread: str = "homogeneous",
              noise: float = 0.3, seed=None, *, n_clusters: int = 3, cluster_radius: float = 0.1,
              margin: float = 2.0) -> GcpSet:
    """Seeded GCP / check-point sets from ``frame`` (an :class:`~fotogeo.geometry.camera.OrientedFrame`) and ``dem``."""
    if spread not in ("homogeneous", "clustered"):
        raise InputError(f"spread must be 'homogeneous' or 'clustered'; got {spread!r}")
    if n_gcp < 1 or n_check < 0:
        raise InputError(f"need n_gcp ≥ 1 and n_check ≥ 0; got {n_gcp}, {n_check}")
    rng = np.random.default_rng(seed)
    size = frame.camera.image_size
    for _ in range(20):  # redraw points whose ray misses the DEM
        if spread == "homogeneous":
            px = stratified_pixels(n_gcp + n_check, size, rng, margin)
            order = rng.permutation(len(px))
            g_px, c_px = px[order[:n_gcp]], px[order[n_gcp:]]
        else:
            g_px = clustered_pixels(n_gcp, size, rng, n_clusters, cluster_radius, margin)
            c_px = stratified_pixels(n_check, size, rng, margin) if n_check else np.empty((0, 2))
        g_xyz, c_xyz = frame.pixel_to_world(g_px, dem), frame.pixel_to_world(c_px, dem)
        if np.isfinite(g_xyz).all() and np.isfinite(c_xyz).all():
            break
    else:
        raise InputError("could not draw points whose rays all meet the DEM; check that the DEM covers the frame")
    noisy = g_px + rng.normal(0.0, noise, g_px.shape) if noise > 0 else g_px.copy()
    return GcpSet(g_xyz, noisy, g_px, c_xyz, c_px)
