"""The images' EXIF/XMP facts (:mod:`fotogeo.io.exif`) -> an :class:`ApproximateBlock`.

Read through GDAL only (rasterio): EXIF tags are the ``EXIF_*`` metadata items (rationals as
``"(37) (32) (41.5838)"``, bytes as ``"0x01"``), XMP is the one string of the ``xml:XMP`` domain,
parsed with :mod:`xml.etree` (values as attributes or elements, ``rdf:Seq`` lists joined by
commas). An XMP packet that does not parse is ignored with a :class:`FotogeoWarning` naming the
file. :func:`read_image_metadata` returns the raw facts of one image (:class:`ImageMetadata`);
:func:`read_exif_block` turns a list of images into the block.

**Position**: EXIF ``GPSLatitude/Longitude`` with their N/S/E/W refs (else DJI's XMP
``GpsLatitude/GpsLongitude``; 0°, 0° is read as no fix); Z = DJI's ``AbsoluteAltitude`` when
present, else EXIF ``GPSAltitude``, negated when ``GPSAltitudeRef`` is 1 ("below sea level"; the
value itself is unsigned). Its **height reference** per vendor (:func:`height_reference`):
senseFly = ellipsoid (eBee RTK user manual 2014 §5.1; on the snowpeak images EXIF ``GPSAltitude``
equals geoinfo's ``altitude_wgs84``); DJI with RTK tags = ellipsoid (Zenmuse P1 and Mavic 3
manuals: ``AbsoluteAltitude`` is the "geodetic height"; DJI support: RTK aircraft write
ellipsoidal heights); DJI without RTK and every other vendor = unknown (``None``; DJI support:
non-RTK aircraft write a barometric altitude). σ of the position: DJI ``RtkStdLon/Lat/Hgt``
(σ_h = RMS of the two horizontal axes), senseFly / Pix4D ``GPSXYAccuracy`` / ``GPSZAccuracy``.

**Attitude** (:mod:`fotogeo.geometry.attitude`), in this order: a gimbal's own angles (DJI
``drone-dji:Gimbal{Yaw,Pitch,Roll}Degree``: NED, ZYX, pitch −90 = nadir, :func:`rotation_from_ypr`;
Parrot ``drone-parrot:Camera{Yaw,Pitch,Roll}Degree`` is *assumed* to follow DJI's convention, not
checked against Parrot's documentation); a senseFly ``geoinfo.txt`` when given; an aircraft body's
angles in XMP (Pix4D/MicaSense ``Camera:Yaw/Pitch/Roll``, senseFly ``sensefly:Yaw/Pitch/Roll``,
pitch 0 = nadir: :func:`rotation_from_body_ypr`); else unknown. Yaw is taken from true north.

**Camera** (focal length in pixels; the first source present wins): DJI ``DewarpData``
(``"date;fx,fy,cx,cy,k1,k2,p1,p2,k3"``, cx, cy offsets of the principal point from the image
centre in pixels, OpenCV's Brown model — DJI Mavic 3M/Matrice 4 manuals; with ``DewarpFlag`` 1 the
image is already undistorted and the k, p are not used); DJI ``CalibratedFocalLength`` (px) and
``CalibratedOpticalCenterX/Y`` (px, taken in the corner convention: DJI writes w/2, h/2); Pix4D
``Camera:PerspectiveFocalLength`` (mm) over the pixel pitch; EXIF ``FocalLength`` over the pixel
pitch from ``FocalPlaneXResolution`` (unit ``FocalPlaneResolutionUnit``: 2 inch — the EXIF
default —, 3 cm, 4 mm, 5 µm; square pixels); ``FocalLengthIn35mmFilm``, defined on the diagonal:
``f_px = f35 · hypot(w, h) / 43.27`` (43.27 mm = the 36×24 mm diagonal). The calibrations written in
full-resolution pixels are scaled to a resized file and cross-checked against the 35 mm equivalent
(:mod:`fotogeo.io.exif_camera`; a contradiction is refused by name). Without distortion terms
the camera's are 0. One camera per id ``"<make> <model> <w>x<h> <focal>"`` (the model alone when it
starts with the make); mixed cameras give several ids. Pixels are the file's stored rows and
columns (GDAL ignores the EXIF ``Orientation`` flag): the attitude conventions refer to them.
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from ..errors import FotogeoWarning, InputError
from ..geometry.approx_block import DISTORTION_TERMS, ApproxCamera, ApproximateBlock, ApproxShot
from ..geometry.attitude import patb_in_map, rotation_from_body_ypr, rotation_from_ypr
from ..geometry.camera import FrameCamera

from .exif import ImageMetadata, read_image_metadata
from .exif_camera import resized_without_xmp


def height_reference(meta: ImageMetadata) -> tuple[str | None, str]:
    """``(reference, sentence)``: the vertical reference of ``meta.altitude`` by vendor (module docstring)."""
    v = meta.vendor
    if v == "senseFly":
        return "ellipsoid", "senseFly: GPSAltitude is the height above the WGS 84 ellipsoid (eBee RTK manual §5.1)"
    if v == "DJI" and meta.xs("drone-dji:RtkFlag") is not None:
        return "ellipsoid", "DJI with RTK: AbsoluteAltitude is the ellipsoidal (geodetic) height (DJI manuals)"
    if v == "DJI":
        return None, "DJI without RTK: the altitude is barometric (DJI support); its reference is unknown"
    return None, f"{v}: the reference of EXIF GPSAltitude is not documented; height reference unknown"


def position_sigmas(meta: ImageMetadata):
    """``(σ_h, σ_v)`` of the position (m) from RTK or GNSS accuracy tags, None where absent."""
    if meta.xs("drone-dji:RtkFlag") is not None:
        lo, la, sv = (meta.x(f"drone-dji:RtkStd{k}") for k in ("Lon", "Lat", "Hgt"))
        sh = math.sqrt((lo ** 2 + la ** 2) / 2) if lo and la else None
    else:
        sh = meta.x("sensefly:GPSXYAccuracy", "Camera:GPSXYAccuracy")
        sv = meta.x("sensefly:GPSZAccuracy", "Camera:GPSZAccuracy")
    return (sh if sh and sh > 0 else None), (sv if sv and sv > 0 else None)


def attitude_rotation(meta: ImageMetadata, geo_record=None):
    """``(R camera-OpenCV -> ENU, source)`` from the first attitude source present, or ``(None, "")``."""
    for ns, suffix in (("drone-dji:Gimbal", "Degree"), ("drone-parrot:Camera", "Degree")):
        y, p, r = (meta.x(f"{ns}{k}{suffix}") for k in ("Yaw", "Pitch", "Roll"))
        if y is not None and p is not None:
            return rotation_from_ypr(y, p, r or 0.0), f"{ns}*{suffix} (gimbal)"
    if geo_record is not None and geo_record.attitude is not None:
        return rotation_from_body_ypr(*geo_record.attitude), "geoinfo heading/pitch/roll (aircraft body)"
    for ns in ("Camera", "sensefly"):
        y, p, r = (meta.x(f"{ns}:{k}") for k in ("Yaw", "Pitch", "Roll"))
        if y is not None and p is not None:
            return rotation_from_body_ypr(y, p, r or 0.0), f"{ns}:Yaw/Pitch/Roll (aircraft body)"
    return None, ""


def _focal(meta: ImageMetadata):
    """``(fx, fy, principal point or None, distortion, source)`` of the first camera source present, in the
    file's pixels (:func:`fotogeo.io.exif_camera.focal_of`: full-resolution calibrations scaled to a resized file)."""
    from .exif_camera import focal_of
    return focal_of(meta)


