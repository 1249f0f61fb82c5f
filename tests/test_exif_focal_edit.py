"""An EXIF FocalLength edited to another value inside the lens's zoom range (nothing in the files tells it from a
zoom position, fotogeo.io.exif_lens) is contradicted by the adjustment: the self-calibration's estimate of the focal
length, kept when the correlation rule holds it fixed (fotogeo.tools.triangulate.exif_focal).

Real eBee JPEGs (Canon IXUS 125 HS, 4.3 mm) resized to 1/4 with their EXIF and XMP, FocalLength edited to 5 mm.
"""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import jpeg_metadata as jm
from fotogeo.errors import FotogeoWarning, ModelError
from fotogeo.geometry.camera import FrameCamera
from fotogeo.tools.triangulate.exif_focal import check_exif_focal

SOURCE = "4.3 mm x FocalPlaneXResolution (186.64 px/mm); calibration scaled by 0.25 to the file's 1152x864 px"
GOOD = {"variance_components": {"image": {"sigma0": 1.0}}}


def _held(estimate, sigma):
    return ({"parameter": "ppx", "estimate": 590.0, "sigma": 2.0},
            {"parameter": "f", "estimate": estimate, "sigma": sigma, "multiple_correlation": 0.9997})


@pytest.mark.parametrize("units", [1.0, 1 / 186.64])  # the camera in pixels, and in millimetres
def test_a_focal_length_its_free_estimate_contradicts_is_named_and_refused_a_quarter_off(units):
    cam = FrameCamera(802.57 * units, (1152 * units, 864 * units), (1152, 864))
    with pytest.warns(FotogeoWarning, match=r"focal length is 803 px from 4.3 mm x FocalPlaneXResolution \(186.64 "
                                            r"px/mm\); with the focal length free the adjustment puts it at 933 ± 8 "
                                            r"px \(5.00 mm\), 16% and 16 σ from it .* edited.*--camera"):
        check_exif_focal(SOURCE, cam, stats := dict(GOOD), False, _held(933.0 * units, 8.0 * units))
    assert "puts it at 933 ± 8 px" in stats["focal_length_check"]  # into report.json's statistics
    with pytest.raises(ModelError, match=r"puts it at 1100 ± 8 px .* 37% and 37 σ .* more than 25% off: .*--camera"):
        check_exif_focal(SOURCE, cam, GOOD, False, _held(1100.0 * units, 8.0 * units))
    check_exif_focal(SOURCE, cam, GOOD, False, _held(814.6 * units, 3.4 * units))  # 1.5 %, 3.5 σ: a real lens
    check_exif_focal(SOURCE, cam, GOOD, False, _held(900.0 * units, 40.0 * units))  # 12 %, 2.4 σ: not shown
    check_exif_focal(SOURCE, cam, GOOD, True, _held(933.0 * units, 8.0 * units))  # --self-calibration given
    check_exif_focal("", cam, GOOD, False, _held(933.0 * units, 8.0 * units))  # --camera
    check_exif_focal(SOURCE, cam, GOOD, False, _held(933.0 * units, float("nan")))  # σ unknown
    check_exif_focal(SOURCE, cam, GOOD, False, ())  # the focal length not held fixed (or never free)


@pytest.mark.data
@pytest.mark.slow
def test_an_ebee_focal_length_edited_inside_its_zoom_range_is_named_or_refused(tmp_path, data_dir):
    """The strip IMG_2280-2282 at 1/4 with FocalLength 5 mm (933 px where the camera took 4.3 mm, 803 px): it used to
    exit 0 with a camera 16 % too long in silence; the adjustment with f free puts it near 4.3 mm, and the run warns
    naming both. At 8.6 mm (twice) it is refused. --self-calibration none takes the images' camera as the user's."""
    src = data_dir / "drone_snowpeak" / "img"
    frames = [jm.resized_copy(src / f"{n}.JPG", tmp_path / f"{n}.JPG", 4) for n in ("IMG_2280", "IMG_2281", "IMG_2282")]
    for f in frames:
        jm.set_exif_tags(f, {0x920A: 5.0})
    res = CliRunner().invoke(_main(), ["triangulate", *map(str, frames), "-o", str(tmp_path / "out")])
    said = " ".join(res.output.split())
    assert res.exit_code == 0, said
    assert "focal length is 933 px from 5 mm x FocalPlaneXResolution" in said and "--camera" in said, said
    free = float(said.split("puts it at ")[1].split(" px")[0].split(" ±")[0])
    assert abs(free / 802.57 - 1) < 0.03, said  # the camera's 4.3 mm, not the tag's 5 mm
    res = CliRunner().invoke(_main(), ["triangulate", *map(str, frames), "-o", str(tmp_path / "quiet"), "-q"])
    assert res.exit_code == 0 and "camera: the images' focal length is 933 px" in res.output, res.output  # -q too
    res = CliRunner().invoke(_main(), ["triangulate", *map(str, frames), "-o", str(tmp_path / "kept"), "-q",
                                       "--self-calibration", "none"])
    assert res.exit_code == 0, res.output
    assert json.loads((tmp_path / "kept" / "report.json").read_text())["camera"]["focal_length"] > 930
    for f in frames:
        jm.set_exif_tags(f, {0x920A: 8.6})
    res = CliRunner().invoke(_main(), ["triangulate", *map(str, frames), "-o", str(tmp_path / "twice"), "-q"])
    said = " ".join(res.output.split())
    assert res.exit_code == 2 and not (tmp_path / "twice" / "exterior_orientation.txt").exists(), said
    assert "more than 25% off" in said and "--camera" in said, said


def _main():
    from fotogeo.cli import main
    return main
