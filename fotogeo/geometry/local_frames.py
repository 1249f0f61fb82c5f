"""Local Cartesian frames of SfM reconstructions and the map (array layer, pyproj).

* **topocentric** (OpenSfM): east-north-up axes at a reference ``(lat, lon, alt)``; positions go
  through ECEF (EPSG:4978; from geodetic lon/lat/h, EPSG:4979, by :func:`fotogeo.crs.ecef`, back by pyproj), and
  a vector's axes turn with the local ENU frame from the reference to the point;
* **grid** (ODM, after OpenSfM's ``export_geocoords``): easting and northing as offsets parallel to the UTM grid
  from an origin — the UTM coordinates of the reference, or ODM's offset (``grid_origin``) — in the reference's
  zone or the one ODM chose (``grid_crs``); z is the altitude itself (``export_geocoords`` adds the reference's);
* into a projected map CRS the local east-north axes turn by the meridian convergence
  (:func:`grid_angle`, from ``pyproj.Proj.get_factors``: a conformal map turns them by this angle).

:class:`LocalFrame` holds one reading: local <-> lon/lat/h <-> map positions and the local -> map
axis rotations.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np


def _enu_to_ecef(lon, lat) -> np.ndarray:
    """``(n, 3, 3)`` rotations of local east-north-up axes into ECEF at ``lon, lat`` (degrees)."""
    lo, la = np.radians(np.atleast_1d(lon)), np.radians(np.atleast_1d(lat))
    so, co, sa, ca = np.sin(lo), np.cos(lo), np.sin(la), np.cos(la)
    z = np.zeros_like(lo)
    return np.stack([np.stack([-so, -sa * co, ca * co], -1), np.stack([co, -sa * so, ca * so], -1),
                     np.stack([z, ca, sa], -1)], -2)


@lru_cache(maxsize=32)
def _transformer(src, dst):
    from pyproj import Transformer
    return Transformer.from_crs(src, dst, always_xy=True)


def _apply(src, dst, *cols) -> list:
    """``Transformer(src -> dst).transform`` on 1-D arrays (one point goes through as floats: pyproj would
    convert a one-element array to a scalar, which numpy deprecates)."""
    cols = [np.asarray(c, float).ravel() for c in cols]
    if cols[0].size == 1:
        return [np.array([v]) for v in _transformer(src, dst).transform(*(float(c[0]) for c in cols))]
    return [np.asarray(v, float) for v in _transformer(src, dst).transform(*cols)]


def topocentric_to_lonlath(xyz, ref) -> np.ndarray:
    """Topocentric ``(n, 3)`` at ``ref = (lat, lon, alt)`` -> ``(n, 3)`` lon, lat (degrees), ellipsoidal h."""
    from ..crs import ecef
    lat0, lon0, h0 = ref
    e = ecef(lon0, lat0, h0)[0] + np.asarray(xyz, float).reshape(-1, 3) @ _enu_to_ecef(lon0, lat0)[0].T
    return np.column_stack(_apply(4978, 4979, e[:, 0], e[:, 1], e[:, 2]))


def lonlath_to_topocentric(llh, ref) -> np.ndarray:
    """Inverse of :func:`topocentric_to_lonlath`."""
    from ..crs import ecef
    lat0, lon0, h0 = ref
    p = np.asarray(llh, float).reshape(-1, 3)
    return (ecef(p[:, 0], p[:, 1], p[:, 2]) - ecef(lon0, lat0, h0)[0]) @ _enu_to_ecef(lon0, lat0)[0]


def grid_angle(crs, lon, lat) -> np.ndarray:
    """Angle (radians, counter-clockwise) from true east to the grid's x axis at ``lon, lat``: the
    meridian convergence, from the partial derivatives of ``pyproj.Proj.get_factors`` (a conformal map
    turns the local east-north axes by this angle)."""
    from pyproj import Proj
    f = Proj(crs).get_factors(np.atleast_1d(np.asarray(lon, float)), np.atleast_1d(np.asarray(lat, float)))
    return np.arctan2(np.asarray(f.dy_dlam, float), np.asarray(f.dx_dlam, float))


def _rz(theta) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def ecef_to_map(C, map_crs) -> tuple:
    """ECEF positions ``C`` ``(n, 3)`` in ``map_crs``: ``(positions (n, 3) with ellipsoidal heights, M (n, 3, 3))``,
    ``M`` the rotation from ECEF axes to the map's (east-north-up at each point, turned by the grid convergence), so
    that a rotation world -> camera ``R`` in ECEF is ``R·Mᵀ`` in the map."""
    C = np.asarray(C, float).reshape(-1, 3)
    lon, lat, h = _apply(4978, 4979, C[:, 0], C[:, 1], C[:, 2])
    x, y = _apply(4326, map_crs, lon, lat)
    M = _rz(grid_angle(map_crs, lon, lat)) @ np.swapaxes(_enu_to_ecef(lon, lat), 1, 2)
    return np.column_stack([x, y, h]), M


class LocalFrame:
    """One reading of an SfM local frame (OpenSfM/ODM): local <-> map positions and the local -> map axis rotations."""

    def __init__(self, kind: str, ref, map_crs, grid_crs=None, grid_origin=None):
        from ..crs import utm_crs_for
        self.kind, self.ref, self.crs = kind, tuple(float(v) for v in ref), map_crs
        self.utm = grid_crs if grid_crs is not None else utm_crs_for(self.ref[1], self.ref[0])
        self.utm0 = (np.array(_transformer(4326, self.utm).transform(self.ref[1], self.ref[0])) if grid_origin is None
                     else np.asarray(grid_origin, float))

    def to_lonlath(self, local) -> np.ndarray:
        local = np.asarray(local, float).reshape(-1, 3)
        if self.kind == "topocentric":
            return topocentric_to_lonlath(local, self.ref)
        en = self.utm0 + local[:, :2]
        lon, lat = _apply(self.utm, 4326, en[:, 0], en[:, 1])
        return np.column_stack([lon, lat, local[:, 2]])

    def from_lonlath(self, llh) -> np.ndarray:
        llh = np.asarray(llh, float).reshape(-1, 3)
        if self.kind == "topocentric":
            return lonlath_to_topocentric(llh, self.ref)
        e, n = _apply(4326, self.utm, llh[:, 0], llh[:, 1])
        return np.column_stack([e - self.utm0[0], n - self.utm0[1], llh[:, 2]])

    def to_map(self, local):
        """Map positions ``(n, 3)`` and the rotations ``M`` ``(n, 3, 3)`` with ``R_map = M·R_local``."""
        llh = self.to_lonlath(local)
        x, y = _apply(4326, self.crs, llh[:, 0], llh[:, 1])
        turn = _rz(grid_angle(self.crs, llh[:, 0], llh[:, 1]))
        if self.kind == "topocentric":
            tilt = np.swapaxes(_enu_to_ecef(llh[:, 0], llh[:, 1]), 1, 2) @ _enu_to_ecef(self.ref[1], self.ref[0])
        else:
            tilt = _rz(-grid_angle(self.utm, llh[:, 0], llh[:, 1]))
        return np.column_stack([x, y, llh[:, 2]]), turn @ tilt

    def from_map(self, xyz):
        """Inverse of :meth:`to_map`: local positions and ``M`` (``R_local = Mᵀ·R_map``)."""
        xyz = np.asarray(xyz, float).reshape(-1, 3)
        lon, lat = _apply(self.crs, 4326, xyz[:, 0], xyz[:, 1])
        local = self.from_lonlath(np.column_stack([lon, lat, xyz[:, 2]]))
        return local, self.to_map(local)[1]
