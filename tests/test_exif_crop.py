"""A copy of a camera's frame that keeps its EXIF was taken for a resize whenever its size was smaller than EXIF
PixelXDimension says: a centre crop of the eBee's 4608x3456 frame (2304x1728) got the focal length of a resize by
1/2 (1605 px instead of 3210), and a resized copy with its border trimmed (2244x1688) the geometric mean of two
factors. The camera's own EXIF thumbnail now tells a crop (fotogeo.io.exif_thumbnail.thumbnail_view), a resize must give
the file's size to the pixel on both axes, and the resize taken is said on the console (a Note)."""
from __future__ import annotations

import warnings

import pytest

import jpeg_metadata as jm
from fotogeo.errors import InputError, InputNote
from fotogeo.io.exif import read_image_metadata
from fotogeo.io.exif_camera import focal_of


def _cropped(src, dst, box):
    """``src``'s pixels ``box = (x0, y0, x1, y1)`` into the JPEG ``dst`` with the original's APP1 segments (EXIF,
    its thumbnail, XMP) as they were — what a cropping tool that keeps the metadata leaves."""
    import struct

    import cv2
    import numpy as np
    data = src.read_bytes()
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    x0, y0, x1, y1 = box
    enc = cv2.imencode(".jpg", img[y0:y1, x0:x1], [cv2.IMWRITE_JPEG_QUALITY, 92])[1].tobytes()
    segments, i = [], 2
    while i + 4 <= len(data) and data[i] == 0xFF and data[i + 1] != 0xDA:
        length = struct.unpack(">H", data[i + 2:i + 4])[0]
        if data[i + 1] == 0xE1:
            segments.append(data[i:i + 2 + length])
        i += 2 + length
    dst.write_bytes(b"\xff\xd8" + b"".join(segments) + enc[2:])
    return dst


@pytest.fixture
def original(data_dir):
    return data_dir / "drone_snowpeak" / "img" / "IMG_2281.JPG"


@pytest.mark.data
@pytest.mark.parametrize("box", [(1152, 864, 3456, 2592), (0, 0, 2304, 1728), (2000, 1500, 3536, 2652),
                                 (96, 72, 4512, 3384), (192, 144, 4416, 3312)],
                         ids=["centre 1/2", "corner 1/2", "off-centre 1/3", "trim 96/72", "trim 192/144"])
def test_a_crop_with_the_exif_kept_is_refused_by_its_thumbnail(tmp_path, original, box):
    """Placed to a thumbnail pixel (160 px wide: 29 px of the frame). A crop keeping most of the frame (96/72 px per
    side: 4416x3312, taken for a resize by 0.9583) still matches the thumbnail fairly well as a whole, but clearly
    better at its place, 3 thumbnail pixels from the corner where a resize lies."""
    import re
    crop = read_image_metadata(_cropped(original, tmp_path / "crop.JPG", box))
    assert (crop.width, crop.height) == (box[2] - box[0], box[3] - box[1])
    with pytest.raises(InputError, match=r"its EXIF thumbnail .* matches the file at \d+,\d+ of that frame \(± 29 px, "
                                         r"correlation 0.9\d\).*cropped, not resized.*--camera") as err:
        focal_of(crop)
    x, y = map(int, re.search(r"at (\d+),(\d+) of", str(err.value)).groups())
    assert abs(x - box[0]) <= 29 and abs(y - box[1]) <= 29


@pytest.mark.data
def test_a_resize_is_said_with_what_tells_it(tmp_path, original):
    full = focal_of(read_image_metadata(original))[0]
    half = read_image_metadata(jm.resized_copy(original, tmp_path / "half.JPG", 2.0))
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        assert focal_of(half)[0] == pytest.approx(full / 2, rel=1e-9)
    notes = [str(w.message) for w in got if issubclass(w.category, InputNote)]
    assert notes == ["images of 2304x1728 px whose EXIF PixelXDimension says 4608x3456 are taken as a resize by 1/2 "
                     "from 4608x3456 (their calibration scaled to the file; their EXIF thumbnail agrees); if the "
                     "images were cropped, give --camera"]


@pytest.mark.data
@pytest.mark.parametrize("factor", [3.0, 1 / 0.6, 1 / 0.37, 7.3, 1.01])
def test_a_resize_is_not_taken_for_a_crop(tmp_path, original, factor):
    full = focal_of(read_image_metadata(original))[0]
    copy = read_image_metadata(jm.resized_copy(original, tmp_path / "copy.JPG", factor))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputNote)
        assert focal_of(copy)[0] == pytest.approx(full * copy.width / 4608, rel=1e-9)


