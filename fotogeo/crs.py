"""CRS helpers: the automatic UTM zone, transformers, and pixel sizes across CRSs.

pyproj parses, compares and transforms CRSs; it is imported by the functions that need it, not with this module: a
run whose CRSs all come from rasters (``fotogeo ortho`` of frames on a DEM) holds them as rasterio's and, when two of
them have the same WKT, needs no pyproj at all (:func:`same_crs`; the DEM's vertical part is read from PROJJSON,
:func:`fotogeo.geometry.vertical.crs_json`).
"""
from __future__ import annotations

import warnings

import numpy as np

from .errors import InputError


def parse_crs(spec, what: str = "CRS") -> CRS:
    """A :class:`pyproj.CRS` from an EPSG code, WKT, PROJ string or CRS object; a clear
    :class:`InputError` naming ``what`` otherwise (the one CRS parser of fotogeo).

    >>> parse_crs("EPSG:32635").to_epsg()
    32635
    >>> parse_crs("EPSG:99999", "output CRS")
    Traceback (most recent call last):
    fotogeo.errors.InputError: output CRS 'EPSG:99999' is not a CRS pyproj understands (...); give an EPSG code ...
    """
    from pyproj import CRS
    from pyproj.exceptions import CRSError
    try:
        return CRS.from_user_input(spec)
    except (CRSError, TypeError, ValueError) as e:
        raise InputError(f"{what} {str(spec)[:80]!r} is not a CRS pyproj understands ({str(e)[:120]}); "
                         f"give an EPSG code such as EPSG:32735, a WKT or a PROJ string") from None


