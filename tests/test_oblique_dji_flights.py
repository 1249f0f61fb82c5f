"""DJI flights unlike the four-frame converging sets guided matching was built on (tests/rendered_dji_flight.py,
issues 30 and 32): a Phantom 4 Pro's 5472 × 3648 frames resized to 456 × 304 after capture (EXIF
``PixelXDimension``, XMP ``DewarpData``/``CalibratedFocalLength`` still at full size), a ring of eight obliques 30° off
nadir around one place over hills with buildings, triangulated from their files alone (no camera, orientation, DEM or
control):

* with RTK GPS (σ 2 cm): the camera read from the XMP is the true one scaled to the files (focal 3648 / 12 px), and
  every frame lies within 0.10 m and 0.25° of the truth;
* with GPS that is not RTK (σ 3 m and a common offset of (1.5, −2, 4) m): the block follows the GPS datum (its common
  offset is not observable from the images), and after a 7-parameter fit onto the truth every frame lies within
  0.10 m and 0.25°.

Larger sets and sizes (17 frames with a nadir grid at 1368 × 912 and 912 × 608, a −45° double grid, a Mavic's 4:3
frames, towers, no XMP): ``benchmarks/oblique_heldout_bench.py``.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.io.camera import read_exterior_orientation
from rendered_dji_flight import dji_flight, errors

CENTRE_M, ANGLE_DEG = 0.10, 0.25
SMALL = {"pattern": "ring", "file_size": (456, 304), "nadir": False, "buildings": 2}


def _triangulate(block, out):
    res = CliRunner().invoke(main, ["triangulate", *map(str, block["frames"]), "-o", str(out), "-q"],
                             terminal_width=200)
    assert res.exit_code == 0, res.output
    adj = read_exterior_orientation(out / "exterior_orientation.txt")
    assert sorted(adj) == sorted(block["names"])
    return adj


def test_resized_phantom_ring_with_rtk(tmp_path):
    block = dji_flight(tmp_path / "frames", seed=11, **SMALL)
    adj = _triangulate(block, tmp_path / "out")
    cam = json.loads((tmp_path / "out" / "report.json").read_text())["camera"]
    true = block["camera"]
    assert cam["focal_length"] == pytest.approx(true.focal_length, abs=1e-6), cam  # 3648 / 12
    assert cam["principal_point"] == pytest.approx(list(true.principal_point), abs=1e-6), cam
    e = errors(adj, block["truth"], fit=False)
    assert e["centre_max_m"] < CENTRE_M and e["angle_max_deg"] < ANGLE_DEG, e


def test_resized_phantom_ring_without_rtk_follows_the_gps_datum(tmp_path):
    offset = np.array([1.5, -2.0, 4.0])
    block = dji_flight(tmp_path / "frames", seed=14, rtk=False, gps_sigma=3.0, gps_offset=tuple(offset), **SMALL)
    adj = _triangulate(block, tmp_path / "out")
    shift = np.mean([adj[n].centre - block["truth"][n].centre for n in adj], axis=0)
    assert np.linalg.norm(shift - offset) < 3.0 * 3.0 / np.sqrt(len(adj)) + 0.5, shift  # the GPS's datum
    e = errors(adj, block["truth"], fit=True)
    assert e["centre_max_m"] < CENTRE_M and e["angle_max_deg"] < ANGLE_DEG, e
