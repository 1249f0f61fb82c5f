"""The camera an image's EXIF/XMP describe, in the pixels of the file as it is (resized copies included).

Calibration tags are written by the camera for its full-resolution frame: DJI ``DewarpData`` (fx, fy,
principal-point offsets in pixels), ``CalibratedFocalLength`` / ``CalibratedOpticalCenterX/Y`` (pixels) and
EXIF ``FocalPlaneXResolution`` (pixels per unit on the sensor). A copy downsampled after capture keeps them,
so they are scaled to the file: ``s = width / PixelXDimension`` (EXIF ``PixelXDimension``/``PixelYDimension``,
the size the camera wrote). Sources that contradict each other are named, never arbitrated:

* ``PixelXDimension`` against the other records of the size the camera wrote (EXIF ``RelatedImageWidth``, Canon's
  maker note; :mod:`.exif_sizes`): a tool that rewrote ``PixelXDimension`` to a resized copy's size would make the
  focal length ``1/s`` times too long, whatever ``s``;

* ``PixelXDimension × PixelYDimension`` not the file's size times one factor (cropped, rotated or resized
  unevenly): the calibration cannot be carried over;
* DJI ``CalibratedOpticalCenterX/Y`` (written as the full frame's centre, w/2, h/2) implying another full
  size than ``PixelXDimension`` does (tags edited by the resizing tool);
* EXIF ``FocalPlaneXResolution``/``YResolution`` (``p`` pixels per millimetre on the sensor) over the sensor the 35 mm
  equivalent implies — diagonal ``d = 43.27 · f / f35`` mm from ``FocalLength`` ``f`` and ``FocalLengthIn35mmFilm``
  ``f35``, split in the frame's aspect — give the camera's frame in pixels, ``(p_x · d · w / hypot(w, h), p_y · d · h /
  hypot(w, h))``; a frame ``k`` times the size ``PixelXDimension`` says (the file's own without it), ``|k − 1| >``
  :data:`F35_TOLERANCE`, names a copy resized with every size record rewritten, with its factor and the tags that
  restore it. These three tags survive the tools that rewrite ``PixelXDimension``, ``RelatedImageWidth`` and drop the
  maker note (they describe the sensor, not the file), and a camera's own file agrees with itself (within
  :data:`F35_TOLERANCE`; docs/benchmarks/dsm.md, "When every record of the size is rewritten: the sensor", has how
  closely the eBee's originals agree). Used when the focal plane is the camera source (no DJI XMP calibration): beside
  ``DewarpData`` or ``CalibratedFocalLength`` the calibration itself is checked against the 35 mm equivalent (below),
  and no DJI original was at hand to show that its ``FocalPlaneXResolution`` agrees;
* the focal length in pixels against ``FocalLengthIn35mmFilm``, which does not depend on the file's size
  (``f_px = f35 · hypot(w, h) / 43.27``, defined on the diagonal): more than :data:`F35_TOLERANCE` apart
  (the equivalent is rounded to a millimetre and may refer to another aspect ratio).

A digital zoom (EXIF ``DigitalZoomRatio`` ``z > 1``: the centre ``1/z`` of the sensor enlarged to the full frame)
makes each file pixel ``1/z`` of a sensor pixel, so the focal plane's ``f · p`` is ``z`` times too short. It is used,
as ``f · p · z``, only when ``FocalLengthIn35mmFilm`` includes the zoom — the frame the two records imply is ``1/z``
of the file's, two records agreeing — and refused naming ``DigitalZoomRatio`` and ``--camera`` otherwise (a frame the
file's own size: both records include the zoom or neither does; one record alone cannot say). Without the tag, a file
larger than the frame its records imply is not called a resize: its focal length would come out ``k`` times too short.

A file smaller than ``PixelXDimension`` is a resize only if one factor gives its size to the pixel on both axes
(:func:`resize_factor`: a copy with its border trimmed is not). A crop of the frame keeps every record above, and
they all describe the camera's frame, not the file: ``FocalPlaneXResolution``, the 35 mm equivalent and DJI's
``CalibratedOpticalCenterX/Y`` agree with a resize of the same size, and so do the tie points' residuals of a nadir
block (a focal length too short goes into the height). The camera's EXIF thumbnail, of the whole frame, tells them
apart (:mod:`.exif_thumbnail`): a crop it shows, resized or not, is refused, and so is a file it does not match
as a whole, a mirrored one, and one turned a half turn beside a DJI calibration (its principal point and tangential
terms are the turned frame's; with the principal point at the centre the turned resize is the same camera); otherwise the resize taken is said as an :class:`~fotogeo.errors.InputNote` with what told it, since
without a thumbnail nothing does.

Each contradiction is refused once per image, naming the records, the factor and the fix. Not used: a
thumbnail's size (the vendor's choice, the same whatever the frame) and ``FocalLength`` against
the 35 mm equivalent alone (a crop factor, no size in pixels).

A resized copy is also known by what it lacks: tools that resize (PIL's ``save(exif=...)``, many batch
resizers) copy the EXIF block and drop the XMP packet, where drone cameras write the attitude (senseFly
``sensefly:Yaw/Pitch/Roll``, DJI gimbal angles), the GNSS accuracy and the calibration. A file smaller than its
``PixelXDimension`` with no XMP at all is named as such (:func:`resized_without_xmp`): such a copy has lost its
attitude prior, and two strips that do not overlap each other then leave each strip's roll free — the same refusal
as the full-size originals stripped of their XMP (docs/benchmarks/dsm.md, "eBee flight").
"""
from __future__ import annotations

