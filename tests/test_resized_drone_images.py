"""Images downsampled after capture keep the camera's full-resolution calibration tags: the camera read from
them is scaled to the file (fotogeo.io.exif_camera), and sources that contradict each other are named.

DJI-like files (DewarpData, CalibratedFocalLength/OpticalCenter, FocalLengthIn35mmFilm, PixelXDimension) written
at a reduced size, and the real eBee JPEGs (Canon: FocalLength x FocalPlaneXResolution, PixelXDimension 4608)
resized by OpenCV with their EXIF/XMP segments kept as they were.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import jpeg_metadata as jm
from fotogeo.errors import InputError
from fotogeo.io.exif_block import read_exif_block
from test_io_exif import write_image, xmp_packet

FULL, FX, OFF = (640, 480), 520.0, (1.5, -2.0)
DEWARP = "2024-01-01;520,521,1.5,-2,-0.06,0.02,0.0004,-0.0003,0"
BASE = {"EXIF_Make": "DJI", "EXIF_Model": "FC-render", "EXIF_GPSLatitude": "(46) (30) (0)",
        "EXIF_GPSLatitudeRef": "N", "EXIF_GPSLongitude": "(7) (15) (0)", "EXIF_GPSLongitudeRef": "E",
        "EXIF_GPSAltitude": "(1300)", "EXIF_GPSAltitudeRef": "0x00"}
F35 = FX * 43.2666 / math.hypot(*FULL)  # the 35 mm equivalent of the full frame


def _dim(w, h):
    return {"EXIF_PixelXDimension": str(w), "EXIF_PixelYDimension": str(h)}


def _camera(path):
    return next(iter(read_exif_block([path]).cameras.values()))


@pytest.mark.parametrize("factor", [2, 4, 5])
def test_dewarp_data_is_scaled_to_a_downsampled_file(tmp_path, factor):
    size = (FULL[0] // factor, FULL[1] // factor)
    tags = {**BASE, **_dim(*FULL), "EXIF_FocalLengthIn35mmFilm": f"{round(F35)}"}
    cam = _camera(write_image(tmp_path / "a.tif", tags, xmp_packet(f"><drone-dji:DewarpData>{DEWARP}"
                                                                   f"</drone-dji:DewarpData>"), size=size))
    s = 1.0 / factor
    assert cam.camera.image_size == size
    assert (cam.camera.fx, cam.camera.fy) == pytest.approx((520 * s, 521 * s), rel=1e-12)
    assert cam.camera.principal_point == pytest.approx((size[0] / 2 + 1.5 * s, size[1] / 2 - 2.0 * s), rel=1e-12)
    assert cam.distortion["k1"] == -0.06 and cam.distortion["p2"] == -0.0003  # normalised: unchanged
    assert f"scaled by {s:.4g}" in cam.source and "PixelXDimension 640x480" in cam.source
    # the full-resolution file is read as written
    full = _camera(write_image(tmp_path / "b.tif", tags, xmp_packet(f"><drone-dji:DewarpData>{DEWARP}"
                                                                    f"</drone-dji:DewarpData>"), size=FULL))
    assert full.camera.fx == 520.0 and "scaled" not in full.source


def test_calibrated_focal_length_and_optical_centre_are_scaled(tmp_path):
    xmp = xmp_packet(" drone-dji:CalibratedFocalLength='520' drone-dji:CalibratedOpticalCenterX='320'"
                     " drone-dji:CalibratedOpticalCenterY='240'>")
    cam = _camera(write_image(tmp_path / "a.tif", {**BASE, **_dim(*FULL)}, xmp, size=(160, 120)))
    assert cam.camera.fx == pytest.approx(130.0) and cam.camera.principal_point == pytest.approx((80.0, 60.0))


def test_contradicting_sources_are_named(tmp_path):
    dewarp = xmp_packet(f"><drone-dji:DewarpData>{DEWARP}</drone-dji:DewarpData>")
    # the resizing tool updated PixelXDimension but not the calibration: the 35 mm equivalent contradicts it
    tags = {**BASE, **_dim(160, 120), "EXIF_FocalLengthIn35mmFilm": f"{round(F35)}"}
    with pytest.raises(InputError, match=r"DewarpData is 520 px, FocalLengthIn35mmFilm 28 mm gives 129 px, but its "
                                         r"EXIF PixelXDimension says 160x120, the file's own size: "
                                         r"a copy resized by 1/4 .*-PixelXDimension=640 "
                                         r"-PixelYDimension=480 FILE"):
        read_exif_block([write_image(tmp_path / "a.tif", tags, dewarp, size=(160, 120))])
    # the optical centre belongs to a 640 x 480 frame, the file is 160 x 120 and says nothing of its size
    xmp = xmp_packet(" drone-dji:CalibratedFocalLength='520' drone-dji:CalibratedOpticalCenterX='320'"
                     " drone-dji:CalibratedOpticalCenterY='240'>")
    with pytest.raises(InputError, match=r"CalibratedOpticalCenterX/Y \(320, 240\) belong to a 640x480 frame"):
        read_exif_block([write_image(tmp_path / "b.tif", BASE, xmp, size=(160, 120))])
    # resized unevenly (or cropped): no single factor
    with pytest.raises(InputError, match=r"PixelYDimension is 640x480, not the file's size times one factor"):
        read_exif_block([write_image(tmp_path / "c.tif", {**BASE, **_dim(*FULL)}, dewarp, size=(160, 100))])



@pytest.mark.data
@pytest.mark.slow
def test_resized_real_frames_triangulate_from_their_files(tmp_path, data_dir):
    """Three consecutive eBee frames at a quarter of their size: the camera scaled by PixelXDimension, the strip
    adjusted from the files alone, its centres within 3σ of the GPS; the same copies without PixelXDimension (nothing
    tells they were resized) get the full-size focal length and the run is refused."""
    src = data_dir / "drone_snowpeak" / "img"
    names = ["IMG_2280", "IMG_2281", "IMG_2282"]
    (tmp_path / "small").mkdir()
    frames = [jm.resized_copy(src / f"{n}.JPG", tmp_path / "small" / f"{n}.JPG", 4) for n in names]
    full_fx = _camera(src / "IMG_2280.JPG").camera.fx
    small = _camera(frames[0])
    assert small.camera.image_size == (1152, 864) and small.camera.fx == pytest.approx(full_fx / 4, rel=1e-12)
    out = tmp_path / "out"
    res = CliRunner().invoke(main_cli(), ["triangulate", *map(str, frames), "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    rep = json.loads((out / "report.json").read_text())
    gps = read_exif_block(frames).shots
    from fotogeo.io.camera import read_exterior_orientation
    for n, e in read_exterior_orientation(out / "exterior_orientation.txt").items():
        d = np.array([e.X, e.Y, e.Z]) - gps[n].position
        assert np.hypot(d[0], d[1]) < 3 * gps[n].sigma_h and abs(d[2]) < 3 * gps[n].sigma_v, (n, d)
    assert rep["statistics"]["image_rms_px"] < 0.5
    # without PixelXDimension, RelatedImageWidth and the maker note nothing says the file was resized: the focal
    # length is 4x too long
    for f in frames:
        for k, tag in enumerate((0xA002, 0xA005, 0x927C)):
            jm.rename_ifd0_tag(f, tag, 0xA0F2 + k, exif_ifd=True)
    assert _camera(frames[0]).camera.fx == pytest.approx(full_fx, rel=1e-12)
    res = CliRunner().invoke(main_cli(), ["triangulate", *map(str, frames), "-o", str(tmp_path / "o2"), "-q",
                                          "--undetermined", "fail"])
    assert res.exit_code != 0 and "does not determine" in res.output, res.output  # refused, not silently off


@pytest.mark.data
def test_resized_copies_without_their_xmp_are_refused_naming_the_resize(tmp_path, data_dir):
    """The eBee frames resized with their EXIF but not their XMP (as PIL's save(exif=...) leaves them) lose the
    attitude prior: the two strips, which do not overlap each other, leave each strip's roll free and the run is
    refused — the refusal names the resize and the fix (copy the XMP), not only "near-parallel rays or no datum".
    With the XMP kept the copies read the originals' attitude."""
    src = data_dir / "drone_snowpeak" / "img"
    names = ["IMG_2186", "IMG_2188", "IMG_2189", "IMG_2280", "IMG_2281", "IMG_2282"]
    (tmp_path / "bare").mkdir()
    (tmp_path / "kept").mkdir()
    bare = [jm.resized_copy(src / f"{n}.JPG", tmp_path / "bare" / f"{n}.JPG", 4, xmp=False) for n in names]
    kept = jm.resized_copy(src / "IMG_2186.JPG", tmp_path / "kept" / "IMG_2186.JPG", 4)
    block = read_exif_block(bare)
    assert set(block.lost) == set(names) and all(s.angles is None for s in block.shots.values())
    assert "1152x864 (its EXIF PixelXDimension says 4608x3456) without XMP" in block.lost["IMG_2186"]
    assert any(n.startswith("resized copies without XMP") for n in block.notes)
    with_xmp = read_exif_block([kept])
    assert not with_xmp.lost and with_xmp.shots["IMG_2186"].angles is not None
    assert not read_exif_block([src / "IMG_2186.JPG"]).lost  # the original: nothing lost
    res = CliRunner().invoke(main_cli(), ["triangulate", *map(str, bare), "-o", str(tmp_path / "out"), "-q"])
    assert res.exit_code != 0, res.output
    said = " ".join(res.output.split())
    assert "IMG_2186, IMG_2188, IMG_2189, IMG_2280, IMG_2281 and 1 more: a copy resized to 1152x864" in said, said
    assert "exiftool -tagsFromFile ORIGINAL -xmp:all COPY" in said and "--geoinfo, --eo" in said, said


def test_what_was_lost_is_said_once_per_reason():
    from fotogeo.tools.triangulate.tool import _grouped
    lost = {f"F{i}": "resized" for i in range(7)} | {"G": "unreadable"}
    assert _grouped(lost) == "F0, F1, F2, F3, F4 and 2 more: resized; G: unreadable"


def test_a_frame_overlapping_none_gets_advice_on_the_source_given():
    """"check the orientation file" only when one was given (--eo)."""
    from fotogeo.tools.triangulate.tool import _overlap_advice
    assert _overlap_advice("eo.json", None, None) == "check the orientation file (--eo eo.json)"
    for camera in (None, "cam.yaml"):
        said = _overlap_advice(None, camera, None)
        assert "orientation file" not in said and "GPS and attitude" in said
    assert "camera read from the images' EXIF/XMP" in _overlap_advice(None, None, None)


def main_cli():
    from fotogeo.cli import main
    return main


@pytest.mark.data
def test_copies_with_pixel_dimension_rewritten_are_refused_by_their_residuals(tmp_path, data_dir):
    """eBee frames resized to 1/2 with EXIF PixelXDimension rewritten to the new size (Photoshop/Lightroom exports),
    no other record of the camera's size left (RelatedImageWidth, maker note) and FocalPlaneXResolution left for the
    full frame: the focal length read is 3210 px at 2304 px, twice too long,
    and no FocalLengthIn35mmFilm contradicts it. The adjustment cannot estimate f (held fixed for its correlation
    with the height) and bends the rest: the tie points' residuals are several times least-squares matching's
    precision, and the run is refused naming the camera's source, the sensor it implies and the fix."""
    src = data_dir / "drone_snowpeak" / "img"
    frames = [jm.resized_copy(src / f"{n}.JPG", tmp_path / f"{n}.JPG", 2) for n in ("IMG_2186", "IMG_2188", "IMG_2189")]
    for f in frames:
        jm.set_integer_tag(f, 0xA002, 2304, exif_ifd=True)
        jm.set_integer_tag(f, 0xA003, 1728, exif_ifd=True)
        for k, tag in enumerate((0xA005, 0x927C)):  # RelatedImageWidth and the maker note would name the copy
            jm.rename_ifd0_tag(f, tag, 0xA0F2 + k, exif_ifd=True)  # (tests/test_exif_sizes.py): none left here
    assert _camera(frames[0]).camera.fx == pytest.approx(_camera(src / "IMG_2186.JPG").camera.fx, rel=1e-12)
    res = CliRunner().invoke(main_cli(), ["triangulate", *map(str, frames), "-o", str(tmp_path / "out"), "-q"])
    said = " ".join(res.output.split())
    assert res.exit_code != 0 and not (tmp_path / "out" / "exterior_orientation.txt").exists(), said
    assert "times least-squares matching's precision" in said and "focal 3210 px at 2304x1728 px" in said, said
    assert "sensor 3.09 x 2.31 mm" in said and "--camera" in said, said


def test_exif_focal_check_applies_to_focal_plane_cameras_not_given_ones():
    """The residual check (fotogeo.tools.triangulate.exif_focal) refuses only a focal length from EXIF
    FocalPlaneXResolution, and not when --self-calibration was given (the camera taken as the user's)."""
    from fotogeo.errors import ModelError
    from fotogeo.geometry.camera import FrameCamera
    from fotogeo.tools.triangulate.exif_focal import MAX_IMAGE_SIGMA0, check_exif_focal
    cam = FrameCamera(3210.0, (2304.0, 1728.0), (2304, 1728))
    src = "4.3 mm x FocalPlaneXResolution (746.57 px/mm)"
    bad = {"variance_components": {"image": {"sigma0": 1.0, "sigma0_given": 2 * MAX_IMAGE_SIGMA0}}}
    good = {"variance_components": {"image": {"sigma0": 0.9 * MAX_IMAGE_SIGMA0}}}
    with pytest.raises(ModelError, match=r"focal 3210 px at 2304x1728 px .* sensor 3.09 x 2.31 mm"):
        check_exif_focal(src, cam, bad, given=False)
    check_exif_focal(src, cam, good, given=False)
    check_exif_focal(src, cam, bad, given=True)
    check_exif_focal("drone-dji:DewarpData", cam, bad, given=False)
    check_exif_focal("", cam, bad, given=False)


@pytest.mark.data
def test_a_long_refusal_is_printed_whole(tmp_path, data_dir):
    """Issue 32: a refusal is never cut. The strip's 1/4 copies without XMP are refused with what the files lost
    before the adjustment's own reason and its fix, 1,100 characters in all: the reason was cut to "(0.43 m RMS from
    … — give the attitude a prior", losing why the attitude is undetermined and which pairs were tried."""
    names = ["IMG_2280", "IMG_2281", "IMG_2282"]
    src = data_dir / "drone_snowpeak" / "img"
    bare = [jm.resized_copy(src / f"{n}.JPG", tmp_path / f"{n}.JPG", 4, xmp=False) for n in names]
    res = CliRunner().invoke(main_cli(), ["triangulate", *map(str, bare), "-o", str(tmp_path / "out"), "-q"])
    assert res.exit_code == 1, res.output
    said = " ".join(res.output.split())
    assert "…" not in said, said
    assert "a rotation of the whole block about that line" in said and "pair(s) tried" in said, said
    assert "give the attitude a prior (--eo-sigma-angle" in said and "exiftool -tagsFromFile ORIGINAL" in said, said


def test_one_line_without_a_limit_keeps_the_whole_text():
    from fotogeo.errors import one_line
    text = "reason " * 200 + "— the fix"
    assert one_line(text, limit=None) == text.strip() and "…" in one_line(text)
