"""The full-frame size a camera wrote outside ``PixelXDimension``, in places resizing tools seldom edit.

EXIF ``PixelXDimension``/``PixelYDimension`` is the size the calibration tags (``FocalPlaneXResolution``, DJI
``DewarpData``) describe; a tool that rewrites it to a resized copy's size makes the focal length in pixels
``1/s`` times too long. Two other records of the size a camera wrote are read here, so that
:func:`fotogeo.io.exif_camera.size_scale` can name such a copy instead of trusting the edited tag:

* the EXIF Interoperability IFD's ``RelatedImageWidth``/``RelatedImageLength`` (tags 0x1001/0x1002, DCF),
  which GDAL exposes as ``EXIF_Related_Image_Width``/``EXIF_Related_Image_Length``;
* Canon's maker note ``AFInfo2`` (tag 0x0026) or ``AFInfo`` (0x0012): ``CanonImageWidth``/``CanonImageHeight``
  (the layout documented by ExifTool's Canon tag tables, Harvey 2024). Maker-note values are addressed from the
  TIFF header; a tool that moved the note without fixing them shifts them by one constant, which is undone by
  taking the first out-of-line value to start right after the note's directory (as ExifTool's ``FixBase`` does;
  the shifted place is read first, the recorded one second). ``AFInfo`` has no size word, so whatever lies at a
  wrong place would read as a size: a block is used only when it is plausible — its size word (``AFInfo2``)
  matches its length, ``NumAFPoints >= ValidAFPoints``, ``0 < AFImageWidth <= CanonImageWidth``, and
  ``CanonImageWidth/CanonImageHeight`` is within 1 % of the aspect of the file or of its ``PixelXDimension`` (either
  orientation). Otherwise the note gives nothing: an implausible record is ignored, never a reason to refuse.

The camera's EXIF thumbnail, its third record of the frame, is read by :mod:`.exif_thumbnail`.
"""
from __future__ import annotations

import struct
from pathlib import Path

#: (maker-note tag, index of the size word, index of NumAFPoints) for Canon's AF information blocks; NumAFPoints is
#: followed by ValidAFPoints, CanonImageWidth, CanonImageHeight, AFImageWidth, AFImageHeight (Harvey 2024)
_CANON_AF = ((0x0026, 0, 2), (0x0012, None, 0))
#: relative difference tolerated between a maker-note size's aspect and the file's
ASPECT_TOLERANCE = 0.01
_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 7: 1, 8: 2, 9: 4, 10: 8}


def written_sizes(tags: dict, size: tuple = (), note=None) -> tuple:
    """``((source, (width, height)), …)``: the full-frame sizes recorded besides ``PixelXDimension`` (module
    docstring); ``tags`` are GDAL's ``EXIF_*`` items of the file, ``size`` its ``(width, height)`` in pixels, ``note``
    its Canon maker note (:func:`canon_note`; None: none)."""
    out = []
    w, h = _int(tags.get("EXIF_Related_Image_Width")), _int(tags.get("EXIF_Related_Image_Length"))
    if w and h:
        out.append(("EXIF RelatedImageWidth x RelatedImageLength", (w, h)))
    if note is not None:
        shapes = (tuple(size) or (None, None), (_int(tags.get("EXIF_PixelXDimension")),
                                                   _int(tags.get("EXIF_PixelYDimension"))))
        canon = canon_size(note, tuple(a / b for a, b in shapes if a and b))
        if canon:
            out.append(("Canon maker note CanonImageWidth x CanonImageHeight", canon))
    return tuple(out)


def _int(text) -> int | None:
    try:
        v = int(float(str(text).strip("() ")))
    except (TypeError, ValueError):
        return None
    return v if v > 0 else None