def camera_of(meta: ImageMetadata) -> tuple[str, ApproxCamera]:
    """``(camera id, ApproxCamera)`` of one image (module docstring); an :class:`InputError` when no
    focal length can be found. A camera with ``fx != fy`` has the sensor ``(w, h·fx/fy)``."""
    w, h = meta.width, meta.height
    fx, fy, pp, dist, src = _focal(meta)
    name = " ".join(s for s in (meta.make, meta.model) if s)
    if meta.make and meta.model and meta.model.lower().startswith(meta.make.lower()):
        name = meta.model
    focal = f"{meta.focal_mm:g}mm" if meta.focal_mm else f"{fx:.0f}px"
    cam = FrameCamera(fx, (float(w), h * fx / fy), (w, h), pp)
    return f"{name or 'unknown camera'} {w}x{h} {focal}", ApproxCamera(
        cam, {**dict.fromkeys(DISTORTION_TERMS, 0.0), **dist}, src)


def _mean_lonlat(points):
    lon0 = points[0][0]
    lon = np.mean([(p[0] - lon0 + 180.0) % 360.0 - 180.0 for p in points]) + lon0
    return (float(lon) + 180.0) % 360.0 - 180.0, float(np.mean([p[1] for p in points]))


def _central_meridian(crs) -> float | None:
    params = crs.coordinate_operation.params if crs.coordinate_operation is not None else ()
    return next((float(p.value) for p in params if p.name.lower().startswith("longitude of")), None)


