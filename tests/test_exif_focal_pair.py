"""The residual check of a focal length from EXIF FocalPlaneXResolution tests the hypothesis of a resized copy
(the focal length divided by the resize factor) instead of judging σ₀ alone (fotogeo.tools.triangulate.exif_focal,
issue 32): a pair holds the camera fixed, so its σ₀ carries the lens distortion, and cannot tell the focal length.

Real eBee JPEGs (Canon IXUS 125 HS, 4.3 mm): the pair IMG_2280/2281 at full size (σ₀ 6.3 with the right camera was
refused), and 1/2 copies with PixelXDimension rewritten and no other record of the camera's size.
"""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import jpeg_metadata as jm
from fotogeo.errors import FotogeoWarning, ModelError
from fotogeo.geometry.camera import FrameCamera
from fotogeo.tools.triangulate.exif_focal import CLEARLY, MAX_IMAGE_SIGMA0, check_exif_focal

SOURCE = "4.3 mm x FocalPlaneXResolution (746.57 px/mm)"
CAM = FrameCamera(3210.0, (4608.0, 3456.0), (4608, 3456))


def _stats(s0):
    return {"variance_components": {"image": {"sigma0": 1.0, "sigma0_given": s0}}}


def test_a_resize_factor_that_fits_clearly_better_is_refused_one_that_does_not_is_named():
    s0 = 2 * MAX_IMAGE_SIGMA0
    with pytest.raises(ModelError, match=r"residuals are 8.0 times .* 1.2 with focal 1605 px \(1/2\).*--camera"):
        check_exif_focal(SOURCE, CAM, _stats(s0), False, refit=lambda: {2: 1.2, 3: 5.2})
    with pytest.warns(FotogeoWarning, match=r"6.5 with focal 1605 px \(1/2\).* cannot tell .* lens distortion"):
        check_exif_focal(SOURCE, CAM, stats := _stats(6.3), False, refit=lambda: {2: 6.5, 3: 5.6},
                         lens_modelled=False)
    assert "cannot tell" in stats["focal_length_check"] and stats["focal_hypotheses"] == {"1": 6.3, "2": 6.5, "3": 5.6}
    # the camera held fixed: σ₀ below the threshold says nothing of the focal length either (a 1/4 copy gave 2.4)
    with pytest.warns(FotogeoWarning, match=r"2.4 times .* 1.7 with focal 802 px \(1/4\)"):
        check_exif_focal(SOURCE, CAM, _stats(2.4), False, refit=lambda: {2: 1.9, 4: 1.7}, lens_modelled=False)
    # the block confirms the focal length (every other fits CLEARLY worse, or not at all): no word
    check_exif_focal(SOURCE, CAM, _stats(5.0), False, refit=lambda: {2: 5.0 * CLEARLY + 1, 3: float("inf")})
    # a self-calibrated block below the threshold is not adjusted again
    check_exif_focal(SOURCE, CAM, _stats(2.3), False, refit=lambda: pytest.fail("adjusted again"))
    # no plausible resize factor: σ₀ alone, as without a refit
    with pytest.raises(ModelError, match="more than 4"):
        check_exif_focal(SOURCE, CAM, _stats(s0), False, refit=dict)


def _main():
    from fotogeo.cli import main
    return main


def _rewritten_half(src, dst):
    """A 1/2 copy with PixelXDimension rewritten and RelatedImageWidth and the maker note gone (nothing in the file
    records the camera's size: its focal length from FocalPlaneXResolution is twice too long)."""
    f = jm.resized_copy(src, dst, 2)
    jm.set_integer_tag(f, 0xA002, 2304, exif_ifd=True)
    jm.set_integer_tag(f, 0xA003, 1728, exif_ifd=True)
    for k, tag in enumerate((0xA005, 0x927C)):
        jm.rename_ifd0_tag(f, tag, 0xA0F2 + k, exif_ifd=True)
    return f


@pytest.mark.data
def test_a_real_pair_with_the_right_camera_is_not_refused(tmp_path, data_dir):
    """IMG_2280/2281 at full size: the camera is right (the 8-frame block's self-calibration puts f at 3226 px),
    but two frames hold it fixed and their σ₀ (6.3) carries the lens; f/2 and f/3 fit no better: a warning."""
    src = data_dir / "drone_snowpeak" / "img"
    frames = jm.copy_frames(src, ["IMG_2280", "IMG_2281"], tmp_path / "img")
    res = CliRunner().invoke(_main(), ["triangulate", *map(str, frames), "-o", str(tmp_path / "out"), "-q"])
    assert res.exit_code == 0, res.output
    stats = json.loads((tmp_path / "out" / "report.json").read_text())["statistics"]
    assert stats["focal_hypotheses"]["1"] > MAX_IMAGE_SIGMA0  # what was refused
    assert "cannot tell" in stats["focal_length_check"]


@pytest.mark.data
def test_a_resized_pair_is_named_and_a_resized_triple_refused(tmp_path, data_dir):
    """The 1/2 copies: the pair IMG_2280/2281 cannot tell the focal length (named in a warning); with IMG_2282 the
    block calibrates the lens and half the focal length fits several times better: refused."""
    src = data_dir / "drone_snowpeak" / "img"
    (tmp_path / "img").mkdir()
    frames = [_rewritten_half(src / f"{n}.JPG", tmp_path / "img" / f"{n}.JPG")
              for n in ("IMG_2280", "IMG_2281", "IMG_2282")]
    res = CliRunner().invoke(_main(), ["triangulate", *map(str, frames[:2]), "-o", str(tmp_path / "pair"), "-q"])
    said = " ".join(res.output.split())
    assert "focal 3210 px at 2304x1728 px" in said and "with focal 1605 px (1/2)" in said, said
    res = CliRunner().invoke(_main(), ["triangulate", *map(str, frames), "-o", str(tmp_path / "triple"), "-q"])
    said = " ".join(res.output.split())
    assert res.exit_code != 0 and not (tmp_path / "triple" / "exterior_orientation.txt").exists(), said
    assert "focal 3210 px at 2304x1728 px" in said and "with focal 1605 px (1/2)" in said and "--camera" in said, said
