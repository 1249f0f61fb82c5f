"""What a drone camera wrote into its images: EXIF and XMP, read through GDAL only (rasterio).

EXIF tags are the ``EXIF_*`` metadata items (rationals as ``"(37) (32) (41.5838)"``, bytes as
``"0x01"``), XMP is the one string of the ``xml:XMP`` domain, parsed with :mod:`xml.etree` (values as
attributes or elements, ``rdf:Seq`` lists joined by commas). An XMP packet that does not parse is
ignored with a :class:`FotogeoWarning` naming the file. :func:`read_image_metadata` returns the raw
facts of one image (:class:`ImageMetadata`); :mod:`fotogeo.io.exif_block` turns them into an
:class:`~fotogeo.geometry.approx_block.ApproximateBlock` (the vendor conventions are stated there).
"""
from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import FotogeoWarning, InputError, RasterError, one_line
from .block import frame_key

#: XMP namespace URIs (lower-case fragments) -> the prefix fotogeo files the tags under
XMP_PREFIXES = (("dji.com/drone-dji", "drone-dji"), ("parrot.com/drone-parrot", "drone-parrot"),
                ("pix4d.com/camera", "Camera"), ("ns.sensefly.com/camera", "Camera"),
                ("ns.sensefly.com/sensefly", "sensefly"), ("micasense.com", "MicaSense"),
                ("ns.adobe.com/exif/", "exif"), ("ns.adobe.com/tiff/", "tiff"), ("ns.adobe.com/xap/", "xmp"))
_RDF = "http://www.w3.org/1999/02/22-rdf-syntax-ns#"
#: millimetres per FocalPlaneResolutionUnit (EXIF 2.3: 2 = inch, the default, 3 = cm; 4 mm, 5 µm in use)
_UNIT_MM = {2: 25.4, 3: 10.0, 4: 1.0, 5: 0.001}
DIAGONAL_35MM = math.hypot(36.0, 24.0)  # 43.27 mm


def _prefix(uri: str) -> str:
    low = uri.lower()
    return next((p for frag, p in XMP_PREFIXES if frag in low), uri)


def _key(tag: str) -> str | None:
    if not tag.startswith("{"):
        return None
    uri, name = tag[1:].split("}", 1)
    return None if uri == _RDF or uri.startswith("adobe:ns:meta") else f"{_prefix(uri)}:{name}"


def parse_xmp(packet: str) -> dict[str, str]:
    """``{"prefix:Name": value}`` of every XMP property (prefixes of :data:`XMP_PREFIXES`, else
    the namespace URI); raises :class:`xml.etree.ElementTree.ParseError` on malformed XML."""
    root = ET.fromstring(packet.strip().strip("\x00\ufeff").strip())
    out: dict[str, str] = {}
    for el in root.iter():
        for k, v in el.attrib.items():
            if (key := _key(k)) is not None:
                out.setdefault(key, v.strip())
        key = _key(el.tag) if isinstance(el.tag, str) else None
        if key is None:
            continue
        items = [li.text.strip() for c in el for li in c if c.tag.startswith("{" + _RDF) and li.text]
        if len(el) == 0 and el.text and el.text.strip():
            out.setdefault(key, el.text.strip())
        elif items:
            out.setdefault(key, ",".join(items))
    return out


def exif_numbers(text) -> list[float]:
    """Numbers of a GDAL EXIF item: ``"(37) (32) (41.5)"``, ``"0x01"``, ``"2"``; [] if none parse."""
    out = []
    for tok in str(text or "").replace("(", " ").replace(")", " ").split():
        try:
            out.append(float(int(tok, 0)) if tok.lower().startswith("0x") else float(tok))
        except ValueError:
            return []
    return [v for v in out if math.isfinite(v)]


def _first(text) -> float | None:
    v = exif_numbers(text)
    return v[0] if v else None


def _dms(text, ref) -> float | None:
    v = exif_numbers(text)
    if not v:
        return None
    deg = sum(x / 60.0 ** i for i, x in enumerate(v[:3]))
    return -deg if str(ref or "").strip().upper()[:1] in ("S", "W") else deg


@dataclass(frozen=True)
class ImageMetadata:
    """The raw facts of one image (degrees, metres, millimetres; ``None`` where absent).

    ``altitude`` is the camera's Z as written (``altitude_tag`` names the tag);
    ``focal_plane_ppmm`` is (x, y) pixels per millimetre on the sensor (at the camera's full resolution,
    ``pixel_dimension``); ``xmp`` holds every XMP property as ``"prefix:Name": "text"`` (:func:`parse_xmp`).
    """

    path: str
    name: str
    width: int
    height: int
    make: str | None = None
    model: str | None = None
    lon: float | None = None
    lat: float | None = None
    altitude: float | None = None
    altitude_tag: str | None = None
    gps_track: float | None = None
    gps_img_direction: float | None = None
    focal_mm: float | None = None
    focal_35mm: float | None = None
    focal_plane_ppmm: tuple | None = None
    xmp: dict = field(default_factory=dict)
    pixel_dimension: tuple | None = None  # EXIF PixelXDimension, PixelYDimension: the size the camera wrote
    xmp_error: str | None = None  # why the XMP packet was ignored (not valid XML), None when it was read
    written_sizes: tuple = ()  # ((source, (w, h)), …): other records of the size the camera wrote (exif_sizes)
    digital_zoom: float | None = None  # EXIF DigitalZoomRatio (0xA404): 0 or 1 when none was used
    canon_focal: tuple | None = None  # (focal at capture or None, lens min, max) mm: Canon maker note (exif_lens)

    def x(self, *names) -> float | None:
        """The first of the XMP ``names`` (case-insensitive ``prefix:Name``) that is a number."""
        return next((v for v in (_first(self.xs(n)) for n in names) if v is not None), None)

    def xs(self, name) -> str | None:
        """The text of the XMP property ``name`` (case-insensitive ``prefix:Name``) or None."""
        return next((v for k, v in self.xmp.items() if k.lower() == name.lower()), None)

    @property
    def vendor(self) -> str:
        make = (self.make or "").lower()
        for tag, name in (("drone-dji:", "DJI"), ("sensefly:", "senseFly"), ("drone-parrot:", "Parrot"),
                          ("micasense:", "MicaSense")):
            if make.startswith(name.lower()) or any(k.lower().startswith(tag) for k in self.xmp):
                return name
        return self.make or "unknown"