def block_crs(crs, lonlat) -> tuple[object, str]:
    """``(map CRS, note)``: the UTM zone of the mean GPS position ``lonlat`` when ``crs`` is None, else
    ``crs`` checked against it: projected, the position inside its area of use, a Transverse
    Mercator's central meridian within 10° and the point scale within 2 % of 1 (Web Mercator at
    37° N: 1.26); an :class:`InputError` naming ``--crs`` and the GPS's UTM zone otherwise."""
    from pyproj import Proj

    from ..crs import area_of_use, outside_area_of_use, parse_crs, require_projected, short_name, utm_crs_for
    utm = utm_crs_for(*lonlat) if lonlat else None
    if crs is None:
        if utm is None:
            return None, "no image has a GPS position: no map CRS (give --crs and --eo or --gcps)"
        return utm, (f"map CRS {short_name(utm)}: the UTM zone of the mean GPS position "
                     f"({lonlat[0]:.5f}, {lonlat[1]:.5f})")
    c = require_projected(parse_crs(crs, "--crs"), "--crs", lonlat)
    if lonlat is None:
        return c, f"map CRS {short_name(c)} (given)"
    lon, lat = lonlat
    aou, cm = area_of_use(c), _central_meridian(c)
    why = ""
    if outside_area_of_use(c, [lonlat], lonlat=True)[0]:
        why = f"outside its area of use ({aou.west:g}..{aou.east:g}°E, {aou.south:g}..{aou.north:g}°N)"
    elif cm is not None and "transverse" in (c.coordinate_operation.method_name or "").lower() and \
            abs((lon - cm + 180.0) % 360.0 - 180.0) > 10.0:
        why = f"more than 10° from its central meridian {cm:g}°"
    elif abs((k := Proj(c).get_factors(lon, lat).meridional_scale) - 1.0) > 0.02:
        why = f"where its scale is {k:.3f}, not about 1"
    if why:
        raise InputError(f"--crs {short_name(c)} does not suit the images: their mean GPS position ({lon:.4f}, "
                         f"{lat:.4f}) is {why}; give {short_name(utm)} ({utm.name}) or leave --crs out")
    return c, f"map CRS {short_name(c)} (given)"


def _position(meta, rec):
    """``(lon, lat, Z, reference, source)`` of one image: the geoinfo record's when there is one."""
    if rec is not None:
        z, ref = rec.height()
        return rec.longitude, rec.latitude, z, ref, "geoinfo"
    ref = height_reference(meta)[0]
    return meta.lon, meta.lat, meta.altitude, ref, meta.altitude_tag or "EXIF"


def _height_source(meta: ImageMetadata, rec) -> str:
    """Where an image's Z comes from, in the words of the files: ``geoinfo altitude_amsl``, ``senseFly EXIF GPSAltitude``."""
    if rec is not None:
        return "geoinfo " + ("altitude_wgs84" if rec.altitude_wgs84 is not None else "altitude_amsl")
    return f"{meta.vendor} {meta.altitude_tag or 'EXIF'}"


