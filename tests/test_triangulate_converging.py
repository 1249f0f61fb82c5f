"""Converging oblique frames — a DJI camera looking east, south, west and north at one place — triangulated from
their own files (tests/rendered_converging.py: EXIF GPS with an RTK σ of 2 cm, XMP gimbal angles with 3° of noise,
``DewarpData``; no camera, no orientation file, no DEM, no control).

Plain matching ties these views poorly (tens of epipolar inliers per pair, up to half of them wrong) and the run was
refused; the pairs are now also matched on the ground plane (fotogeo/tools/triangulate/guided.py). Checked:

* the set the method was built on (fractal texture, 30° off nadir, gimbal pitch −60°) and its copies resized to half
  after capture (``PixelXDimension`` and ``DewarpData`` still at full size): every frame's centre and attitude
  within 0.10 m and 0.25° of the truth (the goal for DJI obliques against an SfM solution; measured 0.06 m / 0.06°
  full size, 0.04 m / 0.06° resized: ``benchmarks/oblique_bench.py``);
* held out — another ground (a real orthophoto, ``../shared/data/ngi``), 45° off nadir, another seed — the same
  tolerances;
* a frame over ground no other frame shows: refused in one line naming the pairs tried with their counts, and
  ``report.json`` (the one file written) lists every pair with its plain and ground-plane counts.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.io.camera import read_exterior_orientation
from rendered_converging import converging_block
from rendered_oblique import angle_error

pytestmark = pytest.mark.slow  # four 600 x 400 frames matched, six pairs twice, per run

CENTRE_M, ANGLE_DEG = 0.10, 0.25


def _run(frames, out, *more):
    return CliRunner().invoke(main, ["triangulate", *map(str, frames), "-o", str(out), "-q", *more],
                              terminal_width=200)


def _errors(block, out):
    adj = read_exterior_orientation(out / "exterior_orientation.txt")
    assert sorted(adj) == sorted(block["names"])
    centre = {n: float(np.linalg.norm(np.subtract(adj[n].centre, block["truth"][n].centre))) for n in adj}
    angle = {n: angle_error(adj[n], block["truth"][n]) for n in adj}
    return centre, angle


@pytest.fixture(scope="module")
def fractal(tmp_path_factory):
    return converging_block(tmp_path_factory.mktemp("converging"), off_nadir=30.0, resize=2)


@pytest.mark.parametrize("files", ["full", "resized"])
def test_four_directions_triangulate_from_their_files(fractal, files, tmp_path):
    out = tmp_path / "out"
    res = _run(fractal[files], out)
    assert res.exit_code == 0, res.output
    centre, angle = _errors(fractal, out)
    assert max(centre.values()) < CENTRE_M, centre
    assert max(angle.values()) < ANGLE_DEG, angle
    pairs = json.loads((out / "report.json").read_text())["matching"]["pairs"]
    assert len(pairs) == 6 and all(p["guided"]["used"] for p in pairs), pairs  # every pair converges > 20°


def test_held_out_ground_and_pitch(tmp_path, data_dir):
    block = converging_block(tmp_path / "ngi", off_nadir=45.0, kind="ngi", seed=1)
    out = tmp_path / "out"
    res = _run(block["full"], out)
    assert res.exit_code == 0, res.output
    centre, angle = _errors(block, out)
    assert max(centre.values()) < CENTRE_M, centre
    assert max(angle.values()) < ANGLE_DEG, angle


def test_a_frame_nothing_ties_is_refused_with_the_pairs_tried(tmp_path):
    from test_bad_input import assert_one_line_error
    block = converging_block(tmp_path / "blank", off_nadir=30.0, unrelated="W")
    out = tmp_path / "out"
    res = _run(block["full"], out, "--undetermined", "fail")  # the default drops it, loudly (test_triangulate_drop_default)
    assert_one_line_error(res, "DJI_0003_W")
    error = next(line for line in res.stderr.splitlines() if line.startswith("Error:"))
    assert "6 pair(s) tried (matches/epipolar inliers)" in error and "on the ground plane" in error, error
    assert "report.json" in error
    assert sorted(p.name for p in out.iterdir()) == ["report.json"]
    rep = json.loads((out / "report.json").read_text())
    assert rep["refused"] in error and rep["frames"] == block["names"]
    rows = rep["matching"]["pairs"]
    assert len(rows) == 6 and all({"matches", "inliers", "plain", "guided"} <= set(r) for r in rows)
    west = [r for r in rows if 2 in r["pair"]]
    assert all(r["inliers"] == r["plain"]["inliers"] == r["guided"]["inliers"] == 0 for r in west), west
    others = [r for r in rows if 2 not in r["pair"]]  # the three others: their ties from the ground plane
    assert all(r["guided"]["used"] and r["inliers"] == r["guided"]["inliers"] >= 50 for r in others), others
