"""A camera guessed from the images' EXIF is calibrated by default, as ODM and Metashape do.

A rendered oblique DJI-like block (tests/rendered_oblique.py: four headings, gimbal at −60°, RTK positions of
σ 2 cm, a lens with Brown distortion k1 −0.06, k2 0.02, p1/p2 4e-4/−3e-4 and a principal point 2.5 px off the
centre) whose files carry only what a camera without a calibration writes: ``FocalLengthIn35mmFilm`` (28 mm, an
integer: the focal length 0.4 % short) and no DJI ``DewarpData``. Held fixed, that pinhole cannot fit the RTK
positions and the block is refused; by default (no ``--self-calibration``) the focal length, the principal point
and the distortion are estimated and every frame is oriented — the principal point too, correlated beyond
0.999 with the attitudes and p2 but determined to a fraction of a pixel (held fixed, its offset went into the
attitudes and a quarter of the frames disagreed with their RTK positions). A second lens (principal point
(−4, 3) px off, k1 −0.10) with another seed checks the rule is not tuned to one case.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

import rendered_oblique as ro
from fotogeo.cli import main
from fotogeo.geometry.camera import ExteriorOrientation
from fotogeo.io.camera import read_exterior_orientation

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def uncalibrated(tmp_path_factory):
    return ro.oblique_block(tmp_path_factory.mktemp("exif_only"), seed=0, rtk=0.02, calibration=False)


def _run(block, out, *extra):
    return CliRunner().invoke(main, ["triangulate", *map(str, block["gimbal"]), "-o", str(out), "-q", *extra])


def test_a_camera_guessed_from_exif_is_calibrated_by_default(uncalibrated, tmp_path):
    res = _run(uncalibrated, tmp_path / "auto")
    assert res.exit_code == 0, res.output
    assert "camera: estimated: the camera is guessed from the images' EXIF" in res.output
    rep = json.loads((tmp_path / "auto" / "report.json").read_text())
    assert rep["start"]["self_calibration"].startswith("estimated")
    camera = (tmp_path / "auto" / "camera.yaml").read_text()
    assert camera.startswith("adjusted:") and "type: brown" in camera
    k1 = float(camera.split("k1:")[1].split()[0])
    assert -0.066 < k1 < -0.054, camera  # the lens's −0.06
    f = float(camera.split("focal_len:")[1].split()[0])
    assert abs(f - ro.FOCAL_PX) < 2.0, camera  # 520 px; the EXIF's 28 mm gives 517.7
    ppx, ppy = (float(camera.split(f"{c}:")[1].split()[0]) * max(ro.SIZE) for c in ("cx", "cy"))
    assert abs(ppx - ro.PP_OFFSET[0]) < 0.5 and abs(ppy - ro.PP_OFFSET[1]) < 0.5, camera  # (1.5, −2.0) px
    # every frame (measured 0.020 / 0.041 m, 0.017 / 0.042°; with the principal point held fixed 15 of 20, 0.27°)
    _assert_oriented(uncalibrated, tmp_path / "auto", 0.05, 0.08, 0.05, 0.1)


def _assert_oriented(block, out, position_median, position_max, angle_median, angle_max):
    """Every frame oriented, its centre and attitude within the given metres and degrees of the truth."""
    adjusted = read_exterior_orientation(out / "exterior_orientation.txt")
    assert len(adjusted) == len(block["truth"]), sorted(set(block["truth"]) - set(adjusted))
    truth = block["truth"]
    errors = [np.linalg.norm(np.subtract([e.X, e.Y, e.Z], [truth[n].X, truth[n].Y, truth[n].Z]))
              for n, e in adjusted.items()]
    assert np.median(errors) < position_median and max(errors) < position_max, errors  # RTK σ 2 cm
    angles = [ro.angle_error(e, ExteriorOrientation(*[getattr(truth[n], a) for a in
                                                        ("X", "Y", "Z", "omega", "phi", "kappa")]))
              for n, e in adjusted.items()]
    assert np.median(angles) < angle_median and max(angles) < angle_max, angles


def test_another_lens_is_calibrated_too(tmp_path):
    block = ro.oblique_block(tmp_path / "block", seed=1, rtk=0.02, calibration=False, pp_offset=(-4.0, 3.0),
                             dewarp=(-0.10, 0.04, -0.0002, 0.0005, 0.0))
    res = _run(block, tmp_path / "auto")
    assert res.exit_code == 0, res.output
    assert "held fixed" not in res.output, res.output
    _assert_oriented(block, tmp_path / "auto", 0.05, 0.08, 0.1, 0.15)  # measured 0.015 / 0.038 m, 0.043 / 0.066°


def test_the_same_camera_held_fixed_is_refused(uncalibrated, tmp_path):
    res = _run(uncalibrated, tmp_path / "fixed", "--self-calibration", "none")
    assert res.exit_code != 0
    assert "its tie points and its prior disagree" in res.output, res.output


def test_none_cannot_be_combined_with_parameters(uncalibrated, tmp_path):
    res = _run(uncalibrated, tmp_path / "bad", "--self-calibration", "none,k1")
    assert res.exit_code != 0 and "--self-calibration none holds the camera fixed" in res.output, res.output
    assert not (tmp_path / "bad").exists()