import math
import warnings
from fractions import Fraction

from ..errors import InputError, InputNote
from .exif import DIAGONAL_35MM, ImageMetadata, exif_numbers
from .exif_lens import check_maker_focal
from .exif_thumbnail import check_thumbnail, thumbnail_says

#: relative difference tolerated between a calibrated focal length and the 35 mm equivalent's
F35_TOLERANCE = 0.15
#: relative difference tolerated between the two axes' scale factors and between full sizes
SIZE_TOLERANCE = 0.01


def _fix(meta: ImageMetadata) -> str:
    return (f"image {meta.path!r} ({meta.width}x{meta.height} px)")


def size_scale(meta: ImageMetadata) -> tuple[float, str]:
    """``(s, note)``: the factor from the camera's full-resolution pixels to the file's (module docstring)."""
    w, h = meta.width, meta.height
    full = meta.pixel_dimension
    noted = _check_written_sizes(meta, full)
    s, seen, turn = 1.0, 0, ""
    if full and full[0] > 0 and full[1] > 0 and (full[0], full[1]) != (w, h):
        s = resize_factor((w, h), full)
        if s is None:
            raise InputError(f"{_fix(meta)}: its EXIF PixelXDimension x PixelYDimension is {full[0]}x{full[1]}, not "
                             f"the file's size times one factor to the pixel (cropped, trimmed, rotated or resized "
                             f"unevenly): its camera calibration cannot be carried over; give the camera (--camera)")
        dji = _full_resolution(meta, w, h, 1.0, focal_plane=False)  # a principal point and distortion of its own
        seen, turn = check_thumbnail(meta, full, s, centred=dji is None)
    cx, cy = meta.x("drone-dji:CalibratedOpticalCenterX"), meta.x("drone-dji:CalibratedOpticalCenterY")
    if cx and cy and cx > 0 and cy > 0:
        implied = (2 * cx, 2 * cy)
        expect = (w / s, h / s)
        if max(abs(implied[0] / expect[0] - 1), abs(implied[1] / expect[1] - 1)) > 0.05:
            raise _resized(meta, full, f"DJI CalibratedOpticalCenterX/Y ({cx:g}, {cy:g}) belong to a "
                                       f"{implied[0]:.0f}x{implied[1]:.0f} frame", implied)
    if _full_resolution(meta, w, h, 1.0, focal_plane=False) is None:  # the focal plane is the camera source
        _check_focal_plane(meta, full)
    note = "" if s == 1.0 else f"calibration scaled by {s:.4g} to the file's {w}x{h} px (EXIF PixelXDimension " \
                               f"{full[0]}x{full[1]})"
    if s != 1.0:
        warnings.warn(f"images of {w}x{h} px whose EXIF PixelXDimension says {full[0]}x{full[1]} are taken as a "
                      f"resize by {_ratio(s)} from {full[0]}x{full[1]} (their calibration scaled to the file; "
                      f"{thumbnail_says(seen, s, full, turn)}); "
                      f"if the images were cropped, give --camera", InputNote, stacklevel=2)
    return s, "; ".join(n for n in (note, noted) if n)


