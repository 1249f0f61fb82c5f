"""A copy resized with every record of its size rewritten (PixelXDimension, RelatedImageWidth) and its maker note
dropped is still named by what describes the sensor, not the file (fotogeo.io.exif_camera): FocalPlaneX/YResolution
over the sensor that FocalLength and FocalLengthIn35mmFilm imply, the records, the factor and the exiftool fix.

Real eBee JPEGs (Canon IXUS 125 HS, 4.3 mm; the camera writes no FocalLengthIn35mmFilm, here added as 24 mm, its
published equivalent: FocalPlaneXResolution over 4608 px gives a 6.17 x 4.62 mm sensor, i.e. 24.1 mm) and DJI-like
files; the originals and the copies resized right are read as before.
"""
from __future__ import annotations

import pytest

import jpeg_metadata as jm
from fotogeo.errors import InputError
from fotogeo.io.exif import read_image_metadata
from fotogeo.io.exif_block import read_exif_block
from fotogeo.io.exif_camera import focal_of, sensor_frame
from test_io_exif import write_image

F35, PX, PY, INTEROP_W, INTEROP_H, MAKER_NOTE = 0xA405, 0xA002, 0xA003, 0x1001, 0x1002, 0x927C


def _copy(src, dst, factor, *, rewrite: bool):
    copy = jm.resized_copy(src, dst, factor)
    jm.set_exif_tags(copy, {F35: 24})
    if rewrite:
        m = read_image_metadata(copy)
        jm.set_exif_tags(copy, {PX: m.width, PY: m.height}, interop={INTEROP_W: m.width, INTEROP_H: m.height},
                         drop=(MAKER_NOTE,))
    return read_image_metadata(copy)


@pytest.mark.data
@pytest.mark.parametrize("factor,by", [(2, "1/2"), (4, "1/4"), (1 / 0.6, "3/5")])
def test_every_size_rewritten_is_named_by_the_sensor(tmp_path, data_dir, factor, by):
    src = data_dir / "drone_snowpeak" / "img" / "IMG_2280.JPG"
    full = focal_of(read_image_metadata(src))[0]
    bad = _copy(src, tmp_path / "bad.JPG", factor, rewrite=True)
    assert [s for _, s in bad.written_sizes] == [(bad.width, bad.height)]  # nothing left records 4608 x 3456
    with pytest.raises(InputError, match=rf"FocalPlaneXResolution/YResolution \(746.6, 747.6 px/mm\) over the sensor "
                                         rf"that FocalLength 4.3 mm and FocalLengthIn35mmFilm 24 mm imply describe a "
                                         rf"4630x3477 frame but its EXIF PixelXDimension says {bad.width}x"
                                         rf"{bad.height}, the file's own size: a copy resized by {by} .*exiftool "
                                         rf"-PixelXDimension=4608 -PixelYDimension=3456 -RelatedImageWidth=4608 "
                                         rf"-RelatedImageHeight=3456 FILE"):
        focal_of(bad)
    right = _copy(src, tmp_path / "right.JPG", factor, rewrite=False)  # the same tag on a copy resized right
    assert focal_of(right)[0] == pytest.approx(full * right.width / 4608, rel=1e-3)
    jm.set_exif_tags(tmp_path / "bad.JPG", {PX: 4608, PY: 3456}, interop={INTEROP_W: 4608, INTEROP_H: 3456})  # the fix
    assert focal_of(read_image_metadata(tmp_path / "bad.JPG"))[0] == pytest.approx(focal_of(right)[0], rel=1e-12)


@pytest.mark.data
def test_the_originals_agree_with_their_sensor(tmp_path, data_dir):
    """Every eBee original, with the 35 mm equivalent added, describes its own 4608 x 3456 frame within 0.5 %."""
    for src in sorted((data_dir / "drone_snowpeak" / "img").glob("*.JPG")):
        meta = read_image_metadata(src)
        assert meta.focal_35mm is None  # as the camera wrote it: the check does not apply
        copy = tmp_path / src.name
        copy.write_bytes(src.read_bytes())
        jm.set_exif_tags(copy, {F35: 24})
        w, h = sensor_frame(read_image_metadata(copy))
        assert abs(w / 4608 - 1) < 0.005 and abs(h / 3456 - 1) < 0.007
        assert focal_of(read_image_metadata(copy))[0] == pytest.approx(focal_of(meta)[0])


DJI = {"EXIF_Make": "DJI", "EXIF_Model": "FC-test", "EXIF_FocalLength": "(8.8)", "EXIF_FocalLengthIn35mmFilm": "24",
       "EXIF_FocalPlaneXResolution": "(4145.45)", "EXIF_FocalPlaneYResolution": "(4145.45)",
       "EXIF_FocalPlaneResolutionUnit": "3"}  # 13.2 mm x 8.8 mm at 5472 x 3648 px: 414.5 px/mm (in cm)


