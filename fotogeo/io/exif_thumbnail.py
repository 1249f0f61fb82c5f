"""The camera's EXIF thumbnail against the file: a resize of the whole frame, a crop, or a crop that was then resized.

The EXIF thumbnail (IFD1 ``JPEGInterchangeFormat``) is the camera's own view of its whole frame and survives the tools
that crop or resize the main image while copying the EXIF block. A file of ``w x h`` pixels whose EXIF
``PixelXDimension`` says ``W x H`` (the same aspect) is a resize of the frame by ``s = w / W``, a crop of ``w x h``
frame pixels, or a crop of ``c·W x c·H`` frame pixels resized by ``s / c`` — any ``c`` between ``s`` and 1; the
calibration tags agree with all of them (:mod:`.exif_camera`). :func:`thumbnail_view` places the file in the thumbnail
(``k = thumbnail width / W`` of the frame's pixels each) by normalised cross-correlation (``cv2.matchTemplate``,
``TM_CCOEFF_NORMED``): once shrunk to the whole thumbnail (a resize) — as stored, turned a half turn or mirrored
(:data:`TURNS`; the turn that matches as a resize does and better than as stored is kept for what follows) — and at
every crop width ``t = c·k·W`` from ``s·k·W`` (a plain crop) to the thumbnail's own at its best place (the width and
place of the best correlation, the whole thumbnail's among them: the crop box to a thumbnail pixel). The widths are
searched one pixel apart in the thumbnail shrunk to :data:`SEARCH_WIDTH` pixels (the 160 px of most cameras as they
are), then at the thumbnail's own width within one shrunk pixel of the best: a phone's 512 px thumbnail costs 0.10–0.12
s of CPU instead of 0.53–1.13 s (:file:`benchmarks/thumbnail_search_bench.py`). It tells them apart only when the file
holds texture at that scale and the thumbnail shows the same frame (its aspect the frame's within
:data:`.exif_sizes.ASPECT_TOLERANCE`: a letterboxed 16:9 thumbnail is not used); a crop of less than a few thumbnail
pixels (a trimmed border) is not told from a resize here.

A resizing tool that applies EXIF ``Orientation`` 3 writes the frame turned a half turn: ``(x, y) → (w − x, h − y)``,
still a resize with the same focal length, its principal point mirrored through the centre and Brown's tangential ``p1,
p2`` negated. It is accepted when the camera source puts the principal point at the centre without tangential terms (the
focal plane, the 35 mm equivalent), refused naming the turn beside a DJI calibration (XMP) of its own. A mirrored file
is no camera's view (one focal length negative) and is refused as such.

:func:`check_thumbnail` refuses what the thumbnail contradicts, naming it: a crop (:func:`thumbnail_crop`) with the box
it found — "cropped, not resized" when the box is the file's size to the thumbnail's precision, else "cropped to … and
resized by …" (its focal length in pixels would be the camera's times that factor, its principal point moved by the box:
the thumbnail places it to ``1/k`` frame pixels only, too coarse for a calibration) — and a file that matches the
thumbnail neither as a whole, in any of :data:`TURNS` (below :data:`THUMB_RESIZE`), nor at any place and width: not a
plain resize (resizes of the eight eBee frames by 1/2 … 1/16 match at 0.976–0.995 as a whole,
:file:`benchmarks/thumbnail_crop_bench.py`).
"""
from __future__ import annotations

import math
import struct
from fractions import Fraction
from typing import NamedTuple

from ..errors import InputError
from .exif_sizes import ASPECT_TOLERANCE, exif_tiff, ifd_entries

#: correlations of a file with its EXIF thumbnail: below the first as a whole and above the second at one place in it
#: (:func:`thumbnail_crop`), the file is a crop of the camera's frame
THUMB_RESIZE, THUMB_CROP = 0.5, 0.8
#: a crop also when its box in the thumbnail correlates this much better than the whole file, with one edge at least
#: :data:`THUMB_SHIFT` thumbnail pixels from the frame's (where a resize puts it)
THUMB_MARGIN, THUMB_SHIFT = 0.1, 2.0
#: the file's pixels as they may lie against the thumbnail: as stored, turned a half turn (what a tool applying EXIF
#: Orientation 3 writes), mirrored left-right or top-bottom
TURNS = {"": lambda a: a, "turned a half turn": lambda a: a[::-1, ::-1], "mirrored left-right": lambda a: a[:, ::-1],
         "mirrored top-bottom": lambda a: a[::-1]}
