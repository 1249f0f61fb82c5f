"""CRS resolution (fotogeo.crs): the automatic UTM zone, parse errors, transforms, pixel sizes."""
import math

import numpy as np
import pytest
from affine import Affine
from pyproj import CRS

from fotogeo.crs import parse_crs, pixel_size_in, resolve_crs, transform_points
from fotogeo.errors import InputError

WGS84 = CRS.from_epsg(4326)


@pytest.mark.parametrize("lon,lat,epsg", [
    (27.1, 39.9, 32635),     # Türkiye, north: zone 35N
    (18.5, -33.9, 32734),    # Cape Town, south: zone 34S
    (-58.4, -34.6, 32721),   # Buenos Aires, west and south: zone 21S
    (29.9, 10.0, 32635),     # either side of the 30° E boundary between zones 35 and 36
    (30.1, 10.0, 32636),
    (29.9, -10.0, 32735),
    (30.1, -10.0, 32736),
])
def test_auto_is_the_utm_zone_of_the_centre(lon, lat, epsg):
    assert resolve_crs("auto", WGS84, [[lon, lat]]).to_epsg() == epsg
    assert resolve_crs(None, WGS84, [lon, lat]).to_epsg() == epsg  # None and "AUTO" mean auto too
    assert resolve_crs("AUTO", WGS84, [[lon, lat]]).to_epsg() == epsg


def test_auto_from_a_projected_reference():
    """'utm' converts the centre (given in the reference CRS) to lon/lat first; 'auto' (issue 11's
    documented default) keeps a projected reference's CRS, which was UTM before."""
    # Web Mercator (3 000 000, 4 800 000) is at 26.95° E, 39.5° N
    assert resolve_crs("utm", CRS.from_epsg(3857), [[3_000_000.0, 4_800_000.0]]).to_epsg() == 32635
    assert resolve_crs("auto", CRS.from_epsg(3857), [[3_000_000.0, 4_800_000.0]]).to_epsg() == 3857
    # a point of zone 35S stays in zone 35S
    assert resolve_crs("auto", CRS.from_epsg(32735), [[400_000.0, 6_300_000.0]]).to_epsg() == 32735


def test_an_explicit_crs_is_kept():
    assert resolve_crs("EPSG:3857", WGS84, [[27.0, 39.0]]).to_epsg() == 3857
    assert resolve_crs("+proj=utm +zone=33 +datum=WGS84 +units=m +no_defs", WGS84, [[27.0, 39.0]]).to_epsg() == 32633
    assert parse_crs(CRS.from_epsg(32735).to_wkt()).to_epsg() == 32735
    assert parse_crs(32735).to_epsg() == 32735


@pytest.mark.parametrize("spec", ["EPSG:99999", "foo", "+proj=nonsense", "", 12.5, None, "GEOGCS[" + "x" * 500])
def test_parse_errors_are_one_line_input_errors_naming_the_input(spec):
    with pytest.raises(InputError) as e:
        parse_crs(spec, "reference CRS")
    msg = str(e.value)
    assert "\n" not in msg and len(msg) < 400, msg  # one line, long WKT cut short
    assert msg.startswith("reference CRS ") and repr(str(spec)[:80]) in msg
    assert "EPSG:" in msg  # the fix: what to give instead


def test_resolve_crs_names_the_option_in_its_error():
    with pytest.raises(InputError, match=r"^output CRS \(or 'auto'\) 'EPSG:99999'"):
        resolve_crs("EPSG:99999", WGS84, [[27.0, 39.0]])


