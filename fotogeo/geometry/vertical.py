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

from ..crs import is_rasterio_crs


def crs_height_reference(crs) -> str | None:
    """``"geoid"``, ``"ellipsoid"`` or None (not stated) for a CRS (pyproj/rasterio/WKT; module docstring).

    >>> crs_height_reference("EPSG:32735+3855"), crs_height_reference("EPSG:4979"), crs_height_reference("EPSG:32735")
    ('geoid', 'ellipsoid', None)
    """
    if crs is None:
        return None
    j = _unbound(crs_json(crs))
    if j["type"] == "CompoundCRS":
        return "geoid" if any(_unbound(s)["type"] == "VerticalCRS" for s in j["components"]) else None
    if j["type"] == "VerticalCRS":
        return "geoid"
    return "ellipsoid" if len(_axes(j)) == 3 else None


def horizontal_crs(crs):
    """The horizontal part of a compound CRS (the CRS itself otherwise), in the library ``crs`` came in: a rasterio
    CRS for a rasterio CRS (a DEM's, read without pyproj), else a pyproj CRS."""
    j = _unbound(crs_json(crs))
    if j["type"] != "CompoundCRS":
        return crs if is_rasterio_crs(crs) else as_pyproj(crs)
    i = next(i for i, s in enumerate(j["components"]) if _unbound(s)["type"] != "VerticalCRS")
    if is_rasterio_crs(crs):
        return type(crs).from_dict(j["components"][i])
    return as_pyproj(crs).sub_crs_list[i]


def is_projected(crs) -> bool:
    """Whether ``crs`` (its horizontal part, if compound) is a projected CRS, as pyproj's ``is_projected`` says.

    >>> is_projected("EPSG:32735+3855"), is_projected("EPSG:4326")
    (True, False)
    """
    j = _unbound(crs_json(crs))
    if j["type"] == "CompoundCRS":
        j = next(_unbound(s) for s in j["components"] if _unbound(s)["type"] != "VerticalCRS")
    return j["type"] == "ProjectedCRS"


def crs_json(crs) -> dict:
    """``crs`` as PROJJSON (PROJ's JSON of a CRS, the one description fotogeo's height and unit questions are read
    from): through rasterio (GDAL's PROJ) for a rasterio CRS, so that a run whose CRSs all come from rasters need not
    import pyproj; through pyproj otherwise."""
    if is_rasterio_crs(crs):
        return crs.to_dict(projjson=True)
    return as_pyproj(crs).to_json_dict()


def _unbound(j: dict) -> dict:
    """The source CRS of a PROJJSON bound CRS (a CRS with a transformation to WGS 84 attached), else ``j``."""
    return j["source_crs"] if j.get("type") == "BoundCRS" else j


def _axes(j: dict) -> list:
    """The axes of PROJJSON CRS ``j`` (a compound CRS's: its components', in order)."""
    if j.get("type") == "CompoundCRS":
        return [a for s in j["components"] for a in _axes(_unbound(s))]
    return (j.get("coordinate_system") or {}).get("axis") or []


def _unit_m(axis: dict) -> float:
    """The conversion factor of a PROJJSON axis's unit to the SI unit (metre, radian), 1 when unstated."""
    unit = axis.get("unit", "metre")
    if isinstance(unit, dict):
        return float(unit.get("conversion_factor", 1.0))
    return {"degree": 0.017453292519943295, "radian": 1.0}.get(unit, 1.0)


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
    j = _unbound(crs_json(crs))
    vertical = next((_unbound(s) for s in j["components"] if _unbound(s)["type"] == "VerticalCRS"), None) \
        if j["type"] == "CompoundCRS" else None
    xy_m = length_unit_m(j)
    unit = (band_unit or "").strip().lower()
    if unit in _LENGTH_UNITS:
        z_m = _LENGTH_UNITS[unit]
    elif vertical is not None and _axes(vertical):
        z_m = _unit_m(_axes(vertical)[0])
    else:
        return 1.0
    return z_m / xy_m


def length_unit_m(crs) -> float:
    """Metres per unit of the horizontal axes of ``crs`` (a CRS or its PROJJSON, :func:`crs_json`; 0.3048 for a CRS
    in feet); 1 for a geographic CRS, whose heights are metres.

    >>> length_unit_m("EPSG:32735"), round(length_unit_m("EPSG:2263"), 7), length_unit_m("EPSG:4326")
    (1.0, 0.3048006, 1.0)
    """
    j = _unbound(crs if isinstance(crs, dict) else crs_json(crs))
    if j["type"] == "CompoundCRS":
        j = next(_unbound(s) for s in j["components"] if _unbound(s)["type"] != "VerticalCRS")
    geographic = j["type"] == "GeographicCRS" or (j.get("coordinate_system") or {}).get("subtype") == "ellipsoidal"
    return 1.0 if geographic or not _axes(j) else _unit_m(_axes(j)[0])


def as_pyproj(crs):
    """``crs`` (a pyproj or rasterio CRS, or anything ``pyproj.CRS.from_user_input`` takes) as a pyproj CRS."""
    from pyproj import CRS
    return CRS.from_user_input(crs.to_wkt() if hasattr(crs, "to_wkt") and not isinstance(crs, CRS) else crs)