def test_a_dji_copy_with_its_calibration_and_sizes_rewritten(tmp_path):
    """DewarpData gives the focal, checked against the 35 mm equivalent (the focal plane is not used beside a DJI
    calibration); the factor and the fix are named, and several images are refused once each."""
    xmp = ("<?xpacket begin=''?><x:xmpmeta xmlns:x='adobe:ns:meta/'><rdf:RDF xmlns:rdf='http://www.w3.org/1999/02/"
           "22-rdf-syntax-ns#'><rdf:Description xmlns:drone-dji='http://www.dji.com/drone-dji/1.0/' drone-dji:"
           "DewarpData='2024-01-01;3650,3650,10,-8,0,0,0,0,0'/></rdf:RDF></x:xmpmeta>")
    size = (5472 // 8, 3648 // 8)
    right = write_image(tmp_path / "right.tif", {**DJI, "EXIF_PixelXDimension": "5472",
                                                 "EXIF_PixelYDimension": "3648"}, xmp, size=size)
    assert focal_of(read_image_metadata(right))[0] == pytest.approx(3650 / 8)
    bad = [write_image(tmp_path / f"bad{k}.tif", {**DJI, "EXIF_PixelXDimension": str(size[0]),
                                                  "EXIF_PixelYDimension": str(size[1])}, xmp, size=size)
           for k in range(3)]
    with pytest.raises(InputError, match=r"'.*bad0.tif' \(684x456 px\): the focal length from drone-dji:DewarpData "
                                         r"is 3650 px, FocalLengthIn35mmFilm 24 mm gives 456 px, but its EXIF "
                                         r"PixelXDimension says 684x456, the file's own size: a copy resized by 1/8 "
                                         r".*-PixelXDimension=5472 "
                                         r"-PixelYDimension=3648 FILE\) \(and 2 more image\(s\) refused on their own "
                                         r"camera tags: bad1, bad2\)") as e:
        read_exif_block(bad)
    assert e.value.frames == ("bad0", "bad1", "bad2")


@pytest.mark.data
@pytest.mark.parametrize("f35, zoom, refused", [
    (48, (2, 1), None),  # the camera's own full-size file at 2x digital zoom, the 35 mm equivalent including it
    (48, None, r"the file is 2 times larger than that frame — a digital zoom the file does not state \(EXIF "
               r"DigitalZoomRatio\), an enlarged copy or its tags edited \(its focal length in pixels would come out "
               r"2 times too short\); give the camera"),
    (24, (2, 1), r"DigitalZoomRatio is 2 .* describe a 4630x3477 frame, the file's own: both records include the "
                 r"zoom or neither does: .*give the camera \(--camera\)"),
    (36, (2, 1), r"DigitalZoomRatio is 2 .* describe a 3087x2318 frame, neither the file's 4608x3456 nor 1/2 of it"),
    (None, (2, 1), r"DigitalZoomRatio is 2 .* only 4.3 mm x FocalPlaneXResolution .* gives its focal length, which "
                   r"may or may not include the zoom"),
    (24, (0, 1), None)])  # 0: no digital zoom used
def test_a_digital_zoom_is_named_and_used_when_the_records_agree(tmp_path, data_dir, f35, zoom, refused):
    """An unresized eBee original tagged as taken at digital zoom: with FocalLengthIn35mmFilm 48 and DigitalZoomRatio
    2 the focal plane x 2 is the file's camera (main refused it as 'a copy resized by 2 ... 0.5 times too long');
    records that cannot tell whether they include the zoom are refused naming it; without the zoom tag the file is
    not called a resize."""
    import shutil
    dst = shutil.copy(data_dir / "drone_snowpeak" / "img" / "IMG_2280.JPG", tmp_path / "z.JPG")
    base = focal_of(read_image_metadata(dst))[0]  # 4.3 mm x 746.6 px/mm: no FocalLengthIn35mmFilm in the original
    jm.set_exif_tags(dst, {**({F35: f35} if f35 else {}), **({0xA404: zoom} if zoom else {})})
    m = read_image_metadata(dst)
    if refused:
        with pytest.raises(InputError, match=refused):
            focal_of(m)
        return
    f, _, _, _, src = focal_of(m)
    z = zoom[0] if zoom[0] else 1
    assert f == pytest.approx(base * z, rel=1e-12) and ("DigitalZoomRatio 2" in src) == (z == 2)


@pytest.mark.data
@pytest.mark.parametrize("tags,px", [({F35: 35}, r"3210 px .* FocalLengthIn35mmFilm 35 mm gives 4659 px"),
                                     ({F35: 24, 0x920A: 5.0}, r"3733 px .* FocalLengthIn35mmFilm 24 mm gives 3195 px")],
                         ids=["35 mm equivalent edited", "focal length edited"])
def test_focal_records_that_contradict_each_other_in_a_resized_copy_are_named_so(tmp_path, data_dir, tags, px):
    """A 1/4 copy whose PixelXDimension still says 4608x3456 (a resize the file's size agrees with) and one of whose
    focal records was edited: a resize changes neither record, yet it was explained as "a copy resized by 3/8 with its
    size records rewritten" with an exiftool fix writing PixelXDimension=3072 — a wrong camera if followed."""
    src = data_dir / "drone_snowpeak" / "img" / "IMG_2280.JPG"
    copy = jm.resized_copy(src, tmp_path / "copy.JPG", 4)
    jm.set_exif_tags(copy, tags)
    with pytest.raises(InputError, match=r"\(1152x864 px\): its EXIF FocalLength .* FocalPlaneXResolution "
                                         r"\(746.6 px/mm\) gives " + px + r": the two focal records contradict "
                                         r"each other .*one of them edited .*give the camera \(--camera\) or use "
                                         r"the originals$") as e:
        focal_of(read_image_metadata(copy))
    assert "exiftool" not in str(e.value) and "a copy resized by" not in str(e.value)