def sensor_frame(meta: ImageMetadata, said=None) -> tuple | None:
    """``(width, height)`` in pixels of the frame that ``FocalPlaneX/YResolution`` describe over the sensor implied
    by ``FocalLength`` and ``FocalLengthIn35mmFilm`` (module docstring), split in the aspect of ``said`` (default
    the file's); None unless the three tags are there."""
    if not (meta.focal_plane_ppmm and meta.focal_mm and meta.focal_35mm and meta.focal_mm > 0 and meta.focal_35mm > 0):
        return None
    w, h = said or (meta.width, meta.height)
    d = DIAGONAL_35MM * meta.focal_mm / meta.focal_35mm
    return meta.focal_plane_ppmm[0] * d * w / math.hypot(w, h), meta.focal_plane_ppmm[1] * d * h / math.hypot(w, h)


def digital_zoom(meta: ImageMetadata) -> float | None:
    """EXIF ``DigitalZoomRatio`` when a digital zoom was used (> 1), else None (module docstring)."""
    z = meta.digital_zoom
    return float(z) if z and math.isfinite(z) and z > 1.0 + 1e-6 else None


def _check_focal_plane(meta: ImageMetadata, full) -> None:
    """A copy resized with every size record rewritten, named by :func:`sensor_frame` (module docstring); with a
    digital zoom ``z``, the frame ``1/z`` of the file's that a 35 mm equivalent including the zoom implies is the
    camera's own (:func:`focal_of`), and any other frame is refused naming ``DigitalZoomRatio``."""
    said = full or (meta.width, meta.height)
    frame = sensor_frame(meta, said)
    if frame is None:
        return
    k = math.sqrt(frame[0] / said[0] * frame[1] / said[1])
    if (z := digital_zoom(meta)) is not None:
        if abs(k * z - 1.0) > F35_TOLERANCE:
            raise _zoomed(meta, z, f"FocalLength {meta.focal_mm:g} mm x FocalPlaneXResolution and "
                                   f"FocalLengthIn35mmFilm {meta.focal_35mm:g} mm describe a {frame[0]:.0f}x"
                                   f"{frame[1]:.0f} frame, " + ("the file's own: both records include the zoom or "
                                                               "neither does" if abs(k - 1.0) <= F35_TOLERANCE else
                                                               f"neither the file's {said[0]}x{said[1]} nor 1/{z:g} "
                                                               f"of it"))
        return
    if abs(k - 1.0) > F35_TOLERANCE:
        ppmm = meta.focal_plane_ppmm
        if full and tuple(full) != (meta.width, meta.height):
            raise _contradicting(meta, full, frame)
        raise _resized(meta, full, f"EXIF FocalPlaneXResolution/YResolution ({ppmm[0]:.1f}, {ppmm[1]:.1f} px/mm) "
                                   f"over the sensor that FocalLength {meta.focal_mm:g} mm and FocalLengthIn35mmFilm "
                                   f"{meta.focal_35mm:g} mm imply describe a {frame[0]:.0f}x{frame[1]:.0f} frame",
                       frame)


def _contradicting(meta: ImageMetadata, full, frame) -> InputError:
    """The refusal of a file resized from its ``PixelXDimension`` (the two sizes one factor apart) whose focal records
    describe another ``frame``: a resize changes neither record, so one of them was edited (or the file resized twice,
    ``PixelXDimension`` rewritten in between) — named as the two records' contradiction, not as a resize."""
    f, f35, ppmm = meta.focal_mm, meta.focal_35mm, meta.focal_plane_ppmm[0]
    by = f35 * math.hypot(*full) / DIAGONAL_35MM
    return InputError(f"{_fix(meta)}: its EXIF FocalLength {f:g} mm x FocalPlaneXResolution ({ppmm:.1f} px/mm) gives "
                      f"{f * ppmm:.0f} px in the {full[0]}x{full[1]} frame of its EXIF PixelXDimension (the file a "
                      f"resize of it by {_ratio(meta.width / full[0])}), its FocalLengthIn35mmFilm {f35:g} mm gives "
                      f"{by:.0f} px: the two focal records contradict each other (over the sensor they describe a "
                      f"{frame[0]:.0f}x{frame[1]:.0f} frame), one of them edited (a resize changes neither) or the "
                      f"file resized twice with PixelXDimension rewritten in between; give the camera (--camera) or "
                      f"use the originals")