def _one_reference(refs: dict, sources: dict, notes: list) -> str | None:
    """The block's height reference from ``{name: reference}`` (``sources``: ``{name: where its Z comes from}``);
    ellipsoid mixed with geoid is refused, a known reference mixed with an unknown one warned about."""
    known = {r for r in refs.values() if r is not None}
    if len(known) > 1:
        e = next(n for n, r in refs.items() if r == "ellipsoid")
        g = next(n for n, r in refs.items() if r == "geoid")
        raise InputError(f"image {e!r} has an ellipsoidal height ({sources[e]}) but {g!r} a geoid (sea-level) "
                         f"height ({sources[g]}); give every image's position in one height reference (e.g. a "
                         f"geoinfo with altitude_wgs84 for all, or --eo)")
    if known and None in refs.values():
        unknown = sorted(n for n, r in refs.items() if r is None)
        text = (f"heights of {len(refs) - len(unknown)} image(s) are {known.pop()} but those of "
                f"{', '.join(unknown[:5])}{' …' if len(unknown) > 5 else ''} ({sources[unknown[0]]}) have an unknown "
                f"reference: the block's height reference is unknown; give their positions in the same reference "
                f"(--geoinfo, --eo) or check the heights of the DEM and control")
        warnings.warn(text, FotogeoWarning, stacklevel=3)
        notes.append(text)
        return None
    return known.pop() if known else None


def _read_all(paths) -> list[ImageMetadata]:
    metas = [read_image_metadata(p) for p in paths]
    if not metas:
        raise InputError("no images given; give the drone's image files")
    seen: dict = {}
    for m in metas:
        if m.name in seen:
            raise InputError(f"images {seen[m.name]!r} and {m.path!r} have the same name {m.name!r}; "
                             f"frames are known by their file name: rename one")
        seen[m.name] = m.path
    return sorted(metas, key=lambda m: m.name)


def _cameras(metas, notes: list) -> tuple[dict, dict]:
    """``({camera id: ApproxCamera}, {image name: camera id})``: the first image of an id defines it. Images whose
    camera tags contradict each other are refused together: the first one's reason in full, the others by name."""
    cameras, ids, refused = {}, {}, []
    for m in metas:
        try:
            cid, cam = camera_of(m)
        except InputError as exc:
            refused.append((m.name, exc))
            continue
        ids[m.name] = cid
        if cid not in cameras:
            cameras[cid] = cam
            notes.append(f"camera {cid!r}: focal {cam.camera.fx:.1f} px from {cam.source}")
        elif abs(cam.camera.fx / cameras[cid].camera.fx - 1) > 1e-3:
            notes.append(f"image {m.name!r}: focal {cam.camera.fx:.1f} px differs from its camera's; the first is kept")
    if len(refused) == 1:
        raise refused[0][1]
    if refused:
        more = [n for n, _ in refused[1:]]
        raise InputError(f"{refused[0][1]} (and {len(more)} more image(s) refused on their own camera tags: "
                         f"{', '.join(more[:5])}{' …' if len(more) > 5 else ''})", frames=[n for n, _ in refused],
                         option=refused[0][1].option)
    return cameras, ids


def _geoinfo_covers(geoinfo: dict, names: list, source: str) -> None:
    """A geoinfo that lists none of the images is another flight's (refused); images it lacks keep their own
    EXIF/XMP (warned, named)."""
    lacking = [n for n in names if n not in geoinfo]
    if len(lacking) == len(names):
        raise InputError(f"{source} lists none of the images ({', '.join(names[:3])}{' …' if len(names) > 3 else ''}; "
                         f"it lists {', '.join(sorted(geoinfo)[:3])} …); give the geoinfo.txt of this flight")
    if lacking:
        warnings.warn(f"{source} has no line for {len(lacking)} image(s) ({', '.join(lacking[:5])}"
                      f"{' …' if len(lacking) > 5 else ''}): their own EXIF/XMP is used", FotogeoWarning, stacklevel=3)