#: crop widths are first searched in the thumbnail shrunk to this width (a phone's 512 px one), then refined
SEARCH_WIDTH = 160


class ThumbnailView(NamedTuple):
    """:func:`thumbnail_view`'s answer; places and sizes in the frame's pixels, to ``1 / k`` of them."""
    r_resize: float  #: correlation of the whole file with the whole thumbnail
    r_crop: float  #: correlation at the best place and width (at least ``r_resize``: the whole is one of them)
    at: tuple  #: that place's top-left corner (x, y)
    width: int  #: the thumbnail's width in pixels
    crop: tuple  #: that place's (width, height)
    turn: str = ""  #: how the file's pixels were turned or mirrored to match (a key of :data:`TURNS`; "" as stored)


def thumbnail_view(path, full: tuple) -> ThumbnailView | None:
    """Where the file ``path`` lies in its EXIF thumbnail of the ``full`` frame (module docstring); None without a
    thumbnail of ``full``'s aspect, a readable file, or texture to match."""
    import cv2
    import numpy as np
    thumb = _thumbnail(path)
    if thumb is None or abs(thumb.shape[1] / thumb.shape[0] * full[1] / full[0] - 1) > ASPECT_TOLERANCE:
        return None
    image = _read_at_least(path, thumb.shape[1])
    if image is None:
        return None
    k = thumb.shape[1] / full[0]
    h, w = image[0].shape
    smallest = round(image[1] * w * k)  # a plain crop: the file's own size at the thumbnail's scale
    if smallest < 8 or smallest > thumb.shape[1] or round(smallest * h / w) > thumb.shape[0]:
        return None
    thumb, image = thumb.astype(np.float32), image[0].astype(np.float32)
    if image.std() < 1.0 or thumb.std() < 1.0:
        return None
    r_resize, turn = _whole_match(thumb, cv2.resize(image, thumb.shape[::-1], interpolation=cv2.INTER_AREA))
    image = np.ascontiguousarray(TURNS[turn](image))
    r_crop, at, size = _coarse_to_fine(thumb, image, smallest, (r_resize, (0, 0), thumb.shape[::-1]))
    return ThumbnailView(r_resize, float(r_crop), (round(at[0] / k), round(at[1] / k)), thumb.shape[1],
                         (round(size[0] / k), round(size[1] / k)), turn)


def _whole_match(thumb, whole) -> tuple[float, str]:
    """``(correlation, turn)`` of the file shrunk to the thumbnail (``whole``) as stored, or turned or mirrored
    (:data:`TURNS`) when that matches as a resize does (:data:`THUMB_RESIZE`) and better than as stored."""
    import cv2
    import numpy as np
    r = {turn: float(cv2.matchTemplate(thumb, np.ascontiguousarray(f(whole)), cv2.TM_CCOEFF_NORMED)[0, 0])
         for turn, f in TURNS.items()}
    turned = max((t for t in TURNS if t), key=r.get)
    return (r[turned], turned) if r[turned] >= THUMB_RESIZE and r[turned] > r[""] else (r[""], "")


def _coarse_to_fine(thumb, image, smallest: int, best: tuple) -> tuple:
    """``(correlation, top-left, size)`` of the best crop width ``t`` from ``smallest`` to the thumbnail's own at its
    best place, ``best`` (the whole thumbnail's match) unless bettered. The widths are searched in the thumbnail
    shrunk to :data:`SEARCH_WIDTH` pixels, then at its own width within one shrunk pixel of the best found there."""
    import cv2
    width = thumb.shape[1]
    q = min(1.0, SEARCH_WIDTH / width)
    if q < 1.0:
        small = cv2.resize(thumb, (round(width * q), round(thumb.shape[0] * q)), interpolation=cv2.INTER_AREA)
        r, _, size = _best_box(small, image, range(max(1, round(smallest * q)), small.shape[1] + 1), (-2.0, 0, 0))
        if r > -2.0:
            widths = range(max(smallest, math.floor((size[0] - 1) / q)), min(width, math.ceil((size[0] + 1) / q)) + 1)
            return _best_box(thumb, image, widths, best)
    return _best_box(thumb, image, range(smallest, width + 1), best)


