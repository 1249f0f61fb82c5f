"""Height references: which surface a DEM's heights are measured from, and the geoid shift.

Two references matter to orthorectification (:data:`~fotogeo.geometry.approx_block.HEIGHT_REFERENCES`):

* ``"ellipsoid"`` — ellipsoidal heights ``h`` (GNSS, RPC00B: vendor RPCs are fitted in WGS 84 ``h``);
* ``"geoid"`` — orthometric (gravity-related) heights ``H`` above a geoid model (EGM96, EGM2008, national
  height systems): most DEMs and aerial-triangulation blocks.

They differ by the geoid undulation ``N``: ``h = H + N`` (N is tens of metres: about +30 m in South
Africa, so an RPC image orthorectified on an orthometric DEM without the shift is displaced by
``30 m · tan(off-nadir angle)``).

:func:`crs_height_reference` reads what a raster's CRS says: a compound CRS whose vertical part is a
vertical CRS (``VERTCRS``) holds gravity-related heights; a 3-D geographic/projected CRS holds
ellipsoidal heights; a 2-D CRS says nothing (None). :class:`ShiftedHeights` adds ``N`` (a raster of
undulations, e.g. PROJ's ``egm96_15.gtx``) to a height source's ``H``.
"""
from __future__ import annotations

import numpy as np


def crs_height_reference(crs) -> str | None:
    """``"geoid"``, ``"ellipsoid"`` or None (not stated) for a CRS (pyproj/rasterio/WKT; module docstring).

    >>> crs_height_reference("EPSG:32735+3855"), crs_height_reference("EPSG:4979"), crs_height_reference("EPSG:32735")
    ('geoid', 'ellipsoid', None)
    """
    if crs is None:
        return None
    c = as_pyproj(crs)
    if c.is_compound:
        return "geoid" if any(s.is_vertical for s in c.sub_crs_list) else None
    if c.is_vertical:
        return "geoid"
    return "ellipsoid" if len(c.axis_info) == 3 else None


def horizontal_crs(crs):
    """The horizontal part of a compound CRS (the CRS itself otherwise), as a pyproj CRS."""
    c = as_pyproj(crs)
    if c.is_compound:
        return next(s for s in c.sub_crs_list if not s.is_vertical)
    return c


class ShiftedHeights:
    """``heights(XY) = source.heights(XY) + undulation.heights(XY)``: orthometric DEM heights made
    ellipsoidal with a geoid raster (both height sources queried at the same map points)."""

    def __init__(self, source, undulation):
        self.source, self.undulation = source, undulation
        lo, hi = source.z_range
        nlo, nhi = undulation.z_range
        self.z_range = (lo + nlo, hi + nhi)

    def heights(self, XY) -> np.ndarray:
        return np.asarray(self.source.heights(XY), float) + np.asarray(self.undulation.heights(XY), float)

    def heights_and_gradient(self, XY):
        h, gx, gy = self.source.heights_and_gradient(XY)
        n, nx, ny = self.undulation.heights_and_gradient(XY)
        return h + n, gx + nx, gy + ny


#: metres per unit of the length units GDAL writes as a band's unit type (``gdalinfo``'s "Unit Type";
#: lower case, "us survey foot" = 1200/3937 m exactly)
_LENGTH_UNITS = {
    "m": 1.0, "metre": 1.0, "meter": 1.0, "metres": 1.0, "meters": 1.0,
    "ft": 0.3048, "foot": 0.3048, "feet": 0.3048, "international foot": 0.3048,
    "us-ft": 1200 / 3937, "ftus": 1200 / 3937, "us survey foot": 1200 / 3937, "us_survey_foot": 1200 / 3937,
    "foot_us": 1200 / 3937, "survey foot": 1200 / 3937, "cm": 0.01, "mm": 0.001, "km": 1000.0,
}


def height_scale(crs, band_unit: str | None, source: str = "DEM") -> float:
    """The factor that brings a DEM's heights into the length unit of its horizontal CRS.

    The camera models compute in one length unit, the map CRS's (metres for a geographic CRS; an RPC's
    heights are metres), so a height stated in another unit is converted:
    ``h = z · m(height unit) / m(horizontal unit)`` (``m`` = metres per unit). The height unit is the band's
    unit type when it names a length (GDAL ``SetUnitType``: ``ft``, ``US survey foot``, ``m`` …), else the
    vertical axis of a compound CRS; neither stated: the horizontal unit (factor 1, the DEM taken as it is).
    A 24 m DEM in a metric CRS whose band says ``ft`` thus gets ``0.3048``; a US State Plane (ftUS) DEM with
    heights in ``ftUS``, ``1``.

    >>> height_scale("EPSG:32735", "ft"), height_scale("EPSG:32735", "metre"), height_scale("EPSG:32735", "")
    (0.3048, 1.0, 1.0)
    """
    if crs is None:
        return 1.0
    c = as_pyproj(crs)
    vertical = next((s for s in c.sub_crs_list if s.is_vertical), None) if c.is_compound else None
    xy_m = length_unit_m(c)
    unit = (band_unit or "").strip().lower()
    if unit in _LENGTH_UNITS:
        z_m = _LENGTH_UNITS[unit]
    elif vertical is not None and vertical.axis_info:
        z_m = float(vertical.axis_info[0].unit_conversion_factor)
    else:
        return 1.0
    return z_m / xy_m


def length_unit_m(crs) -> float:
    """Metres per unit of the horizontal axes of ``crs`` (0.3048 for a CRS in feet); 1 for a geographic CRS, whose
    heights are metres.

    >>> length_unit_m("EPSG:32735"), round(length_unit_m("EPSG:2263"), 7), length_unit_m("EPSG:4326")
    (1.0, 0.3048006, 1.0)
    """
    c = as_pyproj(crs)
    h = horizontal_crs(c)
    return 1.0 if h.is_geographic or not h.axis_info else float(h.axis_info[0].unit_conversion_factor)


def as_pyproj(crs):
    """``crs`` (a pyproj or rasterio CRS, or anything ``pyproj.CRS.from_user_input`` takes) as a pyproj CRS."""
    from pyproj import CRS
    return CRS.from_user_input(crs.to_wkt() if hasattr(crs, "to_wkt") and not isinstance(crs, CRS) else crs)
