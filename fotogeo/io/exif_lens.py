"""The focal length a Canon camera recorded in its maker note, a second source beside EXIF ``FocalLength``.

EXIF ``FocalLength`` times ``FocalPlaneXResolution`` is the focal length in pixels of a camera without a 35 mm
equivalent (Canon's compacts write none), and nothing else in EXIF checks it: an editor or a tool that writes
another lens's value makes the camera that many times too long or short. Canon's maker note (the layout documented
by ExifTool's Canon tag tables, Harvey 2024; 16-bit words, addressed as in :func:`.exif_sizes.maker_note`) keeps:

* ``CameraSettings`` (tag 0x0001; word 0 is the block's size in bytes): ``MaxFocalLength`` (word 23),
  ``MinFocalLength`` (word 24) and ``FocalUnits`` (word 25, units per millimetre): the lens's range;
* ``FocalLength`` (tag 0x0002, written by some models only): ``FocalType``, then the focal length in
  ``FocalUnits``; its ``FocalPlaneXSize``/``YSize`` words hold a sensor size for a few old models only and are not
  read.

:func:`note_focal` returns ``(focal at capture or None, min, max)`` in millimetres from the note
:func:`.exif_sizes.canon_note` parsed (once per file, by :func:`fotogeo.io.exif.read_image_metadata`);
:func:`check_maker_focal` refuses an EXIF focal length more than :data:`FOCAL_TOLERANCE` from the maker note's focal
length or outside the lens's range, naming both records and the fix. Inside the range without the 0x0002 record
(the eBee's Canon IXUS 125 HS writes none) the maker note cannot tell an edited value from a zoom position.
"""
from __future__ import annotations

import struct

from ..errors import InputError

#: relative difference tolerated between EXIF FocalLength and the maker note's records (units' rounding)
FOCAL_TOLERANCE = 0.01


def note_focal(note) -> tuple | None:
    """``(focal_mm or None, min_mm, max_mm)`` from a Canon maker note (:func:`.exif_sizes.canon_note`'s; module
    docstring), None without one, without a readable ``CameraSettings`` block or with an implausible one
    (``0 < min <= max``, units > 0)."""
    if note is None or 0x0001 not in note[2]:
        return None
    tiff, bo, entries, shift = note
    typ, count, off = entries[0x0001]
    if typ != 3 or count < 26:
        return None
    for base in dict.fromkeys((shift, 0)):
        words = _words(tiff, bo, off + base, count)
        if words is None or words[0] != 2 * count:
            continue
        hi, lo, units = words[23:26]
        if not (units > 0 and 0 < lo <= hi):
            return None
        focal = None
        if entries.get(0x0002, (0, 0))[:2] == (3, 4):
            rec = _words(tiff, bo, entries[0x0002][2] + base, 4)
            focal = rec[1] / units if rec and rec[0] in (1, 2) and rec[1] > 0 else None
        return focal, lo / units, hi / units
    return None


def _words(tiff: bytes, bo: str, at: int, count: int) -> tuple | None:
    raw = tiff[at:at + 2 * count]
    return struct.unpack(bo + f"{count}H", raw) if at >= 0 and len(raw) == 2 * count else None


def check_maker_focal(meta, f_mm: float) -> None:
    """Refuse an EXIF focal length ``f_mm`` that ``meta.canon_focal`` (:func:`note_focal`) contradicts (module
    docstring); nothing without that record."""
    if not meta.canon_focal or not f_mm:
        return
    focal, lo, hi = meta.canon_focal
    if focal is not None and abs(f_mm / focal - 1) > FOCAL_TOLERANCE:
        raise InputError(f"image {meta.path!r}: its EXIF FocalLength says {f_mm:g} mm but its Canon maker note's "
                         f"FocalLength says {focal:g} mm: one of them was edited (its focal length in pixels would "
                         f"come out {f_mm / focal:.3g} times the camera's); give the camera (--camera) or, if the "
                         f"maker note is right, restore the tag (exiftool -FocalLength={focal:g} FILE)")
    if f_mm < lo * (1 - FOCAL_TOLERANCE) or f_mm > hi * (1 + FOCAL_TOLERANCE):
        raise InputError(f"image {meta.path!r}: its EXIF FocalLength says {f_mm:g} mm, outside the {lo:g}-{hi:g} mm "
                         f"of its lens (Canon maker note MinFocalLength, MaxFocalLength): the tag was edited or "
                         f"copied from another camera; give the camera (--camera)")
