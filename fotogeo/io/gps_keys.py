"""Which image's GPS is a shot's: every image given claims its own name, with GPS or without, and the same file
name in two folders is one image when their GPS is the same, else matched by the path the project names or refused
by name — an image never lends its GPS to another's shot (:func:`images_gps`, :func:`gps_for`; the SfM readers'
evidence in :mod:`fotogeo.io.sfm_frame`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError

#: σ (m) of a consumer receiver's horizontal GPS position, when the image carries no accuracy tag
DEFAULT_SIGMA_H = 5.0

@dataclass(frozen=True)
class GpsFix:
    """An image's own GPS: lon, lat (degrees), altitude (m; None when the image carries none — never taken as 0),
    the σ of its horizontal position (m) and the altitude's vertical reference when the vendor documents it
    (:func:`fotogeo.io.exif_block.height_reference`)."""

    lon: float
    lat: float
    alt: float | None
    sigma_h: float
    tagged: bool  # the σ comes from the image's accuracy tags (else DEFAULT_SIGMA_H)
    sigma_v: float | None = None  # σ of the altitude (m) from the accuracy tags, when they state it
    height_reference: str | None = None  # "ellipsoid" / "geoid" / None (unknown)


class ImagesGps(dict):
    """``{image key: GpsFix}`` of the images given that carry a GPS position (:func:`images_gps`); ``without``: the
    keys of the images given that carry none (they still claim their own name, :func:`gps_for`); ``paths``:
    ``{key: path}`` of every image given, for the messages; ``named``: the keys that keep their extension (images of
    one folder told apart only by it)."""

    def __init__(self, items=(), without=(), paths=None, named=()):
        super().__init__(items)
        self.without = tuple(without)
        self.paths = dict(paths or {})
        self.named = frozenset(named)

    def mapped(self, f) -> "ImagesGps":
        """The same images with each value ``f(value)``."""
        return ImagesGps({k: f(v) for k, v in self.items()}, self.without, self.paths, self.named)


def project_key(name) -> str:
    r"""The key an SfM project's image name is matched by: the name without its extension, its folders kept
    (``flight1/DJI_0001.JPG`` -> ``flight1/DJI_0001``; a Windows ``\`` read as a folder)."""
    head, _, tail = str(name).replace("\\", "/").rpartition("/")
    stem = Path(tail).stem if tail else tail
    return f"{head}/{stem}" if head else stem


def _tails(paths: list) -> list:
    """The shortest ``folder/…/name`` that tells apart images sharing a stem (copied folders): the stem, or the name
    with its extension for images of one folder (``f/IMG_1.JPG``, ``f/IMG_1.tif``: same name, different extension)."""
    res = [Path(p).resolve() for p in paths]
    names = [r.name if sum(q.parent == r.parent for q in res) > 1 else r.stem for r in res]
    parts = [r.parent.parts for r in res]
    for n in range(1, max(len(q) for q in parts) + 1):
        keys = ["/".join((*q[-n:], m)).lstrip("/") for q, m in zip(parts, names)]
        if len(set(keys)) == len(keys):
            return keys
    return [str(r) for r in res]


def images_gps(paths) -> ImagesGps:
    """``{key: GpsFix}`` of the images in ``paths`` that carry an EXIF/XMP GPS position, keyed by file stem
    (:func:`fotogeo.io.block.frame_key`); the stems of those without GPS are kept in ``without``. Images that share
    a stem (``flight1/DJI_0001.JPG``, ``flight2/DJI_0001.JPG``) are one image when their GPS is the same (a copied
    folder), else each is keyed by the folders that tell it apart (``flight1/DJI_0001``), for :func:`gps_for` to
    match with the path the project names."""
    from .block import frame_key
    from .exif import read_image_metadata
    from .exif_block import height_reference, position_sigmas
    groups: dict = {}
    for p in paths or ():
        groups.setdefault(frame_key(p), []).append((str(p), _fix_of(read_image_metadata(str(p)),
                                                                     position_sigmas, height_reference)))
    out, without, where, named = {}, [], {}, []
    for key, items in groups.items():
        fixes = {g for _, g in items}
        keys = [key] if len(fixes) == 1 else _tails([p for p, _ in items])
        for k, (p, g) in zip(keys, items):
            where[k] = p
            if Path(p).suffix and k.endswith("/" + Path(p).name):
                named.append(k)
            if g is None:
                without.append(k)
            else:
                out[k] = g
    return ImagesGps(out, without, where, named)


def _fix_of(m, position_sigmas, height_reference) -> GpsFix | None:
    if m.lon is None or m.lat is None:
        return None
    sh, sv = position_sigmas(m)
    alt = float(m.altitude) if m.altitude is not None else None
    return GpsFix(float(m.lon), float(m.lat), alt, float(sh) if sh else DEFAULT_SIGMA_H, bool(sh),
                  float(sv) if sv else None, height_reference(m)[0] if alt is not None else None)


def gps_for(gps: dict, keys) -> dict:
    """``gps`` re-keyed by the project's frame ``keys``: each image's key, or the one differing only by case or a
    folder (:func:`fotogeo.io.block.match_keys`), so a project naming ``dji_0001.jpg`` is checked against
    ``DJI_0001.JPG``'s GPS; a key is taken by one image at most (the exact name first), and every image given claims
    its own name, with GPS or without (``gps.without``), so that no image lends its GPS to another's shot. Images
    told apart by their folders (:func:`images_gps`) are matched by the path the project names (``flight1/DJI_0001``
    ends like ``…/flight1/DJI_0001``, whatever the case); images of one folder told apart by their extension only are
    matched by the project's name with its extension; a project key that could be several of them is refused by
    name."""
    from .block import match_keys
    without = set(getattr(gps, "without", ()))
    named = getattr(gps, "named", frozenset())
    names = [*gps, *without]
    keys = list(keys)
    folded = [n for n in names if "/" in n]
    found, rest = {}, []
    for k in keys:
        kp, kf = project_key(k).casefold(), str(k).replace("\\", "/").casefold()
        hit = [n for n in folded if _ends(kp, project_key(n).casefold() if n in named else n.casefold())
               and (n not in named or kf == kp or _ends(kf, n.casefold()))]
        if len(hit) > 1:
            raise _ambiguous(gps, k, hit)
        if hit:
            found[hit[0]] = k
        else:
            rest.append(k)
    plain = [n for n in names if "/" not in n]
    back: dict = {}  # the project's names matched by their key (an extension never tells plain names apart)
    for k in rest:
        back.setdefault(project_key(k), []).append(k)
    found.update((n, back[k][0]) for n, k in match_keys(plain, [k for k in back if len(back[k]) == 1]).items())
    return {k: gps[n] for n, k in found.items() if n not in without}


def _ends(a: str, b: str) -> bool:
    """Whether the names ``a`` and ``b`` are the same file, one naming more of its folders than the other."""
    return a == b or a.endswith("/" + b) or b.endswith("/" + a)


def _ambiguous(gps, key, names) -> InputError:
    paths = getattr(gps, "paths", {})
    fixes = [gps.get(n) for n in names]
    if all(fixes[:2]):
        from pyproj import Geod
        apart = Geod(ellps="WGS84").inv(fixes[0].lon, fixes[0].lat, fixes[1].lon, fixes[1].lat)[2]
        differ = f"positions differ, {apart:.1f} m apart"
    else:
        differ = "one of them carries none"
    said = " and ".join(repr(paths.get(n, n)) for n in names[:3])
    one = len({str(Path(paths.get(n, n)).parent) for n in names}) == 1  # same name, different extension
    share, which = (("have the same name, different extension, as", "it is: give only the images the project was "
                     "made of") if one else ("share the name of", "folder it is: give only the images of the "
                                             "project's folder"))
    return InputError(f"images {said} {share} the project's image {key!r} but not their GPS ({differ}), and the "
                      f"project's name does not say which {which}, or rename the others", frames=names)
