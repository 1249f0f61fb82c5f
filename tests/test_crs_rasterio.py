"""A CRS held as rasterio's (GDAL's parse: what ``fotogeo ortho`` keeps from its DEM so that a run needs no pyproj)
gets the answers pyproj's attributes give for the same CRS: height reference, horizontal part, projected or not,
length units, height scale, name and equality (one CRS mechanism, whichever library holds the CRS)."""
from __future__ import annotations

import pytest
from pyproj import CRS
from rasterio.crs import CRS as RioCRS

from fotogeo.crs import crs_name, same_crs, short_name, transform_points
from fotogeo.geometry.vertical import (crs_height_reference, height_scale, horizontal_crs, is_projected,
                                       length_unit_m)

#: compound (metres; US feet over a ftUS State Plane), 3-D geographic, projected in feet, geographic, geocentric,
#: bound (a TOWGS84 transformation attached), a vertical CRS alone, and a compound CRS of a DEM without an EPSG code
CASES = ["EPSG:32735+3855", "EPSG:2263+6360", "EPSG:4979", "EPSG:2263", "EPSG:4326", "EPSG:4978",
         "+proj=utm +zone=35 +south +ellps=WGS84 +towgs84=0,0,0 +units=m +type=crs", "EPSG:3855",
         'COMPOUNDCRS["Lo25 + EGM2008",PROJCRS["Lo25",BASEGEOGCRS["WGS 84",DATUM["World Geodetic System 1984",'
         'ELLIPSOID["WGS 84",6378137,298.257223563]]],CONVERSION["tm",METHOD["Transverse Mercator",ID["EPSG",9807]],'
         'PARAMETER["Longitude of natural origin",25,ANGLEUNIT["degree",0.0174532925199433]]],'
         'CS[Cartesian,2],AXIS["y",west,LENGTHUNIT["metre",1]],AXIS["x",south,LENGTHUNIT["metre",1]]],'
         'VERTCRS["EGM2008 height",VDATUM["EGM2008 geoid"],CS[vertical,1],AXIS["up",up,LENGTHUNIT["foot",0.3048]]]]']


def _old_reference(c: CRS):
    """pyproj's attributes as fotogeo read them before (the reference the PROJJSON answers must equal)."""
    if c.is_compound:
        return "geoid" if any(s.is_vertical for s in c.sub_crs_list) else None
    if c.is_vertical:
        return "geoid"
    return "ellipsoid" if len(c.axis_info) == 3 else None


@pytest.mark.parametrize("spec", CASES)
def test_rasterio_and_pyproj_crs_give_pyprojs_answers(spec):
    p = CRS.from_user_input(spec)
    r = RioCRS.from_wkt(p.to_wkt())
    h = next(s for s in p.sub_crs_list if not s.is_vertical) if p.is_compound else p
    unit = 1.0 if h.is_geographic or not h.axis_info else h.axis_info[0].unit_conversion_factor
    for c in (p, r):
        assert crs_height_reference(c) == _old_reference(p)
        assert is_projected(c) == h.is_projected
        assert length_unit_m(c) == pytest.approx(unit, rel=1e-12)
        if p.is_compound or not p.is_vertical:  # (pyproj calls a compound CRS vertical too)
            assert CRS.from_user_input(horizontal_crs(c)) == h
        assert crs_name(c) == p.name
    assert type(horizontal_crs(r)) is RioCRS  # no pyproj object where the CRS came in as rasterio's
    if p.is_compound:  # the vertical axis's unit when the band states none
        v = next(s for s in p.sub_crs_list if s.is_vertical)
        assert height_scale(r, None) == pytest.approx(v.axis_info[0].unit_conversion_factor / unit, rel=1e-12)


def test_same_crs_is_pyprojs_equality():
    a, b = RioCRS.from_epsg(32735), RioCRS.from_wkt(CRS.from_epsg(32735).to_wkt())
    assert a.to_wkt() != b.to_wkt() and same_crs(a, b)  # other text, the same CRS: pyproj decides
    assert same_crs(a, RioCRS.from_epsg(32735)) and not same_crs(a, RioCRS.from_epsg(32635))
    assert not same_crs(RioCRS.from_user_input("EPSG:32735+3855"), a)  # compound is not its horizontal part
    assert transform_points(a, "EPSG:32635", [[500000.0, 7000000.0]])[0, 1] == pytest.approx(-3000000.0)
    assert short_name(a) == "EPSG:32735"