def _gps(tags, xmp_get):
    lat = _dms(tags.get("EXIF_GPSLatitude"), tags.get("EXIF_GPSLatitudeRef"))
    lon = _dms(tags.get("EXIF_GPSLongitude"), tags.get("EXIF_GPSLongitudeRef"))
    if lat is None or lon is None:
        lat = _first(xmp_get("drone-dji:GpsLatitude"))
        lon = _first(xmp_get("drone-dji:GpsLongitude") or xmp_get("drone-dji:GpsLongtitude"))
    if lat is None or lon is None or (lat == 0 and lon == 0) or abs(lat) > 90 or abs(lon) > 360:
        return None, None
    return lon, lat


def _altitude(tags, xmp_get):
    if (z := _first(xmp_get("drone-dji:AbsoluteAltitude"))) is not None:
        return z, "drone-dji:AbsoluteAltitude"
    if (z := _first(tags.get("EXIF_GPSAltitude"))) is None:
        return None, None
    ref = _first(tags.get("EXIF_GPSAltitudeRef"))
    return (-z if ref == 1 else z), "EXIF GPSAltitude"


def _ppmm(tags):
    unit = _UNIT_MM.get(int(_first(tags.get("EXIF_FocalPlaneResolutionUnit")) or 2))
    x, y = _first(tags.get("EXIF_FocalPlaneXResolution")), _first(tags.get("EXIF_FocalPlaneYResolution"))
    if unit is None or not x or x <= 0:
        return None
    return x / unit, (y / unit if y and y > 0 else x / unit)


def read_image_metadata(path) -> ImageMetadata:
    """EXIF and XMP of one image through GDAL (module docstring)."""
    from rasterio.errors import RasterioError

    from .exif_lens import note_focal
    from .exif_sizes import canon_note, written_sizes
    from .raster import ropen
    p = Path(path)
    if not p.is_file():
        raise InputError(f"image {str(p)!r} does not exist (or is a folder); give the drone's image files")
    try:
        with ropen(p) as src:
            tags, w, h = src.tags(), src.width, src.height
            packet = src.tags(ns="xml:XMP").get("xml:XMP") if "xml:XMP" in src.tag_namespaces() else None
    except (RasterioError, OSError) as e:
        raise RasterError(one_line(f"image {str(p)!r} cannot be read by GDAL ({e}); is it a JPEG/TIFF "
                                   f"and not truncated?")) from None
    xmp, xmp_error = {}, None
    if packet:
        try:
            xmp = parse_xmp(packet)
        except ET.ParseError as e:
            xmp_error = f"its XMP packet is not valid XML ({e})"
            warnings.warn(f"image {str(p)!r}: its XMP packet is not valid XML ({e}); XMP ignored (attitude, GPS "
                          f"accuracy and calibration tags lost), EXIF used; repair the packet or give the attitude "
                          f"another way (--geoinfo, --eo)", FotogeoWarning, stacklevel=2)
    low = {k.lower(): v for k, v in xmp.items()}
    get = lambda name: low.get(name.lower())  # noqa: E731
    lon, lat = _gps(tags, get)
    z, ztag = _altitude(tags, get)
    text = lambda k: (tags.get(k) or "").strip("\x00 ").strip() or None  # noqa: E731
    note = canon_note(p, text("EXIF_Make"))  # parsed once: the frame's size and its focal length read it
    return ImageMetadata(str(p), frame_key(p), int(w), int(h), text("EXIF_Make"), text("EXIF_Model"), lon, lat, z,
                         ztag, _first(tags.get("EXIF_GPSTrack")), _first(tags.get("EXIF_GPSImgDirection")),
                         _first(tags.get("EXIF_FocalLength")), _first(tags.get("EXIF_FocalLengthIn35mmFilm")),
                         _ppmm(tags), xmp, _pixel_dimension(tags), xmp_error,
                         written_sizes(tags, (int(w), int(h)), note), _first(tags.get("EXIF_DigitalZoomRatio")),
                         note_focal(note))


def _pixel_dimension(tags):
    x, y = _first(tags.get("EXIF_PixelXDimension")), _first(tags.get("EXIF_PixelYDimension"))
    return (int(x), int(y)) if x and y and x > 0 and y > 0 else None


