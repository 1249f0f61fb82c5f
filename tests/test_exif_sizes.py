"""A resized copy whose EXIF PixelXDimension was rewritten to its new size is named by the other records of the size
the camera wrote (fotogeo.io.exif_sizes: the Interoperability IFD's RelatedImageWidth, Canon's maker note), at
every resize factor; a copy whose PixelXDimension was left alone, and the original, are read as before.

Real eBee JPEGs (Canon IXUS 125 HS: FocalPlaneXResolution, no FocalLengthIn35mmFilm) resized by OpenCV with their
metadata segments kept, one tag edited in place; and a TIFF of another camera (no maker note) carrying the tags.
"""
from __future__ import annotations

import pytest

import jpeg_metadata as jm
from fotogeo.errors import InputError
from fotogeo.io.exif import read_image_metadata
from fotogeo.io.exif_camera import focal_of
from test_io_exif import write_image

FULL = (4608, 3456)
INTEROP, MAKER_NOTE = 0xA005, 0x927C  # Exif IFD entries: the Interoperability IFD's pointer, the maker note


def _resized(src, dst, factor, *, rewrite: bool, drop=()):
    copy = jm.resized_copy(src, dst, factor)
    meta = read_image_metadata(copy)
    if rewrite:
        jm.set_integer_tag(copy, 0xA002, meta.width, exif_ifd=True)
        jm.set_integer_tag(copy, 0xA003, meta.height, exif_ifd=True)
    for k, tag in enumerate(drop):  # a private tag number: the entry is no longer read
        jm.rename_ifd0_tag(copy, tag, 0xA0F0 + k, exif_ifd=True)
    return copy


@pytest.mark.data
@pytest.mark.parametrize("factor", [2, 3, 4, 1 / 0.6])
@pytest.mark.parametrize("drop", [(), (INTEROP,), (MAKER_NOTE,)], ids=["both", "maker note only", "interop only"])
def test_rewritten_pixel_dimension_is_named_at_every_factor(tmp_path, data_dir, factor, drop):
    """Refused by RelatedImageWidth; by the Canon maker note alone only noted (an in-camera smaller JPEG may keep
    the sensor's size there and cannot be told from such a copy)."""
    src = data_dir / "drone_snowpeak" / "img" / "IMG_2280.JPG"
    full_fx = focal_of(read_image_metadata(src))[0]
    right = read_image_metadata(_resized(src, tmp_path / "right.JPG", factor, rewrite=False, drop=drop))
    assert focal_of(right)[0] == pytest.approx(full_fx * right.width / FULL[0], rel=1e-3)  # not refused, scaled
    bad = read_image_metadata(_resized(src, tmp_path / "bad.JPG", factor, rewrite=True, drop=drop))
    if INTEROP in drop:
        k = FULL[0] / bad.width
        assert rf"CanonImageHeight says 4608x3456 (a smaller JPEG written by the camera or a copy with " \
               rf"PixelXDimension rewritten; if the latter, its focal length in pixels is {k:.3g} times too long" \
               in focal_of(bad)[4]
        return
    with pytest.raises(InputError, match=rf"PixelXDimension says {bad.width}x{bad.height}, the file's own size, but "
                                         rf"its EXIF RelatedImageWidth.* says 4608x3456: a copy resized with "
                                         rf"PixelXDimension rewritten .*exiftool -PixelXDimension=4608 "
                                         rf"-PixelYDimension=3456"):
        focal_of(bad)


@pytest.mark.data
def test_the_originals_and_a_copy_without_pixel_dimension(tmp_path, data_dir):
    src = data_dir / "drone_snowpeak" / "img"
    for name in ("IMG_2186", "IMG_2212", "IMG_2282"):  # both records present and agreeing with the file
        meta = read_image_metadata(src / f"{name}.JPG")
        assert [s for _, s in meta.written_sizes] == [FULL, FULL] and focal_of(meta)[0] > 3000
    copy = jm.resized_copy(src / "IMG_2280.JPG", tmp_path / "a.JPG", 4)
    jm.rename_ifd0_tag(copy, 0xA002, 0xA0F2, exif_ifd=True)
    with pytest.raises(InputError, match=r"no EXIF PixelXDimension but its EXIF RelatedImageWidth x "
                                         r"RelatedImageLength says 4608x3456: it was resized after capture"):
        focal_of(read_image_metadata(copy))
    # every record of the size rewritten or gone: nothing in the file tells (the residual check of exif_focal is left)
    last = _resized(src / "IMG_2280.JPG", tmp_path / "b.JPG", 2, rewrite=True, drop=(INTEROP, MAKER_NOTE))
    full_fx = focal_of(read_image_metadata(src / "IMG_2280.JPG"))[0]
    assert focal_of(read_image_metadata(last))[0] == pytest.approx(full_fx)