def utm_crs_for(lon: float, lat: float) -> CRS:
    """The WGS 84 UTM zone CRS containing (lon, lat) (EPSG 326zz north, 327zz south).

    >>> utm_crs_for(27.1, 39.9).to_epsg(), utm_crs_for(18.5, -33.9).to_epsg()
    (32635, 32734)
    """
    from pyproj import CRS
    from pyproj.aoi import AreaOfInterest
    from pyproj.database import query_utm_crs_info
    infos = query_utm_crs_info(datum_name="WGS 84",
                               area_of_interest=AreaOfInterest(lon, lat, lon, lat))
    infos = [i for i in infos if i.code.startswith(("326", "327"))]
    if infos:
        return CRS.from_epsg(int(infos[0].code))
    zone = int((lon + 180.0) // 6.0) % 60 + 1
    return CRS.from_epsg((32600 if lat >= 0 else 32700) + zone)


def _transform(t: Transformer, p: np.ndarray) -> np.ndarray:
    """``t`` applied to (N, 2) points; one point goes through as floats (pyproj would convert a
    one-element array to a scalar, which numpy deprecates)."""
    if len(p) == 1:
        return np.array([t.transform(float(p[0, 0]), float(p[0, 1]))], float)
    return np.column_stack(t.transform(p[:, 0], p[:, 1]))


def to_lonlat(crs: CRS, xy) -> np.ndarray:
    """Geographic (lon, lat) of points given in ``crs``."""
    from pyproj import CRS, Transformer
    t = Transformer.from_crs(crs, CRS.from_epsg(4326), always_xy=True)
    return _transform(t, np.asarray(xy, float).reshape(-1, 2))


def ecef(lon, lat, h, ellipsoid=None) -> np.ndarray:
    """Earth-centred Cartesian ``(N, 3)`` (metres) of longitudes, latitudes (degrees) and heights above
    ``ellipsoid`` (pyproj's; WGS 84 when None, EPSG:4979 -> EPSG:4978): ``X = (N + h) cos φ cos λ``,
    ``Y = (N + h) cos φ sin λ``, ``Z = (N (1 − e²) + h) sin φ``, ``N = a / √(1 − e² sin² φ)``.

    >>> ecef([0.0, 90.0], [0.0, 0.0], [0.0, 10.0]).round(3).tolist()
    [[6378137.0, 0.0, 0.0], [0.0, 6378147.0, 0.0]]
    """
    a, inv_f = (6378137.0, 298.257223563) if ellipsoid is None else (ellipsoid.semi_major_metre,
                                                                     ellipsoid.inverse_flattening)
    e2 = 0.0 if not inv_f else (2.0 - 1.0 / inv_f) / inv_f
    lon, lat = np.radians(np.asarray(lon, float).ravel()), np.radians(np.asarray(lat, float).ravel())
    h = np.asarray(h, float).ravel()
    n = a / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
    return np.column_stack([(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                            (n * (1.0 - e2) + h) * np.sin(lat)])


def geocentric(crs, points) -> np.ndarray:
    """Earth-centred Cartesian ``(N, 3)`` (metres) of points ``(N, 3)``: x, y in ``crs`` (pyproj's or rasterio's),
    the height above its ellipsoid, by :func:`ecef` on the CRS's own ellipsoid: distances and angles measured there
    do not depend on the map projection (its scale and the heights' unlike metric)."""
    from pyproj import CRS
    c = CRS.from_user_input(crs)
    g = c.geodetic_crs
    p = np.asarray(points, float).reshape(-1, 3)
    lon, lat = transform_points(c, g, p[:, :2]).T
    return ecef(lon, lat, p[:, 2], g.ellipsoid)


#: the words an output CRS may be given as, besides any CRS pyproj understands
CRS_RULES = ("auto", "reference", "utm")


def choose_output_crs(spec, reference_crs: CRS, centre_xy) -> tuple[CRS, str]:
    """The output CRS for a user ``spec`` and the sentence saying why it was chosen.

    - ``"auto"`` (or None, the default): the reference's CRS when it is projected (a GIS user's
      expectation: the output overlays the reference pixel for pixel), else — a geographic
      reference — the UTM zone of the reference centre ``centre_xy`` (given in ``reference_crs``);
    - ``"reference"``: the reference's CRS (refused later if it is geographic);
    - ``"utm"``: always the WGS 84 UTM zone of the reference centre (the rule of Dihkan (2019),
      whose reference orthophotos are UTM);
    - anything else: an EPSG code, WKT or PROJ string (:func:`parse_crs`).

    >>> from pyproj import CRS
    >>> lo25 = CRS.from_proj4("+proj=tmerc +lon_0=25 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m")
    >>> crs, why = choose_output_crs("auto", lo25, [[20000.0, -3700000.0]])
    >>> crs == lo25, why
    (True, "auto: the reference's CRS (it is projected)")
    >>> crs, why = choose_output_crs("utm", lo25, [[20000.0, -3700000.0]])
    >>> crs.to_epsg(), why
    (32735, 'utm: the UTM zone of the reference centre')
    >>> choose_output_crs(None, CRS.from_epsg(4326), [[27.1, 39.9]])[0].to_epsg()
    32635
    """
    from pyproj import CRS
    word = "auto" if spec is None else str(spec).strip().lower()
    ref = CRS.from_user_input(reference_crs)
    if word == "reference" or (word == "auto" and not (ref.is_geographic or ref.is_geocentric)):
        return ref, f"{word}: the reference's CRS" + (" (it is projected)" if word == "auto" else "")
    if word in ("auto", "utm"):
        lon, lat = to_lonlat(ref, centre_xy)[0]
        why = "the UTM zone of the reference centre" + (" (the reference's CRS is not projected)"
                                                          if word == "auto" else "")
        return utm_crs_for(float(lon), float(lat)), f"{word}: {why}"
    try:
        return parse_crs(spec, "output CRS (or 'auto')"), "given"
    except InputError as e:
        raise InputError(f"{e}, or one of the words {', '.join(CRS_RULES)}") from None


def resolve_crs(spec, reference_crs: CRS, centre_xy) -> CRS:
    """Output CRS from a user spec (:func:`choose_output_crs` without the reason)."""
    return choose_output_crs(spec, reference_crs, centre_xy)[0]


def transform_points(src_crs: CRS, dst_crs: CRS, xy) -> np.ndarray:
    """Transform (N, 2) points between CRSs (x = easting/longitude first)."""
    p = np.asarray(xy, float).reshape(-1, 2)
    if same_crs(src_crs, dst_crs):
        return p.copy()
    return _transform(transformer(src_crs, dst_crs), p)


def transformer(src_crs, dst_crs):
    """pyproj's ``Transformer`` from ``src_crs`` to ``dst_crs`` (pyproj or rasterio CRSs or what pyproj parses;
    x = easting/longitude first), made once per pair of CRSs in a process (keyed by their WKT): finding the operation
    in PROJ's database is what costs, and a run of ``ortho`` over a DEM in another CRS asks for the same one more
    than once. The operation found is kept as its PROJ pipeline (:func:`_as_pipeline`). (pyproj's transformers are
    thread-safe since pyproj 3.1.)"""
    from pyproj import CRS, Transformer
    src, dst = (CRS.from_user_input(c) for c in (src_crs, dst_crs))  # (a rasterio CRS through its WKT)
    key = (src.to_wkt(), dst.to_wkt())
    if None in key:
        return _as_pipeline(Transformer.from_crs(src, dst, always_xy=True))
    if key not in _TRANSFORMERS:
        if len(_TRANSFORMERS) >= 16:
            _TRANSFORMERS.clear()
        _TRANSFORMERS[key] = _as_pipeline(Transformer.from_crs(src, dst, always_xy=True))
    return _TRANSFORMERS[key]


def _as_pipeline(t):
    """The pyproj transformer ``t`` rebuilt from the PROJ pipeline of the one operation it chose (the string PROJ
    itself runs: the same coordinates bit for bit), or ``t`` when it holds several operations chosen point by point
    (no single pipeline). pyproj makes a transformer again in every thread that first uses it (a thread-local
    copy): from ``Transformer.from_crs`` that repeats the search of PROJ's database for the operation, from a
    pipeline it only parses the string — :func:`fotogeo.io.warp.warp_to_grid`'s worker threads transform through
    the DEM sampler's transformer (:class:`fotogeo.geometry.dem.DemSampler`)."""
    from pyproj import Transformer
    pipeline = t.to_proj4()
    return Transformer.from_pipeline(pipeline) if pipeline else t


#: :func:`transformer`'s transformers by the WKT of their CRSs
_TRANSFORMERS: dict = {}


def pixel_size_in(transform, src_crs: CRS, dst_crs: CRS, col: float, row: float) -> float:
    """Side of a square with the area of pixel (col, row) of a raster, measured in ``dst_crs`` units."""
    from .pixels import pixel_to_map
    corners = pixel_to_map(transform, [[col, row], [col + 1, row], [col, row + 1]])
    c = transform_points(src_crs, dst_crs, corners)
    u, v = c[1] - c[0], c[2] - c[0]
    return float(np.sqrt(abs(u[0] * v[1] - u[1] * v[0])))


def same_crs(a, b) -> bool:
    """Whether CRSs ``a`` and ``b`` (pyproj, rasterio, or anything :func:`parse_crs` takes) are the same, as pyproj's
    ``==`` says; two rasterio CRSs with the same WKT are without asking pyproj (the same text parses to the same CRS).

    >>> from pyproj import CRS
    >>> same_crs("EPSG:32735", CRS.from_epsg(32735)), same_crs("EPSG:32735", "EPSG:32635")
    (True, False)
    """
    if a is b or (is_rasterio_crs(a) and is_rasterio_crs(b) and a.to_wkt() == b.to_wkt()):
        return True
    from pyproj import CRS
    return CRS.from_user_input(a) == CRS.from_user_input(b)


def crs_name(crs) -> str:
    """The name of ``crs`` (pyproj's ``CRS.name``; a rasterio CRS's from its PROJJSON, which is what pyproj reads it
    from, without importing pyproj)."""
    if is_rasterio_crs(crs):
        j = crs.to_dict(projjson=True)
        return j.get("name", j.get("source_crs", {}).get("name", ""))  # a bound CRS: its source's
    from pyproj import CRS
    return CRS.from_user_input(crs).name


def is_rasterio_crs(crs) -> bool:
    """Whether ``crs`` is a rasterio CRS (GDAL's parse; a raster's CRS as fotogeo keeps it when no pyproj is needed)."""
    return type(crs).__module__.startswith("rasterio")


def _name(crs: CRS) -> str:
    """A short name of ``crs`` for messages (its EPSG code or name, never a whole WKT)."""
    from pyproj import CRS
    crs = CRS.from_user_input(crs)
    epsg = crs.to_epsg()
    return f"EPSG:{epsg}" if epsg else repr(crs.name[:60])


def crs_text(crs: CRS) -> str:
    """``crs.to_string()`` (its authority code, else its PROJ string) without pyproj's warning that a PROJ
    string loses details: the WKT goes beside it wherever the CRS must be exact."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return crs.to_string()


def short_name(crs: CRS) -> str:
    """``crs`` in one short phrase for summaries: its EPSG code, else its name, else its PROJ string.

    >>> from pyproj import CRS
    >>> short_name(CRS.from_epsg(32735))
    'EPSG:32735'
    >>> short_name(CRS.from_proj4("+proj=tmerc +lon_0=25 +ellps=WGS84 +units=m"))[:26]
    '+proj=tmerc +lat_0=0 +lon_'
    """
    from pyproj import CRS
    crs = CRS.from_user_input(crs)  # a rasterio CRS (fotogeo.crs) named as pyproj names it
    epsg = crs.to_epsg()
    if epsg:
        return f"EPSG:{epsg}"
    if crs.name and crs.name.lower() not in ("unnamed", "unknown", "undefined"):
        return crs.name[:80]
    with warnings.catch_warnings():  # pyproj warns that a PROJ string loses details: here it only names the CRS
        warnings.simplefilter("ignore")
        return (crs.to_proj4() or "")[:120]


def require_planar(crs: CRS, what: str) -> CRS:
    """Refuse a geocentric CRS (X, Y, Z from the Earth's centre: not a map) for ``what``.

    >>> from pyproj import CRS
    >>> require_planar(CRS.from_epsg(4978), "GCP CRS")
    Traceback (most recent call last):
    fotogeo.errors.InputError: GCP CRS EPSG:4978 is geocentric (X, Y, Z from the Earth's centre), not a map; ...
    """
    if crs.is_geocentric:
        raise InputError(f"{what} {_name(crs)} is geocentric (X, Y, Z from the Earth's centre), not a map; "
                         f"use a projected CRS such as the UTM zone of the area (e.g. EPSG:32635)")
    return crs


def require_projected(crs: CRS, what: str, near_lonlat=None, choice: str | None = "'auto'") -> CRS:
    """Refuse a geocentric or geographic CRS for ``what``, an output measured in metres (a
    geographic CRS would report degrees as metres); the message suggests the UTM zone of
    ``near_lonlat`` when given, and ``choice``: the caller's words for the other choice that works for its
    inputs (its automatic one, by default; None when there is none to name, so that the hint never sends the
    user to a choice that fails).

    >>> from pyproj import CRS
    >>> require_projected(CRS.from_epsg(4326), "output CRS", (27.1, 39.9))
    Traceback (most recent call last):
    fotogeo.errors.InputError: output CRS EPSG:4326 is geographic (degrees); fotogeo's residuals, resolution ...
    """
    require_planar(crs, what)
    if crs.is_geographic:
        named = ([f"EPSG:{utm_crs_for(*near_lonlat).to_epsg()}, the UTM zone of the area"] if near_lonlat else []) + (
            [choice] if choice else [])
        raise InputError(f"{what} {_name(crs)} is geographic (degrees); fotogeo's residuals, resolution and "
                         f"RMSE are in metres: use a projected CRS" + (f" ({', or '.join(named)})" if named else ""))
    return crs


def check_lonlat_range(crs: CRS, xy, what: str):
    """Refuse points labelled with a geographic ``crs`` whose coordinates cannot be degrees
    (|lon| > 360 or |lat| > 90): metres labelled as EPSG:4326, a wrong CRS in the file.

    >>> from pyproj import CRS
    >>> check_lonlat_range(CRS.from_epsg(4326), [[500000.0, 4420000.0]], "GCPs 'g.csv'")
    Traceback (most recent call last):
    fotogeo.errors.InputError: GCPs 'g.csv' are labelled EPSG:4326 (degrees) but their coordinates reach ...
    """
    if not crs.is_geographic:
        return
    p = np.asarray(xy, float).reshape(-1, 2)
    p = p[np.isfinite(p).all(axis=1)]
    if len(p) and (np.abs(p[:, 0]).max() > 360 or np.abs(p[:, 1]).max() > 90):
        raise InputError(f"{what} are labelled {_name(crs)} (degrees) but their coordinates reach "
                         f"({np.abs(p[:, 0]).max():.6g}, {np.abs(p[:, 1]).max():.6g}), which are not longitudes and "
                         f"latitudes — probably metres: give their real CRS (e.g. the UTM zone, EPSG:326zz)")


def area_of_use(crs: CRS):
    """pyproj's ``AreaOfUse`` of ``crs`` (west, south, east, north in degrees), that of its EPSG code when its WKT
    carries none (a GeoTIFF's often does not), else None."""
    from pyproj import CRS
    if crs.area_of_use is not None:
        return crs.area_of_use
    epsg = crs.to_epsg()
    return CRS.from_epsg(epsg).area_of_use if epsg else None


def outside_area_of_use(crs: CRS, points, margin_deg: float = 0.0, *, lonlat: bool = False) -> np.ndarray:
    """Boolean mask of the ``points`` ``(N, 2)`` (in ``crs``, or longitude/latitude when ``lonlat``) outside the
    area of use of ``crs`` (:func:`area_of_use`) widened by ``margin_deg`` degrees on every side — the one test of
    "are these coordinates in this CRS at all". Longitudes are compared modulo 360° (an area across the
    antimeridian has west > east); a point that does not transform (NaN, infinite) is outside; with no known area
    only such points are.

    >>> from pyproj import CRS
    >>> outside_area_of_use(CRS.from_epsg(32633), [[500000.0, 6650000.0], [-5e6, 6650000.0]]).tolist()
    [False, True]
    """
    p = np.asarray(points, float).reshape(-1, 2)
    with np.errstate(all="ignore"):
        lon, lat = (p if lonlat else to_lonlat(crs, p)).T
    finite = np.isfinite(lon) & np.isfinite(lat)
    aou = area_of_use(crs)
    if aou is None:
        return ~finite
    w, s, e, n = aou.bounds
    east = e - w if e >= w else e - w + 360.0  # the area's width eastwards from w
    from_w = (lon - (w - margin_deg)) % 360.0  # degrees eastwards from the widened west edge
    with np.errstate(invalid="ignore"):
        inside = finite & (from_w <= east + 2 * margin_deg) & (lat >= s - margin_deg) & (lat <= n + margin_deg)
    return ~inside


def crs_summary(text: str) -> str:
    """A CRS given as text (WKT, EPSG code …) in one short phrase for reports (:func:`short_name`; never a
    whole WKT); the text's first 60 characters when it does not parse."""
    try:
        return short_name(parse_crs(text, "CRS"))
    except Exception:  # noqa: BLE001 - a summary, never a failure
        return str(text)[:60]