def test_transform_points_is_the_identity_between_equal_crss():
    p = np.array([[500_000.123456789, 4_420_000.987654321], [1e-9, -1e9]])
    out = transform_points(CRS.from_epsg(32635), "EPSG:32635", p)  # equal CRSs given two ways
    assert np.array_equal(out, p) and out is not p
    out[0, 0] = 0.0
    assert p[0, 0] == 500_000.123456789  # a copy: the input is untouched
    # a real transform round-trips to well under a millimetre
    ll = transform_points(CRS.from_epsg(32635), WGS84, p[:1])
    assert ll[0, 0] == pytest.approx(27.0, abs=0.1) and ll[0, 1] == pytest.approx(39.9, abs=0.1)
    np.testing.assert_allclose(transform_points(WGS84, CRS.from_epsg(32635), ll), p[:1], atol=1e-4)


def test_pixel_size_in_the_same_crs_is_the_pixel_side():
    assert pixel_size_in(Affine(10.0, 0, 5e5, 0, -10.0, 4.4e6), "EPSG:32635", "EPSG:32635", 3, 7) == 10.0
    # a rotated, rectangular pixel: the side of the square of equal area, sqrt(|det|)
    t = Affine.translation(5e5, 4.4e6) * Affine.rotation(30.0) * Affine.scale(4.0, -9.0)
    assert pixel_size_in(t, "EPSG:32635", "EPSG:32635", 0, 0) == pytest.approx(6.0, rel=1e-9)  # 4e6 m offsets


def test_pixel_size_of_a_geographic_raster_in_utm_against_a_hand_computation():
    """A 0.0001° pixel at 40° N on zone 35's central meridian (27° E). On the WGS 84
    ellipsoid its sides are M·dφ and N·cosφ·dλ (meridian and prime-vertical radii of
    curvature); UTM scales both by k0 = 0.9996 on the central meridian."""
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    phi = math.radians(40.0)
    w = 1 - e2 * math.sin(phi) ** 2
    M, N = a * (1 - e2) / w ** 1.5, a / math.sqrt(w)
    d = math.radians(1e-4)
    expected = 0.9996 * math.sqrt(M * d * N * math.cos(phi) * d)  # about 9.7 m
    # the pixel (0, 0) spans 27.0..27.0001° E and 40.0001..40.0° N
    t = Affine(1e-4, 0, 27.0, 0, -1e-4, 40.0001)
    got = pixel_size_in(t, WGS84, CRS.from_epsg(32635), 0, 0)
    assert got == pytest.approx(expected, rel=2e-5), (got, expected)
    # the other way round: a 10 m UTM pixel measured in degrees is a (tiny) number of degrees
    deg = pixel_size_in(Affine(10.0, 0, 5e5, 0, -10.0, 4.43e6), CRS.from_epsg(32635), WGS84, 0, 0)
    assert 1e-4 < deg < 1.3e-4


@pytest.mark.parametrize("crs, lon, lat", [("EPSG:3857", (-5.0, 8.0), (40.0, 48.0)),
                                           ("EPSG:3031", (-180.0, 180.0), (-89.0, -65.0)),
                                           ("EPSG:32631+5773", (0.0, 6.0), (40.0, 50.0))])
def test_one_route_to_earth_centred(crs, lon, lat):
    """``crs.ecef`` (the one formula of Earth-centred coordinates, ``geometry.local_frames`` uses it) is pyproj's
    EPSG:4979 -> EPSG:4978, and ``crs.geocentric`` of points in a projected, polar or compound CRS is it."""
    from pyproj import Transformer
    from fotogeo.crs import ecef, geocentric
    rng = np.random.default_rng(3)
    ll = np.column_stack([rng.uniform(*lon, 50), rng.uniform(*lat, 50)])
    h = rng.uniform(-100.0, 4000.0, 50)
    want = np.column_stack(Transformer.from_crs(4979, 4978, always_xy=True).transform(ll[:, 0], ll[:, 1], h))
    np.testing.assert_allclose(ecef(ll[:, 0], ll[:, 1], h), want, rtol=0, atol=1e-6)
    xy = transform_points("EPSG:4326", crs, ll)
    np.testing.assert_allclose(geocentric(crs, np.column_stack([xy, h])), want, rtol=0, atol=1e-6)