def _best_box(thumb, image, widths, best: tuple) -> tuple:
    """The best of ``best`` and ``image`` shrunk to each of ``widths`` (its aspect kept) at its best place in
    ``thumb`` (module docstring)."""
    import cv2
    aspect = image.shape[0] / image.shape[1]
    for t in widths:
        size = (t, min(round(t * aspect), thumb.shape[0]))
        shrunk = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        if shrunk.std() < 1.0:
            continue
        _, r, _, at = cv2.minMaxLoc(cv2.matchTemplate(thumb, shrunk, cv2.TM_CCOEFF_NORMED))
        if r > best[0]:
            best = (r, at, size)
    return best


def _thumbnail(path):
    """The EXIF thumbnail of the JPEG ``path`` in grey levels, None without one (or a pointer past the EXIF block)."""
    import cv2
    import numpy as np
    tiff = exif_tiff(path)
    if tiff is None or tiff[:2] not in (b"II", b"MM"):
        return None
    bo = "<" if tiff[:2] == b"II" else ">"
    try:
        ifd0 = struct.unpack(bo + "I", tiff[4:8])[0]
        after = ifd0 + 2 + 12 * struct.unpack(bo + "H", tiff[ifd0:ifd0 + 2])[0]
        ifd1 = struct.unpack(bo + "I", tiff[after:after + 4])[0]
        entries = ifd_entries(tiff, bo, ifd1) if ifd1 else {}
    except (struct.error, IndexError):
        return None
    if 0x0201 not in entries or 0x0202 not in entries:
        return None
    start, n = entries[0x0201][2], entries[0x0202][2]
    if n == 0 or start + n > len(tiff):  # a pointer past the EXIF block (or the part of it read): no thumbnail
        return None
    try:
        return cv2.imdecode(np.frombuffer(tiff[start:start + n], np.uint8), cv2.IMREAD_GRAYSCALE)
    except cv2.error:
        return None


def _read_at_least(path, width: int):
    """``(grey image, its reduction)``: the file decoded at 1/8, 1/4, 1/2 or full size, the smallest at least
    ``width`` pixels wide (a small copy read at 1/8 would be narrower than the thumbnail it is matched in)."""
    import cv2
    flags = {8: cv2.IMREAD_REDUCED_GRAYSCALE_8, 4: cv2.IMREAD_REDUCED_GRAYSCALE_4, 2: cv2.IMREAD_REDUCED_GRAYSCALE_2,
             1: cv2.IMREAD_GRAYSCALE}
    try:
        image = cv2.imread(str(path), flags[8] | cv2.IMREAD_IGNORE_ORIENTATION)
        by = next(b for b in flags if image is None or b == 1 or 8 * image.shape[1] / b >= width)
        if image is not None and by != 8:
            image = cv2.imread(str(path), flags[by] | cv2.IMREAD_IGNORE_ORIENTATION)
    except cv2.error:
        return None
    return None if image is None else (image, by)


def thumbnail_crop(view: ThumbnailView, full) -> bool:
    """Whether ``view`` shows a crop: its best box matches (at least :data:`THUMB_CROP`) and the whole file does not
    (below :data:`THUMB_RESIZE`), or matches clearly worse (by :data:`THUMB_MARGIN`) than that box, one of whose edges
    lies at least :data:`THUMB_SHIFT` thumbnail pixels from the frame's — a crop keeping most of the frame still
    matches well as a whole."""
    if view.r_crop < THUMB_CROP:
        return False
    (x, y), (cw, ch) = view.at, view.crop
    shift = max(abs(x), abs(y), abs(full[0] - x - cw), abs(full[1] - y - ch)) * view.width / full[0]
    return view.r_resize < THUMB_RESIZE or (view.r_crop - view.r_resize >= THUMB_MARGIN and shift >= THUMB_SHIFT)