def _resized(meta: ImageMetadata, full, what: str, frame) -> InputError:
    """The refusal of a file whose calibration records (``what``) describe another ``frame`` than its size records
    say: the records, the factor and the tags that restore it."""
    w, h = meta.width, meta.height
    if full is None:
        told = f"the file is {w}x{h} and carries no EXIF PixelXDimension"
    elif tuple(full) == (w, h):
        told = f"its EXIF PixelXDimension says {full[0]}x{full[1]}, the file's own size"
    else:
        told = f"its EXIF PixelXDimension says {full[0]}x{full[1]}"
    W, H, k = _restored((w, h), frame)
    by = f"{k.numerator}/{k.denominator}" if isinstance(k, Fraction) and k.denominator > 1 else f"{float(k):.3g}"
    if k > 1:  # the file is larger than the frame: no resize names it (a digital zoom, an enlarged copy, an edit)
        return InputError(f"{_fix(meta)}: {what} but {told}: the file is {by} times larger than that frame — a "
                          f"digital zoom the file does not state (EXIF DigitalZoomRatio), an enlarged copy or its "
                          f"tags edited (its focal length in pixels would come out {float(k):.3g} times too short); "
                          f"give the camera (--camera) or use the originals")
    related = any(src.startswith("EXIF RelatedImageWidth") for src, _ in meta.written_sizes)
    tags = f"-PixelXDimension={W} -PixelYDimension={H}" + (
        f" -RelatedImageWidth={W} -RelatedImageHeight={H}" if related else "")
    return InputError(f"{_fix(meta)}: {what} but {told}: a copy resized by {by} with its size records rewritten, "
                      f"or its tags edited (its focal length in pixels would come out {1 / float(k):.3g} times too "
                      f"long); "
                      f"give the camera (--camera), use the originals, or restore the tags (exiftool {tags} FILE)")


def _zoomed(meta: ImageMetadata, z: float, why: str) -> InputError:
    """The refusal of a digitally zoomed file whose focal length in pixels the records cannot tell."""
    return InputError(f"{_fix(meta)}: its EXIF DigitalZoomRatio is {z:g} (a crop of the sensor enlarged to the "
                      f"frame) and {why}: its focal length in pixels cannot be told; give the camera (--camera)")


def _restored(file, frame) -> tuple:
    """``(width, height, factor)``: the camera's size to write back and the file's factor to it — the simple factor
    ``p/q`` (``q <= 8``) nearest ``file/frame`` when within 5 % and the file's size over it is whole but for the
    resize's rounding (a resize by 1/2, 1/3, 3/5: :func:`_before`), else ``frame`` rounded and the factor as
    measured (the 35 mm equivalent is rounded to a millimetre, so the frame it implies is a few pixels off)."""
    k = math.sqrt(file[0] / frame[0] * file[1] / frame[1])
    f = Fraction(k).limit_denominator(8)
    if f > 0 and abs(f / k - 1) <= 0.05:
        sizes = [_before(v, f) for v in file]
        if all(sizes):
            return (*sizes, f)
    return round(frame[0]), round(frame[1]), k


def _before(v: int, f: Fraction) -> int | None:
    """The size ``W`` that a resize by ``f`` rounded to ``v`` pixels (``round(W·f) == v``); of several, the one with
    most factors of two (sensors' sizes are multiples of 8 or 16: 3456, not 3457, for 2074 at 3/5); None if none."""
    got = [W for W in range(math.ceil((v - 0.5) / f), math.floor((v + 0.5) / f) + 1) if round(W * f) == v]
    return max(got, key=lambda W: (W & -W, -W)) if got else None


