"""A camera guessed from the images' EXIF is calibrated by default, as ODM and Metashape do.

A rendered oblique DJI-like block (tests/rendered_oblique.py: four headings, gimbal at −60°, RTK positions of
σ 2 cm, a lens with Brown distortion k1 −0.06, k2 0.02 and a principal point 2.5 px off the centre) whose files
carry only what a camera without a calibration writes: ``FocalLengthIn35mmFilm`` (28 mm, an integer: the focal
length 0.4 % short) and no DJI ``DewarpData``. Held fixed, that pinhole cannot fit the RTK positions and the
block is refused; by default (no ``--self-calibration``) the focal length and the distortion are estimated and
the block is oriented. The same block with its calibration in the files keeps that calibration fixed.
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
    adjusted = read_exterior_orientation(tmp_path / "auto" / "exterior_orientation.txt")
    assert len(adjusted) >= 15, sorted(adjusted)  # of 20
    truth = uncalibrated["truth"]
    errors = [np.linalg.norm(np.subtract([e.X, e.Y, e.Z], [truth[n].X, truth[n].Y, truth[n].Z]))
              for n, e in adjusted.items()]
    assert np.median(errors) < 0.08 and max(errors) < 0.15, errors  # RTK σ 2 cm; measured 0.045 / 0.092 m
    # the principal point's offset cannot be told from the attitude without control: the angles take it
    angles = [ro.angle_error(e, ExteriorOrientation(*[getattr(truth[n], a) for a in
                                                        ("X", "Y", "Z", "omega", "phi", "kappa")]))
              for n, e in adjusted.items()]
    assert np.median(angles) < 0.35, angles  # 2.5 px at 520 px is 0.28°


def test_the_same_camera_held_fixed_is_refused(uncalibrated, tmp_path):
    res = _run(uncalibrated, tmp_path / "fixed", "--self-calibration", "none")
    assert res.exit_code != 0
    assert "its tie points and its prior disagree" in res.output, res.output


def test_none_cannot_be_combined_with_parameters(uncalibrated, tmp_path):
    res = _run(uncalibrated, tmp_path / "bad", "--self-calibration", "none,k1")
    assert res.exit_code != 0 and "--self-calibration none holds the camera fixed" in res.output, res.output
    assert not (tmp_path / "bad").exists()
