"""The real eBee flight (issue 20): ``fotogeo triangulate img/*.JPG -o OUT`` with no hand-written input.

The eight frames come as three groups that do not overlap each other (a 3-frame strip, a 3-frame strip
and the last/first frames of two strips at a turn). Everything comes from the files: the camera from
EXIF FocalLength x FocalPlaneXResolution, the positions from the EXIF GPS (UTM 54N chosen), the σ from
senseFly's GPSXYAccuracy/GPSZAccuracy, the attitude from senseFly's XMP. The turn pair overlaps in a
sliver (its points cover < 2 % of each frame): it is refused by name, and dropped on request. senseFly's
geoinfo.txt gives the same start (the autopilot's attitude from the file instead of the XMP: the same values),
checked for the eight frames, and adjusts a strip.
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
    src = data_dir / "drone_snowpeak"
    frames = sorted(str(p) for p in (src / "img").glob("*.JPG"))
    out = tmp_path / "new" / "out"  # the folder is created
    res = CliRunner().invoke(main, ["triangulate", *frames, "-o", str(out)])  # drop: the default; no -q: warnings
    assert res.exit_code == 0, res.output
    rep = json.loads((out / "report.json").read_text())
    assert sorted(d["name"] for d in rep["dropped_frames"]) == ["IMG_2212", "IMG_2213"]
    assert res.stdout.startswith("2 of 8 frames dropped (undetermined): IMG_221"), res.stdout  # loud, first
    assert "--undetermined fail stops the run instead" in res.stdout.splitlines()[0]
    assert rep["crs"] == "EPSG:32654" and "GPS" in rep["start"]["crs_rule"]
    assert any(n.startswith("attitude: 8 image(s) from sensefly:Yaw/Pitch/Roll") for n in rep["start"]["notes"])
    assert rep["start"]["heights"].startswith("ellipsoid")
    rays = {int(k): v for k, v in rep["matching"]["rays_per_track"].items()}
    assert rays.get(3, 0) > 0 and sum(rays.values()) == rep["matching"]["tracks"]  # 3-ray tracks in the strips
    assert 0.5 < rep["sigma0"] < 10 and rep["statistics"]["image_rms_px"] < 0.5
    for q in rep["frame_quality"]:
        assert q["points"] >= 20 and q["spread"] > 0.1, q  # measured: 27-123 points, 15-59 % of the frame
    gps = read_exif_block(frames).shots
    adjusted = read_exterior_orientation(out / "exterior_orientation.txt")
    assert sorted(adjusted) == ["IMG_2186", "IMG_2188", "IMG_2189", "IMG_2280", "IMG_2281", "IMG_2282"]
    for name, e in adjusted.items():
        d = np.array([e.X, e.Y, e.Z]) - gps[name].position
        assert np.hypot(d[0], d[1]) < 3 * gps[name].sigma_h and abs(d[2]) < 3 * gps[name].sigma_v, (name, d)
        assert np.abs(d).max() > 1e-3, name  # adjusted, not the GPS copied through
    worst = max(rep["frame_quality"], key=lambda q: q["angle_sigma_deg"])
    assert f"worst frame {worst['name']}" in res.output and "GPS heights: ellipsoid" in res.output
    assert "Warning:" in res.stderr and "rests on its prior" in res.stderr  # the strips cannot fix their roll
    page = (out / "report.html").read_text()
    for text in ("IMG_2212", "points cover", "the UTM zone of the images&#x27; GPS positions", "GPS heights",
                 "Rays per track", "no control or check point"):
        assert text in page, text
    assert "drawn ×" not in page.split("Control layout")[1].split("</figure>")[0]


def test_geoinfo_gives_the_xmp_start_and_a_strip_adjusts_from_it(tmp_path, data_dir):
    """senseFly's geoinfo.txt in place of the XMP: the same start for all eight frames (positions within 1 cm —
    the file rounds to 1e-7° — attitudes within 0.01°), the attitude named as the file's; and the 3-frame strip
    IMG_2280–2282 adjusted from it on the command line, its centres within 3 σ of the GPS. (The whole flight with
    --geoinfo ran the XMP's adjustment again from that same start.)"""
    src = data_dir / "drone_snowpeak"
    frames = sorted(str(p) for p in (src / "img").glob("*.JPG"))
    xmp, geo = read_exif_block(frames), read_exif_block(frames, geoinfo=src / "snowpea1_geoinfo.txt")
    assert "attitude: 8 image(s) from geoinfo heading/pitch/roll (aircraft body)" in geo.notes, geo.notes
    for name, shot in xmp.shots.items():
        assert np.abs(np.subtract(geo.shots[name].position, shot.position)).max() < 0.01, name
        assert np.abs(np.subtract(geo.shots[name].angles, shot.angles)).max() < 0.01, name
    strip = [f for f in frames if any(n in f for n in ("IMG_2280", "IMG_2281", "IMG_2282"))]
    out = tmp_path / "strip"
    res = CliRunner().invoke(main, ["triangulate", *strip, "-o", str(out), "-q", "--geoinfo",
                                    str(src / "snowpea1_geoinfo.txt")])
    assert res.exit_code == 0, res.output
    rep = json.loads((out / "report.json").read_text())
    assert any(n.startswith("attitude: 3 image(s) from geoinfo heading/pitch/roll") for n in rep["start"]["notes"])
    adjusted = read_exterior_orientation(out / "exterior_orientation.txt")
    assert sorted(adjusted) == ["IMG_2280", "IMG_2281", "IMG_2282"]
    for name, e in adjusted.items():
        d = np.array([e.X, e.Y, e.Z]) - geo.shots[name].position
        assert np.hypot(d[0], d[1]) < 3 * geo.shots[name].sigma_h and abs(d[2]) < 3 * geo.shots[name].sigma_v
        assert np.abs(d).max() > 1e-3, name  # adjusted, not the GPS copied through


def test_the_turn_pair_alone_is_refused_by_name(tmp_path, data_dir):
    """IMG_2212/2213 overlap in a sliver: the block does not determine them — one line naming both, why and the fix,
    exit code 2; the pair tried and its counts in the line and in report.json, the one file written."""
    from test_bad_input import assert_one_line_error
    img = data_dir / "drone_snowpeak" / "img"
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["triangulate", str(img / "IMG_2212.JPG"), str(img / "IMG_2213.JPG"), "-o",
                                    str(out), "-q", "--undetermined", "fail"], terminal_width=200)
    assert_one_line_error(res, "the block does not determine frame(s) IMG_2212")
    error = next(line for line in res.stderr.splitlines() if line.startswith("Error:"))
    assert "IMG_2213" in error and "points cover" in error and "--undetermined drop" in error and "GCPs" in error
    assert "IMG_2212–IMG_2213" in error and "matches/epipolar inliers" in error and "report.json" in error
    assert sorted(p.name for p in out.iterdir()) == ["report.json"]
    rep = json.loads((out / "report.json").read_text())
    assert rep["refused"].startswith("the block does not determine") and len(rep["matching"]["pairs"]) == 1


def test_dropping_the_turn_pair_would_leave_no_block_and_says_so(tmp_path, data_dir):
    """With ``--undetermined drop`` given, the refusal says that dropping both frames would leave fewer than two,
    instead of advising the option the user already gave."""
    from test_bad_input import assert_one_line_error
    img = data_dir / "drone_snowpeak" / "img"
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["triangulate", str(img / "IMG_2212.JPG"), str(img / "IMG_2213.JPG"), "-o",
                                    str(out), "-q", "--undetermined", "drop"], terminal_width=200)
    assert_one_line_error(res, "the block does not determine frame(s) IMG_2212")
    error = next(line for line in res.stderr.splitlines() if line.startswith("Error:"))
    assert "would leave 0 frame(s), fewer than the 2 a block needs" in error and "leave them out" not in error
    assert sorted(p.name for p in out.iterdir()) == ["report.json"]  # the refusal's report: the pair tried