def _check_written_sizes(meta: ImageMetadata, full) -> str:
    """``PixelXDimension`` (without it, the file's size) against the other records of the size the camera wrote
    (:mod:`.exif_sizes`): a record that is the said size times one factor ``k != 1`` (both axes, either orientation)
    names a resized copy and is refused; any other disagreement (another aspect: a 16:9 frame cut in camera from a
    4:3 sensor) cannot tell a factor and is only noted. A Canon maker note alone against a ``PixelXDimension`` equal to
    the file's size is noted too: an in-camera smaller JPEG (Canon's M/S sizes) may keep the sensor's full size there,
    and nothing in the file tells it from a copy with the tag rewritten. Returns the notes, "" without any."""
    file = (meta.width, meta.height)
    notes = []
    for source, size in meta.written_sizes:
        said = full or file
        k = _uniform_factor(size, said)
        if k == 1.0:
            continue
        if k is None or (full == file and source.startswith("Canon maker note")):
            why = ("not the file's size times one factor: another aspect, not used" if k is None else
                   "a smaller JPEG written by the camera or a copy with PixelXDimension rewritten; if the latter, "
                   "its focal length in pixels is {k:.3g} times too long: give the camera (--camera)".format(k=k))
            notes.append(f"its {source} says {size[0]}x{size[1]} ({why})")
            continue
        fix = (f"give the camera (--camera), use the originals, or restore the tag "
               f"(exiftool -PixelXDimension={size[0]} -PixelYDimension={size[1]} FILE)")
        if full is None:
            raise InputError(f"{_fix(meta)}: it carries no EXIF PixelXDimension but its {source} says "
                             f"{size[0]}x{size[1]}: it was resized after capture, and its calibration tags describe "
                             f"the {size[0]}x{size[1]} frame; {fix}")
        if full == file:
            raise InputError(f"{_fix(meta)}: its EXIF PixelXDimension says {full[0]}x{full[1]}, the file's own size, "
                             f"but its {source} says {size[0]}x{size[1]}: a copy resized with PixelXDimension "
                             f"rewritten to the new size, while FocalPlaneXResolution and the other calibration tags "
                             f"describe the {size[0]}x{size[1]} frame (its focal length in pixels would come out "
                             f"{k:.3g} times too long); {fix}")
        raise InputError(f"{_fix(meta)}: its EXIF PixelXDimension says {full[0]}x{full[1]} but its {source} says "
                         f"{size[0]}x{size[1]}: the image was resized and its tags edited; give the camera (--camera)")
    return "; ".join(notes)


def _uniform_factor(size, said) -> float | None:
    """``k`` with ``size = k · said`` to the pixel on both axes (:func:`resize_factor`; ``said`` swapped allowed: a
    portrait frame), 1.0 when equal, None when no single factor other than ~1 fits (:data:`SIZE_TOLERANCE`: a few
    pixels off is no resize)."""
    if tuple(size) in (tuple(said), tuple(said)[::-1]):
        return 1.0
    for w, h in (said, said[::-1]):
        k = resize_factor(size, (w, h))
        if k is not None and abs(k - 1.0) > SIZE_TOLERANCE:
            return k
    return None


def resize_factor(size, said) -> float | None:
    """``k`` such that a resize of ``said`` by ``k`` gives ``size`` on both axes to within the resize's rounding
    (``|round(k · said) − size| <= 1`` px, ``k`` taken on the longer axis), None when no such factor exists: a
    trimmed border (2244x1688 from 4608x3456) or another aspect is no resize, whatever the geometric mean says."""
    i = 0 if said[0] >= said[1] else 1
    k = size[i] / said[i]
    return k if all(abs(round(k * a) - b) <= 1 for a, b in zip(said, size)) else None


def _ratio(k: float) -> str:
    """``k`` as a simple fraction when it is one (``1/2``, ``3/5``), else to four digits."""
    f = Fraction(k).limit_denominator(8)
    return f"{f.numerator}/{f.denominator}" if abs(f / k - 1) < 1e-3 and f.denominator > 1 else f"{k:.4g}"


def resized_without_xmp(meta: ImageMetadata) -> str | None:
    """What a copy resized after capture lost with its XMP (module docstring), None when the file is at its EXIF
    ``PixelXDimension`` size, has no such tag, or carries XMP."""
    full = meta.pixel_dimension
    if not full or (full[0], full[1]) == (meta.width, meta.height) or meta.xmp or meta.xmp_error:
        return None
    return (f"a copy resized to {meta.width}x{meta.height} (its EXIF PixelXDimension says {full[0]}x{full[1]}) "
            f"without XMP: the resizing tool kept the EXIF and dropped the XMP, and with it the attitude, GPS "
            f"accuracy and calibration tags a drone camera writes there; copy it from the original "
            f"(exiftool -tagsFromFile ORIGINAL -xmp:all COPY)")