def read_exif_block(paths, crs=None, geoinfo=None, camera=None) -> ApproximateBlock:
    """The :class:`ApproximateBlock` of drone images (module docstring).

    ``crs``: the map CRS (any spec :func:`fotogeo.crs.parse_crs` reads); default the UTM zone of the
    mean GPS position. ``geoinfo``: a senseFly ``geoinfo.txt`` path (or the dict of
    :func:`fotogeo.io.geoinfo.read_geoinfo`): for the images it lists, its position (Z =
    ``altitude_wgs84``, ellipsoidal, else ``altitude_amsl``) and attitude replace the EXIF/XMP ones
    (a gimbal's XMP angles still win). Images without any position keep ``position=None`` (a note
    names them; the caller decides whether exterior orientations or GCPs make up for them); angles of
    images without GPS use the block's mean position for the meridian convergence. One height
    reference per block: ellipsoid mixed with geoid is an :class:`InputError`; a known reference
    mixed with an unknown one makes the block's unknown (a warning and a note say so). ``camera``: an
    :class:`ApproxCamera` the user gave (``--camera``) for every image; their EXIF/XMP camera is then not read, so
    that a contradiction in it (a rewritten ``PixelXDimension``) does not stand in the way of the fix it names.
    """
    from pyproj import Transformer
    source = f"geoinfo file {str(geoinfo)!r}" if isinstance(geoinfo, (str, Path)) else "the geoinfo"
    if isinstance(geoinfo, (str, Path)):
        from .geoinfo import read_geoinfo
        geoinfo = read_geoinfo(geoinfo)
    geoinfo = geoinfo or {}
    metas = _read_all(paths)
    resized = {m.name: why for m in metas if (why := resized_without_xmp(m))}
    if geoinfo:
        _geoinfo_covers(geoinfo, [m.name for m in metas], source)
    pos = {m.name: _position(m, geoinfo.get(m.name)) for m in metas}
    located = {n: p for n, p in pos.items() if p[0] is not None and p[2] is not None}
    lonlats = [p[:2] for p in pos.values() if p[0] is not None]
    mean = _mean_lonlat(lonlats) if lonlats else None
    map_crs, crs_note = block_crs(crs, mean)
    notes = [crs_note]
    if camera is None:
        cameras, ids = _cameras(metas, notes)
    else:
        cameras, ids = {camera.source: camera}, {m.name: camera.source for m in metas}
        notes.append(f"camera: {camera.source} for every image (the images' EXIF/XMP camera is not read)")
    ref = _one_reference({n: p[3] for n, p in located.items()},
                         {m.name: _height_source(m, geoinfo.get(m.name)) for m in metas}, notes)
    to_map = Transformer.from_crs("EPSG:4326", map_crs, always_xy=True) if map_crs is not None else None
    shots, sources = {}, {}
    for m in metas:
        lon, lat, z, _, psrc = pos[m.name]
        position = (*to_map.transform(lon, lat), z) if m.name in located and to_map else None
        R, asrc = attitude_rotation(m, geoinfo.get(m.name))
        at = (lon, lat) if lon is not None else mean
        angles = patb_in_map(R, *at, map_crs) if R is not None and at and map_crs is not None else None
        asrc = asrc if angles else "none"
        source = f"position: {psrc if position else 'none'}; angles: {asrc}"
        shots[m.name] = ApproxShot(m.name, ids[m.name], position, angles, *position_sigmas(m), None,
                                   ref if position else None, source)
        sources[asrc] = sources.get(asrc, 0) + 1
    notes.append("attitude: " + ", ".join(f"{n} image(s) from {s}" for s, n in sources.items()))
    why = {height_reference(m)[1] if m.name not in geoinfo else f"geoinfo: {pos[m.name][3]} heights" for m in metas}
    heights = f"{ref or 'unknown'} ({'; '.join(sorted(why))})"
    notes.append(f"height reference: {heights}")
    lost = {m.name: f"{m.xmp_error.split(' (')[0]}: its attitude, GPS accuracy and calibration tags were lost"
            for m in metas if m.xmp_error}
    lost.update({n: why for n, why in resized.items() if shots[n].angles is None})
    if resized:
        notes.append(f"resized copies without XMP (no attitude, GPS accuracy or calibration from it): "
                     f"{', '.join(sorted(resized)[:10])}{' …' if len(resized) > 10 else ''}")
    if lost:
        notes.append(f"XMP unreadable, attitude, GPS accuracy and calibration lost: {', '.join(sorted(lost)[:10])}")
    missing = sorted(n for n in pos if n not in located)
    if missing:
        notes.append(f"images without a GPS position: {', '.join(missing[:10])}"
                     f"{' …' if len(missing) > 10 else ''}; give --eo or --gcps for them")
    return ApproximateBlock(cameras, shots, map_crs, tuple(notes), heights, lost=lost)