@pytest.mark.data
def test_a_trim_narrower_than_the_thumbnail_sees_is_not_said_to_agree(tmp_path, original):
    """48/36 px per side (4512x3384, a resize by 0.9792 to the pixel): 3.3 thumbnail pixels narrower, 1.7 per side."""
    trim = read_image_metadata(_cropped(original, tmp_path / "trim.JPG", (48, 36, 4560, 3420)))
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        focal_of(trim)
    notes = [str(w.message) for w in got if issubclass(w.category, InputNote)]
    assert len(notes) == 1 and "agrees" not in notes[0]
    assert "their EXIF thumbnail, 160 px wide, cannot tell a trim of under 115 px of the frame's width" in notes[0]


@pytest.mark.data
def test_a_thumbnail_pointer_past_the_exif_block_is_no_thumbnail(tmp_path, original):
    """IFD1 JPEGInterchangeFormat pointing past the APP1 segment (an empty slice for OpenCV to decode)."""
    import struct
    half = jm.resized_copy(original, tmp_path / "half.JPG", 2.0)
    data = bytearray(half.read_bytes())
    t = data.find(b"Exif\0\0") + 6
    bo = "<" if data[t:t + 2] == b"II" else ">"
    ifd0 = struct.unpack(bo + "I", data[t + 4:t + 8])[0]
    n0 = struct.unpack(bo + "H", data[t + ifd0:t + ifd0 + 2])[0]
    ifd1 = struct.unpack(bo + "I", data[t + ifd0 + 2 + 12 * n0:t + ifd0 + 6 + 12 * n0])[0]
    for e in range(struct.unpack(bo + "H", data[t + ifd1:t + ifd1 + 2])[0]):
        at = t + ifd1 + 2 + 12 * e
        if struct.unpack(bo + "H", data[at:at + 2])[0] == 0x0201:
            data[at + 8:at + 12] = struct.pack(bo + "I", 60000)
    bad = tmp_path / "bad.JPG"
    bad.write_bytes(bytes(data))
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        assert focal_of(read_image_metadata(bad))[0] == pytest.approx(focal_of(read_image_metadata(half))[0])
    assert any("nothing in them tells a crop from a resize" in str(w.message) for w in got)


@pytest.mark.data
def test_a_resized_copy_with_its_border_trimmed_is_refused(tmp_path, original):
    half = jm.resized_copy(original, tmp_path / "half.JPG", 2.0)
    trimmed = read_image_metadata(_cropped(half, tmp_path / "trim.JPG", (30, 20, 2274, 1708)))
    assert (trimmed.width, trimmed.height) == (2244, 1688)
    with pytest.raises(InputError, match=r"PixelXDimension x PixelYDimension is 4608x3456, not the file's size times "
                                         r"one factor to the pixel \(cropped, trimmed.*--camera"):
        focal_of(trimmed)


@pytest.mark.parametrize("size,said,k", [((2304, 1728), (4608, 3456), 0.5), ((1536, 1152), (4608, 3456), 1 / 3),
                                         ((2765, 2074), (4608, 3456), 0.6), ((1000, 750), (4000, 3000), 0.25),
                                         ((2244, 1688), (4608, 3456), None), ((2304, 1722), (4608, 3456), None),
                                         ((1728, 2304), (4608, 3456), None)])
def test_a_resize_gives_the_size_to_the_pixel_on_both_axes(size, said, k):
    from fotogeo.io.exif_camera import resize_factor
    got = resize_factor(size, said)
    assert got is None if k is None else got == pytest.approx(k, rel=1e-3)


def _cropped_resized(src, dst, box, factor):
    """``src``'s pixels ``box`` resized by ``factor`` (OpenCV, area averaging) with the original's APP1 segments."""
    import cv2
    import numpy as np
    img = cv2.imdecode(np.frombuffer(src.read_bytes(), np.uint8), cv2.IMREAD_COLOR)
    x0, y0, x1, y1 = box
    small = cv2.resize(img[y0:y1, x0:x1], (round((x1 - x0) * factor), round((y1 - y0) * factor)),
                       interpolation=cv2.INTER_AREA)
    enc = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, 92])[1].tobytes()
    dst.write_bytes(_with_app1(src.read_bytes(), enc))
    return dst


def _with_app1(original: bytes, encoded: bytes) -> bytes:
    import struct
    segments, i = [], 2
    while i + 4 <= len(original) and original[i] == 0xFF and original[i + 1] != 0xDA:
        length = struct.unpack(">H", original[i + 2:i + 4])[0]
        if original[i + 1] == 0xE1:
            segments.append(original[i:i + 2 + length])
        i += 2 + length
    return b"\xff\xd8" + b"".join(segments) + encoded[2:]