def check_thumbnail(meta, full, s: float, centred: bool = True) -> tuple[int, str]:
    """Refuse a file taken for a resize by ``s`` of the ``full`` frame that its EXIF thumbnail contradicts (module
    docstring); ``centred``: the camera source puts the principal point at the frame's centre without tangential
    distortion, so that a resize turned a half turn is the same camera (else refused: its calibration is the turned
    frame's). Without a thumbnail or texture nothing is told and the resize stands. Returns ``(width, turn)``: the
    thumbnail's width when it matches the whole file (at least :data:`THUMB_CROP`), else 0, and
    :attr:`ThumbnailView.turn`."""
    view = thumbnail_view(meta.path, full)
    if view is None:
        return 0, ""
    fix = f"image {meta.path!r} ({meta.width}x{meta.height} px): its EXIF thumbnail (the camera's view of its whole " \
          f"{full[0]}x{full[1]} frame, EXIF PixelXDimension)"
    _check_turn(view, fix, centred)
    seen = f"the file {view.turn}" if view.turn else "the file"
    if thumbnail_crop(view, full):
        (x, y), (cw, ch), px = view.at, view.crop, full[0] / view.width
        where = f"at {x},{y} of that frame (± {px:.0f} px, correlation {view.r_crop:.2f}) better than as a whole " \
                f"({view.r_resize:.2f})"
        r = meta.width / cw
        if abs(r - 1) * cw <= 2 * px:  # the box is the file's size to the thumbnail's precision
            raise InputError(f"{fix} matches {seen} {where}: the image was cropped, not resized, so its focal "
                             f"length in pixels is the camera's and its principal point moved by the crop; give the "
                             f"camera of the crop (--camera) or use the originals")
        raise InputError(f"{fix} matches {seen} as the {cw}x{ch} px {where}: the image was cropped to them and "
                         f"resized by about {_about(r)}, not resized by {_about(s)} alone, so its focal length in "
                         f"pixels is the camera's times {r:.3g} (± {2 * px / cw:.0%}) and its principal point moved "
                         f"by the crop; give the full-size images or the camera of the copies (--camera)")
    if view.r_resize < THUMB_RESIZE:
        raise InputError(f"{fix} matches the file neither as a whole, as stored, turned a half turn or mirrored "
                         f"(correlation {view.r_resize:.2f}; a resize matches at {THUMB_RESIZE:g} or more) nor at any "
                         f"place: it is not a plain resize by {_about(s)} of that frame (cropped and resized "
                         f"unevenly, turned a quarter turn, edited, or the thumbnail of another image); give the "
                         f"full-size images or the camera of the copies (--camera)")
    return (view.width if view.r_resize >= THUMB_CROP else 0), view.turn


def _check_turn(view: ThumbnailView, fix: str, centred: bool) -> None:
    """Refuse a file whose pixels match the thumbnail only mirrored (no camera's view: a pinhole camera with one
    focal length negative), or turned a half turn when the camera source is not ``centred``
    (:func:`check_thumbnail`): a half turn maps ``(x, y)`` to ``(w − x, h − y)``, the same focal length, the
    principal point mirrored through the centre and the tangential coefficients ``p1, p2`` negated."""
    as_stored = f"correlation {view.r_resize:.2f}, better than as stored"
    if view.turn.startswith("mirrored"):
        raise InputError(f"{fix} matches the file only {view.turn} ({as_stored}): a mirror image is no camera's "
                         f"view; give the images as the camera wrote them (mirror them back)")
    if view.turn and not centred:
        raise InputError(f"{fix} matches the file only {view.turn} ({as_stored}): the image was turned (as a tool "
                         f"applying EXIF Orientation 3 writes it), so the principal point and distortion of its DJI "
                         f"calibration (XMP) are the turned frame's; turn it back (jpegtran -rotate 180) or give the "
                         f"camera of the copies (--camera)")


def thumbnail_says(seen: int, s: float, full, turn: str = "") -> str:
    """What the EXIF thumbnail (``seen`` pixels wide when it matches the whole file, else 0; ``turn`` how the file
    matched it, :data:`TURNS`) tells of a resize by ``s`` of the ``full`` frame: it agrees only when a centred crop of
    the same size, ``(1 − s) · seen`` thumbnail pixels narrower, lies :data:`THUMB_SHIFT` of them from the corner
    (:func:`thumbnail_crop` would see it)."""
    turned = f" ({turn}: the same focal length, the principal point at the centre)" if turn else ""
    if not seen:
        return "nothing in them tells a crop from a resize" + turned
    if (1 - s) * seen >= 2 * THUMB_SHIFT:
        return "their EXIF thumbnail agrees" + turned
    return (f"their EXIF thumbnail, {seen} px wide, cannot tell a trim of under {2 * THUMB_SHIFT * full[0] / seen:.0f} "
            f"px of the frame's width from a resize{turned}")


def _about(k: float) -> str:
    """``k`` as a simple fraction (``1/4``) when within 2 % of one, else to three digits."""
    f = Fraction(k).limit_denominator(8)
    return f"{f.numerator}/{f.denominator}" if abs(f / k - 1) < 0.02 and f.denominator > 1 else f"{k:.3g}"