def canon_size(note, aspects: tuple = ()) -> tuple | None:
    """CanonImageWidth x CanonImageHeight from a Canon maker note (:func:`maker_note`'s), None when absent,
    unreadable or implausible (module docstring); ``aspects``: the width/height ratios it may have (none: not
    checked)."""
    if note is None:
        return None
    tiff, bo, entries, shift = note
    for tag, size_word, at in _CANON_AF:
        if tag in entries and entries[tag][0] == 3 and entries[tag][1] >= at + 6:
            typ, count, off = entries[tag]
            for base in dict.fromkeys((shift, 0)):
                vals = struct.unpack(bo + f"{count}H", tiff[off + base:off + base + 2 * count].ljust(2 * count, b"\0"))
                if (size_word is None or vals[size_word] == 2 * count) and _plausible(vals[at:at + 6], aspects):
                    return int(vals[at + 2]), int(vals[at + 3])
    return None


def canon_note(path, make: str | None) -> tuple | None:
    """:func:`maker_note` of the JPEG ``path`` when its EXIF ``make`` is Canon's (the layout read here and by
    :mod:`fotogeo.io.exif_lens`), else None: parsed once for every reading of it."""
    return maker_note(path) if (make or "").strip().lower().startswith("canon") else None


def maker_note(path) -> tuple | None:
    """``(tiff, byte order, {tag: (type, count, value or offset)}, shift)`` of a JPEG's maker note directory, None
    without one; ``shift`` is what the out-of-line values moved by (module docstring: read there first, then at the
    recorded place)."""
    tiff = exif_tiff(path)
    if tiff is None or tiff[:2] not in (b"II", b"MM"):
        return None
    bo = "<" if tiff[:2] == b"II" else ">"
    try:
        exif_ifd = ifd_entries(tiff, bo, struct.unpack(bo + "I", tiff[4:8])[0]).get(0x8769)
        note = ifd_entries(tiff, bo, exif_ifd[2]).get(0x927C) if exif_ifd else None
        if not note or note[1] < 14:
            return None
        start = note[2]
        entries = ifd_entries(tiff, bo, start)
    except (struct.error, IndexError):
        return None
    outside = [e[2] for e in entries.values() if _SIZES.get(e[0], 1) * e[1] > 4]
    return tiff, bo, entries, (start + 2 + 12 * len(entries) + 4 - min(outside)) if outside else 0


def _plausible(af, aspects: tuple) -> bool:
    """NumAFPoints, ValidAFPoints, CanonImageWidth/Height, AFImageWidth/Height that can be a camera's (module
    docstring)."""
    n, valid, w, h, af_w, af_h = af
    if not (n >= valid and w > 0 and h > 0 and 0 < af_w <= w and af_h > 0):
        return False
    return not aspects or any(abs(w / h / a - 1) <= ASPECT_TOLERANCE or abs(h / w / a - 1) <= ASPECT_TOLERANCE
                              for a in aspects)


def ifd_entries(tiff: bytes, bo: str, at: int) -> dict:
    """``{tag: (type, count, value or offset)}`` of the IFD at ``at``."""
    n = struct.unpack(bo + "H", tiff[at:at + 2])[0]
    out = {}
    for i in range(n):
        tag, typ, count = struct.unpack(bo + "HHI", tiff[at + 2 + 12 * i:at + 10 + 12 * i])
        raw = tiff[at + 10 + 12 * i:at + 14 + 12 * i]
        out[tag] = (typ, count, struct.unpack(bo + "I", raw)[0])
    return out


def exif_tiff(path) -> bytes | None:
    """The TIFF block of a JPEG's EXIF APP1 segment, None for another format or without one."""
    try:
        with open(Path(path), "rb") as f:
            data = f.read(1 << 17)
    except OSError:
        return None
    if data[:2] != b"\xff\xd8":
        return None
    i = 2
    while i + 4 <= len(data) and data[i] == 0xFF and data[i + 1] not in (0xDA, 0xD9):
        n = struct.unpack(">H", data[i + 2:i + 4])[0]
        if data[i + 1] == 0xE1 and data[i + 4:i + 10] == b"Exif\0\0":
            return data[i + 10:i + 2 + n]
        i += 2 + n
    return None
