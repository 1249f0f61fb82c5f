"""DJI's ``drone-dji:DewarpData``, read by one public reader (:func:`fotogeo.io.exif_camera.dewarp_data`) that the
camera source and the SfM lens check both use."""
from __future__ import annotations

import pytest

from fotogeo.io.exif import ImageMetadata
from fotogeo.io.exif_camera import dewarp_data, focal_of

DEWARP = "2022-06-08;3713.29,3713.29,7.02,-11.26,-0.112,0.0140,-0.000133,0.000371,-0.0225"


def _meta(xmp, size=(5472, 3648)):
    return ImageMetadata("DJI_0001.JPG", "DJI_0001", *size, make="DJI", xmp=xmp, pixel_dimension=size)


def test_dewarp_data_in_full_resolution_pixels_and_brown_terms():
    fx, fy, pp, dist = dewarp_data(_meta({"drone-dji:DewarpData": DEWARP}))
    assert (fx, fy) == (3713.29, 3713.29)
    assert pp == pytest.approx((5472 / 2 + 7.02, 3648 / 2 - 11.26))  # offsets from the centre, corner convention
    assert dist == {"k1": -0.112, "k2": 0.0140, "p1": -0.000133, "p2": 0.000371, "k3": -0.0225}


def test_dewarp_data_scaled_and_undistorted_and_absent():
    fx, _, pp, _ = dewarp_data(_meta({"drone-dji:DewarpData": DEWARP}, (2736, 1824)), 0.5)
    assert fx == pytest.approx(3713.29 / 2) and pp == pytest.approx((1368 + 3.51, 912 - 5.63))
    flat = dewarp_data(_meta({"drone-dji:DewarpData": DEWARP, "drone-dji:DewarpFlag": "1"}))
    assert flat[0] == 3713.29 and flat[3] == {}  # the camera undistorted the file itself
    for xmp in ({}, {"drone-dji:DewarpData": "2022-06-08;3713.29,3713.29,7.02"},
                {"drone-dji:DewarpData": DEWARP.replace("3713.29,3713.29", "0,0")}):
        assert dewarp_data(_meta(xmp)) is None


def test_the_camera_source_reads_the_same():
    meta = _meta({"drone-dji:DewarpData": DEWARP})
    fx, fy, pp, dist, src = focal_of(meta)
    assert (fx, fy, pp, dist) == dewarp_data(meta) and src == "drone-dji:DewarpData"