@pytest.mark.parametrize("said,refused", [((6000, 4000), False), ((3000, 2000), True)])
def test_another_cameras_related_image_size(tmp_path, said, refused):
    """A TIFF of another make (no maker note read) 3000x2000 px whose camera wrote 6000x4000: PixelXDimension
    kept (scaled by 1/2) or rewritten to 3000x2000 (named by RelatedImageWidth)."""
    tags = {"EXIF_Make": "SONY", "EXIF_Model": "ILCE-7RM2", "EXIF_FocalLength": "(35)",
            "EXIF_FocalPlaneXResolution": "(4000)", "EXIF_FocalPlaneResolutionUnit": "3",
            "EXIF_PixelXDimension": str(said[0]), "EXIF_PixelYDimension": str(said[1]),
            "EXIF_Related_Image_Width": "6000", "EXIF_Related_Image_Length": "4000"}
    meta = read_image_metadata(write_image(tmp_path / "a.tif", tags, size=(3000, 2000)))
    if refused:
        with pytest.raises(InputError, match=r"RelatedImageLength says 6000x4000: a copy resized with "
                                             r"PixelXDimension rewritten.*2 times too long"):
            focal_of(meta)
    else:
        assert focal_of(meta)[0] == pytest.approx(35 * 400 / 2)  # 400 px/mm at 6000 px, scaled to 3000


@pytest.mark.parametrize("moved", [0, 300, -40])
def test_a_canon_maker_note_moved_by_a_tool_is_read_where_its_values_went(tmp_path, moved):
    """A maker note whose values' offsets were written for another place in the file (a tool moved the note without
    fixing them, ``moved`` bytes): read from the first value's place right after the note's directory; a block
    whose size word does not match its length (another layout) gives nothing."""
    import struct

    from fotogeo.io.exif_sizes import canon_size, maker_note

    def jpeg(size_word):
        af = struct.pack("<49H", size_word, 2, 9, 1, 4608, 3456, 4608, 3456, *([0] * 41))
        note_at, exif_at = 60, 26
        note = struct.pack("<HHHII", 1, 0x0026, 3, 49, note_at + 18 + moved) + b"\0" * 4 + af
        tiff = (b"II*\0" + struct.pack("<I", 8) + struct.pack("<HHHII", 1, 0x8769, 4, 1, exif_at) + b"\0" * 4
                + struct.pack("<HHHII", 1, 0x927C, 7, len(note), note_at) + b"\0" * 4)
        tiff = tiff.ljust(note_at, b"\0") + note
        path = tmp_path / f"c{size_word}.jpg"
        body = b"Exif\0\0" + tiff
        path.write_bytes(b"\xff\xd8\xff\xe1" + struct.pack(">H", len(body) + 2) + body + b"\xff\xd9")
        return path
    assert canon_size(maker_note(jpeg(98))) == (4608, 3456)
    assert canon_size(maker_note(jpeg(97))) is None


