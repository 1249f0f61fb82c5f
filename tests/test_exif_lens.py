"""Canon's maker note as a second source of the focal length (fotogeo.io.exif_lens): an EXIF FocalLength the maker
note contradicts — its FocalLength record, or the lens's MinFocalLength..MaxFocalLength — is refused naming both,
the originals and a PIL-rewritten copy (maker note moved) read as before.

Real eBee JPEGs (Canon IXUS 125 HS: CameraSettings 4.3-21.5 mm, no FocalLength record) with the tag edited in place,
and a hand-written maker note carrying the FocalLength record (tag 0x0002).
"""
from __future__ import annotations

import shutil
import struct
from types import SimpleNamespace

import pytest

import jpeg_metadata as jm
from fotogeo.errors import InputError
from fotogeo.io.exif import read_image_metadata
from fotogeo.io.exif_camera import focal_of


@pytest.mark.data
@pytest.mark.parametrize("focal,refused", [(4.3, False), (43.0, True), (2.15, True), (21.5, False)])
def test_an_ebee_focal_length_outside_its_lens_is_refused(tmp_path, data_dir, focal, refused):
    src = data_dir / "drone_snowpeak" / "img" / "IMG_2280.JPG"
    assert read_image_metadata(src).canon_focal == (None, 4.3, 21.5)
    copy = shutil.copy(src, tmp_path / "IMG_2280.JPG")
    jm.set_exif_tags(copy, {0x920A: focal})  # PIL re-serialises the EXIF: the maker note's values move
    meta = read_image_metadata(copy)
    assert meta.focal_mm == pytest.approx(focal) and meta.canon_focal == (None, 4.3, 21.5)
    if refused:
        with pytest.raises(InputError, match=rf"FocalLength says {focal:g} mm, outside the 4.3-21.5 mm of its lens "
                                             rf"\(Canon maker note MinFocalLength, MaxFocalLength\).*--camera"):
            focal_of(meta)
    else:
        assert focal_of(meta)[0] == pytest.approx(focal * 4608 / 6.172, rel=1e-3)  # 746.57 px/mm


def _note_tiff(record) -> bytes:
    """A TIFF block whose maker note holds CameraSettings (4.3-21.5 mm in 1/1000 mm) and, if given, the FocalLength
    record ``record`` (FocalType, FocalLength, FocalPlaneXSize, FocalPlaneYSize)."""
    exif_at, note_at = 26, 44
    tags = [(0x0001, 48)] + ([(0x0002, 4)] if record else [])
    vals_at = note_at + 2 + 12 * len(tags) + 4
    settings = [96] + [0] * 22 + [21500, 4300, 1000] + [0] * 22
    note, at = struct.pack("<H", len(tags)), vals_at
    for tag, n in tags:
        note += struct.pack("<HHII", tag, 3, n, at)
        at += 2 * n
    note += b"\0" * 4 + struct.pack("<48H", *settings) + (struct.pack("<4H", *record) if record else b"")
    head = b"II*\0" + struct.pack("<I", 8) + struct.pack("<HHHII", 1, 0x8769, 4, 1, exif_at) + b"\0" * 4
    head += struct.pack("<HHHII", 1, 0x927C, 7, len(note), note_at) + b"\0" * 4
    return head + note


@pytest.mark.parametrize("record,exif_mm,want", [
    ((2, 4300, 0, 0), 8.6, "Canon maker note's FocalLength says 4.3 mm: one of them was edited .* 2 times"),
    ((2, 4300, 0, 0), 4.3, None), ((1, 8600, 0, 0), 8.6, None), ((2, 4300, 0, 0), 4.32, None),
    (None, 8.6, None), (None, 30.0, "outside the 4.3-21.5 mm")])
def test_the_focal_length_record_of_the_maker_note_checks_the_exif_tag(monkeypatch, record, exif_mm, want):
    from fotogeo.io import exif_sizes as xs
    from fotogeo.io.exif_lens import check_maker_focal, note_focal
    monkeypatch.setattr(xs, "exif_tiff", lambda p: _note_tiff(record))
    got = note_focal(xs.canon_note("x.jpg", "Canon"))  # read_image_metadata's path: the note parsed once
    assert got == ((record[1] / 1000 if record else None), 4.3, 21.5)
    assert note_focal(xs.canon_note("x.jpg", "DJI")) is None
    meta = SimpleNamespace(path="x.jpg", canon_focal=got)
    if want is None:
        check_maker_focal(meta, exif_mm)
    else:
        with pytest.raises(InputError, match=want):
            check_maker_focal(meta, exif_mm)


@pytest.mark.data
def test_an_ebee_frames_maker_note_is_parsed_once_for_its_size_and_its_focal_length(data_dir, monkeypatch):
    """The metadata reader parses a Canon maker note once; both readings of it (CanonImageWidth x CanonImageHeight
    and the lens's focal lengths) come from that parse."""
    from fotogeo.io import exif_sizes as xs
    read, real = [], xs.exif_tiff
    monkeypatch.setattr(xs, "exif_tiff", lambda p: read.append(p) or real(p))
    meta = read_image_metadata(data_dir / "drone_snowpeak" / "img" / "IMG_2280.JPG")
    assert meta.canon_focal == (None, 4.3, 21.5)
    assert ("Canon maker note CanonImageWidth x CanonImageHeight", (4608, 3456)) in meta.written_sizes
    assert len(read) == 1
