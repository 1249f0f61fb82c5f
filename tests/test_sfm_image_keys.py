"""The images' own GPS as evidence for an SfM project is keyed so that no image lends its GPS to another's shot
(fotogeo.io.sfm_frame.images_gps / gps_for): an image without GPS still claims its own name, and the same file name
in two folders (a user's copied folders) is matched by the path the project names, or refused by name."""
from __future__ import annotations

import pytest

from fotogeo.errors import InputError
from fotogeo.io.sfm_frame import gps_for, images_gps, project_key
from test_io_exif import write_image


def _gps(lat_s: float = 0.0) -> dict:
    return {"EXIF_Make": "ACME", "EXIF_Model": "Cam", "EXIF_GPSLatitude": f"(46) (30) ({lat_s})",
            "EXIF_GPSLatitudeRef": "N", "EXIF_GPSLongitude": "(7) (15) (0)", "EXIF_GPSLongitudeRef": "E",
            "EXIF_GPSAltitude": "(1300)", "EXIF_GPSAltitudeRef": "0x00"}


def _img(path, tags):
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_image(path, tags)


def test_an_image_without_gps_keeps_its_own_name(tmp_path):
    """``DJI_0001`` has no GPS, ``dji_0001`` has: the project's shot ``DJI_0001`` is the first image's, so it gets
    no GPS (before: ``dji_0001``'s, by the case-insensitive fallback)."""
    bare = _img(tmp_path / "DJI_0001.tif", {"EXIF_Make": "ACME", "EXIF_Model": "Cam"})
    other = _img(tmp_path / "dji_0001.tif", _gps())
    gps = images_gps([bare, other])
    assert set(gps) == {"dji_0001"} and gps.without == ("DJI_0001",)
    assert gps_for(gps, ["DJI_0001"]) == {}
    assert gps_for(gps, ["dji_0001"]) == {"dji_0001": gps["dji_0001"]}
    assert set(gps_for(images_gps([other]), ["DJI_0001"])) == {"DJI_0001"}  # alone, it is the shot's (renamed)


def test_the_same_name_in_two_folders(tmp_path):
    a = _img(tmp_path / "flight1" / "DJI_0001.tif", _gps(0.0))
    b = _img(tmp_path / "flight2" / "DJI_0001.tif", _gps(2.0))  # 62 m further north
    c = _img(tmp_path / "flight1" / "DJI_0002.tif", _gps(1.0))
    gps = images_gps([a, b, c])
    assert set(gps) == {"flight1/DJI_0001", "flight2/DJI_0001", "DJI_0002"}
    # a project naming the bare file name could be either: refused by name, never the last one read
    with pytest.raises(InputError, match=r"images '.*flight1/DJI_0001.tif' and '.*flight2/DJI_0001.tif' share the "
                                         r"name of the project's image 'DJI_0001' but not their GPS \(positions "
                                         r"differ, 61.8 m apart\)"):
        gps_for(gps, ["DJI_0001", "DJI_0002"])
    # a project naming the path (COLMAP keeps image_path-relative names) picks its own
    got = gps_for(gps, [project_key("flight2/DJI_0001.JPG"), project_key(r"flight1\DJI_0002.JPG")])
    assert got == {"flight2/DJI_0001": gps["flight2/DJI_0001"], "flight1/DJI_0002": gps["DJI_0002"]}
    # a project that does not name that image at all is not concerned
    assert gps_for(gps, ["DJI_0002"]) == {"DJI_0002": gps["DJI_0002"]}


def test_a_copied_folder_is_one_image(tmp_path):
    """The same file in two folders (a copy): the same GPS, one piece of evidence, keyed by its name."""
    a = _img(tmp_path / "flight1" / "DJI_0001.tif", _gps(0.0))
    b = _img(tmp_path / "copy" / "DJI_0001.tif", _gps(0.0))
    gps = images_gps([a, b])
    assert list(gps) == ["DJI_0001"] and gps_for(gps, ["DJI_0001"]) == {"DJI_0001": gps["DJI_0001"]}


@pytest.mark.parametrize("key, got", [("flight1/dji_0001", "flight1/DJI_0001"),
                                      ("FLIGHT2/DJI_0001", "flight2/DJI_0001"), ("dji_0001", None), ("DJI_0001", None)])
def test_folders_are_matched_whatever_the_case(tmp_path, key, got):
    """The project's name differing by case from the images' is matched like every other key (main gave ``{}``:
    the shot silently lost its GPS evidence); a bare name that could be either folder's is refused by name."""
    a = _img(tmp_path / "flight1" / "DJI_0001.tif", _gps(0.0))
    b = _img(tmp_path / "flight2" / "DJI_0001.tif", _gps(2.0))
    gps = images_gps([a, b])
    if got is None:
        with pytest.raises(InputError, match=rf"share the name of the project's image '{key}' but not their GPS "
                                             rf"\(positions differ, 61.8 m apart\)"):
            gps_for(gps, [key])
    else:
        assert gps_for(gps, [key]) == {key: gps[got]}


def test_the_same_name_with_another_extension_in_one_folder(tmp_path):
    """``IMG_1.JPG`` with GPS and ``IMG_1.tif`` without, in one folder: keyed by their full names; a project naming
    ``IMG_1`` is refused as "same name, different extension" without a distance (main: the two keys collided and the
    message named one file twice, "0.0 m apart"); a project naming the extension gets that file's GPS or none."""
    jpg = _img(tmp_path / "f" / "IMG_1.JPG", _gps(0.0))
    tif = _img(tmp_path / "f" / "IMG_1.tif", {"EXIF_Make": "ACME", "EXIF_Model": "Cam"})
    gps = images_gps([jpg, tif])
    assert set(gps) == {"f/IMG_1.JPG"} and gps.without == ("f/IMG_1.tif",)
    with pytest.raises(InputError, match=r"images '.*f/IMG_1.JPG' and '.*f/IMG_1.tif' have the same name, different "
                                         r"extension, as the project's image 'IMG_1' but not their GPS \(one of "
                                         r"them carries none\)") as err:
        gps_for(gps, ["IMG_1"])
    assert " m apart" not in str(err.value)
    assert gps_for(gps, ["img_1.jpg"]) == {"img_1.jpg": gps["f/IMG_1.JPG"]}
    assert gps_for(gps, ["f/IMG_1.tif"]) == {}
