"""Prediction grids of a fitted orientation model for the GCP picker (issue 14).

The dock predicts where the second click of a GCP belongs while the cursor moves, without a
round trip to the worker per mouse move: it interpolates these grids bilinearly.

* ``forward`` — image → map: ``cols`` and ``rows`` evenly spaced over the whole image
  (0..width, 0..height, corner convention), ``x[i][j], y[i][j]`` the map position of pixel
  ``(cols[j], rows[i])`` (:meth:`~fotogeo.geometry.georeference.Georeference.pixel_to_map`; 3-D
  models intersect the DEM, else the constant height, else the GCPs' mean height).
* ``inverse`` — map → image: ``xs`` ascending and ``ys`` descending (north up) over the GCPs'
  map extent padded on each side by half its span, ``col[i][j], row[i][j]`` the pixel of map
  point ``(xs[j], ys[i])`` (3-D models at the DEM height there, falling back on the constant
  or the GCPs' mean height where the DEM has none).

Values are None (JSON null) where the model gives no answer (a ray that misses the DEM, a point behind the
camera, a rational function's pole, a ray-DEM intersection that did not converge: its ground
point, projected back, misses the pixel by more than :data:`CONSISTENT_PX`).
"""
from __future__ import annotations

import numpy as np

from ...geometry.dem import heights_at
from ...geometry.georeference import Georeference

def _listed(a: np.ndarray) -> list:
    """Nested lists of floats, None where ``a`` is not finite (JSON null)."""
    return np.where(np.isfinite(a), a, None).tolist()


PAD = 0.5  # fraction of the GCPs' span added on each side of the inverse grid
CONSISTENT_PX = 0.1  # a forward node whose ground point projects back further than this is dropped


def dem_on_map_grid(dem, crs):
    """``dem`` (a :class:`~fotogeo.geometry.dem.Dem` in any CRS) resampled bilinearly onto a north-up
    grid in ``crs`` with as many cells as it has (NaN outside it), so that the grids' many ray-DEM
    intersections sample a DEM in the map CRS without a coordinate transformation per step.

    For the prediction grids only: a second bilinear resampling smooths the heights a little; the
    GCPs' own heights are sampled from the original DEM (:func:`fotogeo.tools.gcp.fit.dem_heights`).
    """
    from pyproj import CRS
    from rasterio.transform import from_origin

    from ...crs import transform_points
    from ...geometry.dem import Dem
    from ...pixels import outline
    dem_crs = CRS.from_user_input(dem.crs)
    if dem_crs == crs:
        return dem
    rows, cols = dem.data.shape
    edge = np.array([dem.transform * tuple(p) for p in outline(cols, rows, 33)])
    edge = transform_points(dem_crs, crs, edge)
    lo, hi = np.nanmin(edge, axis=0), np.nanmax(edge, axis=0)
    transform = from_origin(lo[0], hi[1], (hi[0] - lo[0]) / cols, (hi[1] - lo[1]) / rows)
    c, r = np.meshgrid(np.arange(cols) + 0.5, np.arange(rows) + 0.5)
    X = transform.c + transform.a * c
    Y = transform.f + transform.e * r
    z = dem.heights(transform_points(crs, dem_crs, np.column_stack([X.ravel(), Y.ravel()])))
    return Dem(np.asarray(z, float).reshape(rows, cols), transform, crs=crs, path=dem.path)


def _fallback_height(ground, default_height):
    z = ground[:, 2]
    if default_height is not None:
        return float(default_height)
    return float(np.nanmean(z)) if np.isfinite(z).any() else 0.0


def forward_grid(model, crs, size, n: int, heights) -> dict | None:
    """Image → map grid (module docstring); None without an image size."""
    if not size[0]:
        return None
    cols, rows = np.linspace(0.0, size[0], n), np.linspace(0.0, size[1], n)
    C, R = np.meshgrid(cols, rows)
    px = np.column_stack([C.ravel(), R.ravel()])
    with np.errstate(all="ignore"):
        if getattr(model, "src_dims", 2) == 3:
            # the model's DEM intersection (Georeference.pixel_to_map; only the nodes that have not converged
            # are iterated); an intersection that did not converge (steep relief) has no answer
            XY = model.inverse(px, heights)[:, :2]
            back = model.forward(np.column_stack([XY, heights_at(heights, XY)]))
            XY[~(np.hypot(*(back - px).T) < CONSISTENT_PX)] = np.nan
        else:
            XY = Georeference(model, heights=heights, crs=crs).pixel_to_map(px)
    return {"cols": cols.tolist(), "rows": rows.tolist(), "x": _listed(XY[:, 0].reshape(n, n)),
            "y": _listed(XY[:, 1].reshape(n, n))}


def inverse_grid(model, crs, ground, n: int, dem_sampler, fallback: float) -> dict:
    """Map → image grid over the padded GCP extent (module docstring)."""
    lo, hi = ground[:, :2].min(axis=0), ground[:, :2].max(axis=0)
    span = hi - lo
    span = np.where(span > 0, span, max(float(span.max()), 1.0))
    lo, hi = lo - PAD * span, hi + PAD * span
    xs, ys = np.linspace(lo[0], hi[0], n), np.linspace(hi[1], lo[1], n)
    X, Y = np.meshgrid(xs, ys)
    XY = np.column_stack([X.ravel(), Y.ravel()])
    z = np.full(len(XY), fallback)
    if dem_sampler is not None:
        h = np.asarray(dem_sampler.heights(XY), float)
        z = np.where(np.isfinite(h), h, fallback)
    with np.errstate(all="ignore"):
        P = Georeference(model, heights=z, crs=crs).map_to_pixel(XY)
    return {"xs": xs.tolist(), "ys": ys.tolist(), "col": _listed(P[:, 0].reshape(n, n)),
            "row": _listed(P[:, 1].reshape(n, n))}


def prediction_grids(model, crs, ground, size, n: int, *, dem=None, default_height=None):
    """``(forward, inverse)`` grids of ``model`` (ground → image) with ``n`` x ``n`` nodes each.

    ``ground`` ``(N, 3)`` are the GCPs used (their extent, their mean height); ``dem`` a height
    source at points in ``crs`` (:func:`dem_on_map_grid`) or None; ``size`` the image
    ``(width, height)`` or ``(None, None)``.
    """
    n = max(2, min(int(n), 200))
    fallback = _fallback_height(ground, default_height)
    sampler = dem
    heights = sampler if sampler is not None else fallback
    return forward_grid(model, crs, size, n, heights), inverse_grid(model, crs, ground, n, sampler, fallback)