@pytest.mark.data
@pytest.mark.parametrize("fraction,place,factor", [(0.8, (0.5, 0.5), 1 / 4), (0.8, (0.0, 0.0), 1 / 4),
                                                   (0.9, (0.5, 0.5), 1 / 2), (0.6, (0.8, 0.3), 1 / 3),
                                                   (0.9, (0.0, 0.0), 0.37), (0.6, (0.5, 0.5), 1 / 4)],
                         ids=["centre 80 % 1/4", "top-left 80 % 1/4", "centre 90 % 1/2", "off-centre 60 % 1/3",
                              "top-left 90 % 0.37", "centre 60 % 1/4"])
def test_a_crop_then_resized_is_refused_naming_both(tmp_path, original, fraction, place, factor):
    """Cropped then resized with the EXIF kept, the copy's size is the frame's times ``fraction · factor``: it was
    taken for a resize by that (the central 80 % at 1/4 for 1/5: focal length 642 px for 803, tie points 14 m high)
    since the crop was looked for at the size of a plain crop only (a 32 px box in the 160 px thumbnail, not 128)."""
    import re
    cw, ch = round(4608 * fraction), round(3456 * fraction)
    x0, y0 = round((4608 - cw) * place[0]), round((3456 - ch) * place[1])
    copy = read_image_metadata(_cropped_resized(original, tmp_path / "copy.JPG", (x0, y0, x0 + cw, y0 + ch), factor))
    with pytest.raises(InputError, match=r"its EXIF thumbnail .* matches the file as the \d+x\d+ px at \d+,\d+ of that "
                                         r"frame \(± 29 px, correlation 0.9\d\).*cropped to them and resized by about "
                                         r".*give the full-size images or the camera of the copies \(--camera\)") as e:
        focal_of(copy)
    w, h, x, y, r = re.search(r"the (\d+)x(\d+) px at (\d+),(\d+) .* times ([\d.]+) \(", str(e.value)).groups()
    assert abs(int(w) - cw) <= 29 and abs(int(h) - ch) <= 29 and abs(int(x) - x0) <= 29 and abs(int(y) - y0) <= 29
    assert float(r) == pytest.approx(factor, rel=0.02)


@pytest.mark.data
def test_a_copy_its_thumbnail_matches_nowhere_is_not_taken_for_a_resize(tmp_path, original, data_dir):
    """A 1/4 copy of another frame of the flight (IMG_2188) under this one's EXIF (the size of a resize by 1/4): the
    thumbnail matches it neither as a whole, as stored, turned or mirrored, nor at any place, which contradicts a
    plain resize; it was taken for one, in silence but for a Note. (A 1/4 copy turned a half turn was the case here:
    it is a resize with the same camera, now accepted, tests/test_exif_thumbnail.py.)"""
    import cv2
    img = cv2.imread(str(data_dir / "drone_snowpeak" / "img" / "IMG_2188.JPG"), cv2.IMREAD_COLOR)
    small = cv2.resize(img, (1152, 864), interpolation=cv2.INTER_AREA)
    other = tmp_path / "other.JPG"
    other.write_bytes(_with_app1(original.read_bytes(), cv2.imencode(".jpg", small)[1].tobytes()))
    with pytest.raises(InputError, match=r"its EXIF thumbnail .* matches the file neither as a whole, as stored, "
                                         r"turned a half turn or mirrored \(correlation -?0\.\d\d; a resize matches "
                                         r"at 0.5 or more\) nor at any place: it is not a plain resize by 1/4 of that "
                                         r"frame .*--camera"):
        focal_of(read_image_metadata(other))


@pytest.mark.data
@pytest.mark.parametrize("frame", ["IMG_2186", "IMG_2188", "IMG_2212", "IMG_2213"])
def test_a_crop_keeping_the_top_left_corner_is_refused(tmp_path, data_dir, frame):
    """90 % of the frame from its top-left corner still matches the thumbnail at 0.54-0.67 as a whole, and its place
    is the corner where a resize lies: these four frames were taken for a resize by 0.9. Its far edges lie 16
    thumbnail pixels inside the frame's."""
    src = data_dir / "drone_snowpeak" / "img" / f"{frame}.JPG"
    crop = read_image_metadata(_cropped(src, tmp_path / "crop.JPG", (0, 0, 4147, 3110)))
    with pytest.raises(InputError, match=r"matches the file at 0,0 of that frame \(± 29 px, correlation 0.9\d\) "
                                         r"better than as a whole \(0.[5-7]\d\): the image was cropped, not resized"):
        focal_of(crop)
