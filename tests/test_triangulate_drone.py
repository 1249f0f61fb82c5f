"""The real eBee flight (issue 20): ``fotogeo triangulate img/*.JPG -o OUT`` with no hand-written input.

The eight frames come as three groups that do not overlap each other (a 3-frame strip, a 3-frame strip
and the last/first frames of two strips at a turn). Everything comes from the files: the camera from
EXIF FocalLength x FocalPlaneXResolution, the positions from the EXIF GPS (UTM 54N chosen), the σ from
senseFly's GPSXYAccuracy/GPSZAccuracy, the attitude from senseFly's XMP. The turn pair overlaps in a
sliver (its points cover < 2 % of each frame): it is refused by name, and dropped on request.
There is no ground truth: the adjusted centres are judged against the GPS and its σ.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.io.camera import read_exterior_orientation
from fotogeo.io.exif_block import read_exif_block

pytestmark = [pytest.mark.data, pytest.mark.slow]


def test_drone_block_from_the_files_alone(tmp_path, data_dir):
    frames = sorted(str(p) for p in (data_dir / "drone_snowpeak" / "img").glob("*.JPG"))
    out = tmp_path / "new" / "out"  # the folder is created
    res = CliRunner().invoke(main, ["triangulate", *frames, "-o", str(out), "-q",
                                                    "--undetermined", "drop"])
    assert res.exit_code == 0, res.output
    rep = json.loads((out / "report.json").read_text())
    assert sorted(d["name"] for d in rep["dropped_frames"]) == ["IMG_2212", "IMG_2213"]
    assert rep["crs"] == "EPSG:32654" and "GPS" in rep["start"]["crs_rule"]
    assert rep["matching"]["rays_per_track"].get("3", 0) > 0  # tracks of 3 rays in the 3-frame strips
    assert 0.5 < rep["sigma0"] < 10 and rep["statistics"]["image_rms_px"] < 0.5
    for q in rep["frame_quality"]:
        assert q["points"] >= 20 and q["spread"] > 0.1, q  # measured: 27-91 points, 15-40 % of the frame
    gps = read_exif_block(frames).shots
    adjusted = read_exterior_orientation(out / "exterior_orientation.txt")
    for name, e in adjusted.items():
        d = np.array([e.X, e.Y, e.Z]) - gps[name].position
        assert np.hypot(d[0], d[1]) < 3 * gps[name].sigma_h and abs(d[2]) < 3 * gps[name].sigma_v, (name, d)
    assert "IMG_2188" in res.output and "worst frame" in res.output
