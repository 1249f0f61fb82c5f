"""The EXIF thumbnail against copies of the eBee frame that are still a resize, or that no camera wrote: a resize
turned a half turn (what a resizing tool applying EXIF Orientation 3 writes) was refused as matching "neither as a
whole (0.24)" though its camera is the same; a mirrored resize was refused as not matching, with the wrong reason; a
thumbnail too flat at its own width made the best box worse than the whole (0.747 against 0.946); a phone's 512 px
thumbnail is searched coarse to fine (fotogeo.io.exif_thumbnail.thumbnail_view)."""
from __future__ import annotations

import warnings
from types import SimpleNamespace

import pytest

from fotogeo.errors import InputError, InputNote
from fotogeo.io import exif_thumbnail as et
from fotogeo.io.exif import read_image_metadata
from fotogeo.io.exif_camera import focal_of

W, H = 4608, 3456


@pytest.fixture
def original(data_dir):
    return data_dir / "drone_snowpeak" / "img" / "IMG_2186.JPG"


def _edited(src, dst, factor, edit):
    """``src`` resized by ``1/factor`` (OpenCV, area averaging), then ``edit``-ed, into the JPEG ``dst`` with the
    original's APP1 segments (EXIF, its thumbnail, XMP) as they were."""
    import struct

    import cv2
    import numpy as np
    data = src.read_bytes()
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    small = cv2.resize(img, (round(W / factor), round(H / factor)), interpolation=cv2.INTER_AREA)
    enc = cv2.imencode(".jpg", np.ascontiguousarray(edit(small)), [cv2.IMWRITE_JPEG_QUALITY, 95])[1].tobytes()
    segments, i = [], 2
    while i + 4 <= len(data) and data[i] == 0xFF and data[i + 1] != 0xDA:
        length = struct.unpack(">H", data[i + 2:i + 4])[0]
        if data[i + 1] == 0xE1:
            segments.append(data[i:i + 2 + length])
        i += 2 + length
    dst.write_bytes(b"\xff\xd8" + b"".join(segments) + enc[2:])
    return dst


@pytest.mark.data
def test_a_resize_turned_a_half_turn_keeps_the_camera(tmp_path, original):
    """The eBee's camera (FocalPlaneXResolution) has its principal point at the centre and no tangential terms: the
    turned quarter-size copy is the same camera, f = 3210.3 / 4 px."""
    full = focal_of(read_image_metadata(original))[0]
    turned = read_image_metadata(_edited(original, tmp_path / "turned.JPG", 4.0, lambda a: a[::-1, ::-1]))
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        fx, fy, pp, dist, _ = focal_of(turned)
    assert (fx, fy, pp, dist) == (pytest.approx(full / 4, rel=1e-9), pytest.approx(full / 4, rel=1e-9), None, {})
    notes = [str(w.message) for w in got if issubclass(w.category, InputNote)]
    assert len(notes) == 1 and "their EXIF thumbnail agrees (turned a half turn: the same focal length" in notes[0]


@pytest.mark.data
def test_a_half_turned_resize_with_a_calibration_of_its_own_is_refused(tmp_path, original):
    """A DJI calibration (XMP) has its own principal point and tangential terms, now the turned frame's."""
    turned = _edited(original, tmp_path / "turned.JPG", 4.0, lambda a: a[::-1, ::-1])
    meta = SimpleNamespace(path=str(turned), width=W // 4, height=H // 4)
    with pytest.raises(InputError, match=r"matches the file only turned a half turn \(correlation "
                                         r"(0\.9\d|1\.00), better than as stored\).*principal point"
                                         r".*jpegtran -rotate 180.*--camera"):
        et.check_thumbnail(meta, (W, H), 0.25, centred=False)
    assert et.check_thumbnail(meta, (W, H), 0.25, centred=True) == (160, "turned a half turn")


@pytest.mark.data
@pytest.mark.parametrize("way,edit", [("left-right", lambda a: a[:, ::-1]), ("top-bottom", lambda a: a[::-1])])
def test_a_mirrored_resize_is_refused_as_mirrored(tmp_path, original, way, edit):
    mirrored = read_image_metadata(_edited(original, tmp_path / "mirrored.JPG", 4.0, edit))
    with pytest.raises(InputError, match=rf"matches the file only mirrored {way} \(correlation "
                                         r"(0\.9\d|1\.00), better than as stored\): a mirror image is no "
                                         r"camera's view"):
        focal_of(mirrored)


@pytest.mark.data
def test_the_best_box_is_never_worse_than_the_whole(tmp_path, original, monkeypatch):
    """A scene at 2.5 % of the frame's contrast with noise (a thumbnail of std 1.05): the file shrunk to the whole
    thumbnail's width is too flat for the crop search, which used to skip that width and give a box (86,173) of
    0.75 beside the whole's 0.95."""
    import cv2
    import numpy as np
    src = cv2.imread(str(original), cv2.IMREAD_GRAYSCALE).astype(np.float32)
    scene = 200 + 0.025 * (src - src.mean()) + np.random.default_rng(0).normal(0, 2.0, src.shape)
    small = cv2.resize(scene, (160, 120), interpolation=cv2.INTER_AREA).astype(np.uint8)
    thumb = cv2.imdecode(cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, 85])[1], 0)
    half = tmp_path / "flat.jpg"
    cv2.imwrite(str(half), np.clip(cv2.resize(scene, (W // 2, H // 2), interpolation=cv2.INTER_AREA), 0, 255)
                .astype(np.uint8), [cv2.IMWRITE_JPEG_QUALITY, 92])
    monkeypatch.setattr(et, "_thumbnail", lambda path: thumb)
    view = et.thumbnail_view(half, (W, H))
    assert view.r_resize > 0.9 and view.r_crop >= view.r_resize
    assert view.at == (0, 0) and view.crop == (W, H)


@pytest.mark.data
@pytest.mark.parametrize("box,factor", [((0, 0, 2765, 2074), 0.5), ((1152, 864, 3456, 2592), 1.0)],
                         ids=["corner 60% then 1/2", "centre 1/2"])
def test_a_phone_sized_thumbnail_places_a_crop_to_its_pixel(tmp_path, original, monkeypatch, box, factor):
    """A 512 px thumbnail (9 frame pixels each): the widths are searched at 160 px, then refined at 512."""
    import cv2
    img = cv2.imread(str(original), cv2.IMREAD_GRAYSCALE)
    thumb = cv2.resize(img, (512, 384), interpolation=cv2.INTER_AREA)
    x0, y0, x1, y1 = box
    part = cv2.resize(img[y0:y1, x0:x1], (round((x1 - x0) * factor), round((y1 - y0) * factor)),
                      interpolation=cv2.INTER_AREA)
    copy = tmp_path / "crop.jpg"
    cv2.imwrite(str(copy), part, [cv2.IMWRITE_JPEG_QUALITY, 92])
    monkeypatch.setattr(et, "_thumbnail", lambda path: thumb)
    view = et.thumbnail_view(copy, (W, H))
    px = W / 512
    assert view.r_crop > 0.95 and view.r_resize < view.r_crop - 0.1
    assert abs(view.at[0] - x0) <= 2 * px and abs(view.at[1] - y0) <= 2 * px
    assert abs(view.crop[0] - (x1 - x0)) <= 2 * px and abs(view.crop[1] - (y1 - y0)) <= 2 * px