@pytest.mark.data
def test_the_fix_named_works_a_camera_given_is_used_and_the_exif_camera_not_read(tmp_path, data_dir):
    """The refusal names --camera: with a camera given, triangulate's start reads the copies' GPS and attitude and
    not their contradicting EXIF camera (it was refused the same way, so the fix named could not be followed)."""
    from fotogeo.tools.triangulate.sources import _from_images
    src = data_dir / "drone_snowpeak" / "img"
    frames = [_resized(src / f"{n}.JPG", tmp_path / f"{n}.JPG", 2, rewrite=True) for n in ("IMG_2280", "IMG_2281")]
    cam = tmp_path / "cam.yaml"
    cam.write_text("ixus:\n  type: pinhole\n  im_size: [2304, 1728]\n  focal_len: 4.3\n"
                   "  sensor_size: [6.1722, 4.6227]\n")
    with pytest.raises(InputError, match="PixelXDimension rewritten"):
        _from_images(frames, None, None, True)
    block = _from_images(frames, None, None, True, camera=str(cam))
    assert set(block.cameras) == {"--camera"} and block.cameras["--camera"].camera.fx == pytest.approx(1605.1, abs=1)
    assert all(s.position is not None and s.angles is not None for s in block.shots.values())
    assert any("the images' EXIF/XMP camera is not read" in n for n in block.notes)


def _canon_tiff(af: list, tag: int, moved: int) -> bytes:
    """A TIFF block whose maker note carries CameraSettings and the AF block ``af`` (``tag``) out of line, the note
    placed ``moved`` bytes after where its values' offsets say, filler 0x1234 before it."""
    import struct
    exif_at, note_at = 26, 44
    vals_at = note_at + 2 + 24 + 4
    note = struct.pack("<HHHII", 2, 0x0001, 3, 4, vals_at) + struct.pack("<HHII", tag, 3, len(af), vals_at + 8)
    note += b"\0" * 4 + struct.pack("<4H", 1, 2, 3, 4) + struct.pack(f"<{len(af)}H", *af)
    head = b"II*\0" + struct.pack("<I", 8) + struct.pack("<HHHII", 1, 0x8769, 4, 1, exif_at) + b"\0" * 4
    head += struct.pack("<HHHII", 1, 0x927C, 7, len(note), note_at + moved) + b"\0" * 4
    return head + struct.pack("<H", 0x1234) * (moved // 2) + note


@pytest.mark.parametrize("moved", [0, 64, 200])
def test_a_moved_afinfo_without_size_word_is_read_where_it_went_or_not_at_all(monkeypatch, moved):
    """AFInfo (0x0012, no size word) moved by a tool: read at the shifted place (the stale one holds 0x1234 words,
    4660x4660); a block that is not plausible (more valid than AF points, AFImageWidth above CanonImageWidth,
    another aspect than the file's) gives nothing."""
    from fotogeo.io import exif_sizes as xs
    good = [9, 9, 4608, 3456, 4608, 3456, 100, 100, 0, 0, 0, 0]
    for af, aspects, want in ((good, (4 / 3,), FULL), (good, (), FULL), (good, (16 / 9,), None),
                              (good, (3 / 4,), FULL), ([9, 10] + good[2:], (4 / 3,), None),
                              (good[:4] + [5000] + good[5:], (4 / 3,), None)):
        monkeypatch.setattr(xs, "exif_tiff", lambda p, t=_canon_tiff(af, 0x0012, moved): t)
        assert xs.canon_size(xs.maker_note("x.jpg"), aspects) == want, (af, aspects)


@pytest.mark.parametrize("record,refused", [((4608, 3456), False), ((9216, 5184), True), ((5184, 9216), True),
                                            ((4650, 2560), False), ((4600, 2600), False)])
def test_only_a_uniform_factor_is_refused(record, refused):
    """A 4608x2592 file (PixelXDimension the same) whose RelatedImageWidth says ``record``: a 4:3 frame (a 16:9 cut in
    camera), sizes off by more than 1 % between the axes or by a few pixels are noted; twice the size, either
    orientation, is refused."""
    from fotogeo.io.exif import ImageMetadata
    from fotogeo.io.exif_camera import size_scale
    meta = ImageMetadata("x.JPG", "x", 4608, 2592, "SONY", "X", None, None, None, None, None, None, 4.3, None, None,
                         {}, (4608, 2592), None, (("EXIF RelatedImageWidth x RelatedImageLength", record),))
    if refused:
        with pytest.raises(InputError, match=r"a copy resized .* 2 times too long"):
            size_scale(meta)
    else:
        s, note = size_scale(meta)
        assert s == 1.0 and f"says {record[0]}x{record[1]} (not the file's size times one factor" in note
