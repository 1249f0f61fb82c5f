"""A ground → image model in geographic ``(lon, lat, h)`` (an RPC) used in a projected map CRS.

:class:`LonLatModel` wraps such a model so that it takes map ``(X, Y, Z)`` like every other 3-D
model of :class:`~fotogeo.geometry.georeference.Georeference`: ``forward`` converts ``(X, Y)`` to
``(lon, lat)`` (pyproj, ``always_xy``) and keeps ``Z`` (the height must already be what the model
expects: ellipsoidal for RPC00B, :mod:`fotogeo.geometry.vertical`); ``inverse`` intersects the
model's lines of sight with a height source given in the map CRS and returns map points.
"""
from __future__ import annotations

import numpy as np

from ..pixels import as_points
from .dem import heights_at, is_height_source


class LonLatModel:
    """``model`` (ground (lon, lat, h) → pixel) seen from the map CRS ``crs`` (module docstring)."""

    src_dims = 3

    def __init__(self, model, crs):
        from pyproj import CRS, Transformer
        self.model = model
        self.crs = CRS.from_user_input(crs)
        self._to_ll = Transformer.from_crs(self.crs, CRS.from_epsg(4326), always_xy=True)
        self._to_map = Transformer.from_crs(CRS.from_epsg(4326), self.crs, always_xy=True)

    def lonlat(self, XY) -> np.ndarray:
        XY = np.asarray(XY, float)
        return np.column_stack(self._to_ll.transform(XY[:, 0], XY[:, 1]))

    def to_map(self, lonlat) -> np.ndarray:
        ll = np.asarray(lonlat, float)
        return np.column_stack(self._to_map.transform(ll[:, 0], ll[:, 1]))

    def forward(self, XYZ) -> np.ndarray:
        P = as_points(XYZ, 3, "ground points")
        return self.model.forward(np.column_stack([self.lonlat(P[:, :2]), P[:, 2]]))

    def inverse(self, pixel, heights=None, **_) -> np.ndarray:
        """Map ``(X, Y, Z)`` of image pixels at ``heights`` (a number, ``(N,)`` or a map-CRS height source)."""
        if is_height_source(heights):
            heights = _LonLatHeights(heights, self.to_map)  # the model samples in lon/lat
        ll = np.asarray(self.model.inverse(as_points(pixel, 2, "pixels"), heights), float)
        return np.column_stack([self.to_map(ll[:, :2]), ll[:, 2] if ll.shape[1] > 2 else np.full(len(ll), np.nan)])


class _LonLatHeights:
    """A map-CRS height ``source`` sampled at ``(lon, lat)`` (``to_map`` converts), keeping its ``z_range``."""

    def __init__(self, source, to_map):
        self.source, self.to_map = source, to_map
        if hasattr(source, "z_range"):  # callers test hasattr, never None
            self.z_range = source.z_range

    def __call__(self, LL) -> np.ndarray:
        return heights_at(self.source, self.to_map(LL))