def focal_of(meta: ImageMetadata):
    """``(fx, fy, principal point or None, distortion, source)`` of the first camera source present, in the
    file's pixels (module docstring; the sources' order is :mod:`fotogeo.io.exif_block`'s)."""
    w, h = meta.width, meta.height
    s, note = size_scale(meta)
    got = _full_resolution(meta, w, h, s)
    if (z := digital_zoom(meta)) is not None:
        got = _zoom_focal(meta, got, z)
    if got is None:
        if meta.focal_35mm:
            f = meta.focal_35mm * math.hypot(w, h) / DIAGONAL_35MM
            return f, f, None, {}, f"FocalLengthIn35mmFilm {meta.focal_35mm:g} mm (diagonal 43.27 mm)"
        raise InputError(f"image {meta.path!r}: no focal length in its EXIF/XMP (FocalLength with "
                         f"FocalPlaneXResolution, FocalLengthIn35mmFilm, DJI CalibratedFocalLength); "
                         f"give a camera file")
    fx, fy, pp, dist, src = got
    if meta.focal_35mm:
        f35 = meta.focal_35mm * math.hypot(w, h) / DIAGONAL_35MM
        if abs(fx / f35 - 1.0) > F35_TOLERANCE:
            scaled = f" scaled by {s:.4g} for its size" if s != 1.0 else ""
            said = (w / s, h / s)
            raise _resized(meta, meta.pixel_dimension, f"the focal length from {src} is {fx:.0f} px{scaled}, "
                                                       f"FocalLengthIn35mmFilm {meta.focal_35mm:g} mm gives "
                                                       f"{f35:.0f} px,", (said[0] * fx / f35, said[1] * fx / f35))
    return fx, fy, pp, dist, src + (f"; {note}" if note else "")


def _zoom_focal(meta: ImageMetadata, got, z: float):
    """The focal plane's camera of a file digitally zoomed by ``z``: ``f · p · z`` (each file pixel is ``1/z`` of a
    sensor pixel, the crop centred), when ``FocalLengthIn35mmFilm`` includes the zoom (checked by
    :func:`_check_focal_plane`); any other source may or may not include it and is refused."""
    w, h = meta.width, meta.height
    if got is None or not meta.focal_35mm or _full_resolution(meta, w, h, 1.0, focal_plane=False) is not None:
        src = got[4] if got else (f"FocalLengthIn35mmFilm {meta.focal_35mm:g} mm" if meta.focal_35mm else "")
        raise _zoomed(meta, z, f"only {src or 'no focal record'} gives its focal length, which may or may not "
                               f"include the zoom")
    fx, fy, pp, dist, src = got
    return fx * z, fy * z, pp, dist, f"{src} x DigitalZoomRatio {z:g} (FocalLengthIn35mmFilm agrees)"


def dewarp_data(meta: ImageMetadata, s: float = 1.0):
    """``(fx, fy, principal point, distortion)`` of DJI's XMP ``drone-dji:DewarpData`` in the file's pixels, None
    when the file carries none (or not its nine numbers with positive focal lengths).

    The tag is ``"date;fx,fy,cx,cy,k1,k2,p1,p2,k3"``: the focal lengths and the principal point's offset from the
    frame's centre in the camera's full-resolution pixels (scaled here by ``s``, :func:`size_scale`; 1: read as
    written), the principal point returned in the corner convention, ``(w/2 + s·cx, h/2 + s·cy)`` of the file's size;
    ``distortion`` is Brown's ``{k1, k2, p1, p2, k3}`` (:mod:`fotogeo.geometry.brown`), ``{}`` when
    ``drone-dji:DewarpFlag`` is 1 (the camera undistorted the image itself)."""
    vals = exif_numbers((meta.xs("drone-dji:DewarpData") or "").split(";")[-1].replace(",", " "))
    if len(vals) != 9 or vals[0] <= 0 or vals[1] <= 0:
        return None
    dist = {} if meta.x("drone-dji:DewarpFlag") == 1 else dict(zip(("k1", "k2", "p1", "p2", "k3"), vals[4:]))
    return s * vals[0], s * vals[1], (meta.width / 2 + s * vals[2], meta.height / 2 + s * vals[3]), dist


def _full_resolution(meta: ImageMetadata, w: int, h: int, s: float, focal_plane: bool = True):
    """The calibration sources written in full-resolution pixels, scaled by ``s``; None when there is none
    (``focal_plane`` False: DJI's XMP calibration only)."""
    if (dewarp := dewarp_data(meta, s)) is not None:
        return (*dewarp, "drone-dji:DewarpData")
    if (f := meta.x("drone-dji:CalibratedFocalLength")) and f > 0:
        cx, cy = meta.x("drone-dji:CalibratedOpticalCenterX"), meta.x("drone-dji:CalibratedOpticalCenterY")
        return s * f, s * f, ((s * cx, s * cy) if cx and cy else None), {}, "drone-dji:CalibratedFocalLength"
    if focal_plane and meta.focal_plane_ppmm and (f := meta.x("Camera:PerspectiveFocalLength") or meta.focal_mm):
        check_maker_focal(meta, f)
        ppmm = meta.focal_plane_ppmm[0] * s
        return f * ppmm, f * ppmm, None, {}, f"{f:g} mm x FocalPlaneXResolution ({ppmm:.2f} px/mm)"
    return None
