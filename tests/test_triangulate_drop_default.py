"""Undetermined frames are dropped by default — loudly — and a flight mostly undetermined is refused.

As photogrammetric packages leave unaligned cameras out, ``triangulate`` drops a frame the block does not determine
(``--undetermined drop``, the default of the library, the command and the QGIS dialog: one option table). It is
never silent: the console's first summary line says how many of how many frames were dropped, which and why, and
how to stop the run instead (``--undetermined fail``); report.json lists them with their reasons. Dropping is
refused when fewer than 2 frames, or less than half of the frames given, would remain.

The small 2 × 5 block of test_triangulate, written to files with a tie-point table, some frames cut to a sliver
(their observations in a 12 % corner): refused or dropped before the adjustment (sparse frames), in seconds.
"""
from __future__ import annotations

import dataclasses
import inspect
import json

import numpy as np
import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.io.camera import read_exterior_orientation
from fotogeo.options import TRIANGULATE
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.tools.triangulate import triangulate
from fotogeo.tools.triangulate.determinacy import why_not_dropped
from fotogeo.tools.triangulate.register import registration_start
from test_bad_input import assert_one_line_error
from test_triangulate import CAMERA, write_block


@pytest.fixture(scope="module")
def sb():
    return simulate_block(seed=6, strips=2, frames_per_strip=5, camera=CAMERA, point_spacing=50.0, margin=3.0,
                          n_check=8)


def _slivers(sb, frames: list):
    """``sb`` with the observations of the frames ``frames`` (indices) kept only in their top-left 12 % corner."""
    b = sb.block
    w, h = CAMERA.image_size
    far = np.isin(b.obs_frame, frames) & ((b.obs_pixel[:, 0] > 0.12 * w) | (b.obs_pixel[:, 1] > 0.12 * h))
    keep = ~far
    block = dataclasses.replace(b, obs_frame=b.obs_frame[keep], obs_point=b.obs_point[keep],
                                obs_pixel=b.obs_pixel[keep],
                                obs_sigma=None if b.obs_sigma is None else np.asarray(b.obs_sigma)[keep])
    return dataclasses.replace(sb, block=block)


def _cli(folder, frames, checks, *extra):
    return CliRunner().invoke(main, ["triangulate", *map(str, frames), "--camera", str(folder / "camera.yaml"),
                                     "--eo", str(folder / "eo.txt"), "--observations", str(folder / "tie.csv"),
                                     "--gcps", str(folder / "gcp_list.txt"), "--check-points", checks,
                                     "--image-sigma", "0.3", "-o", str(folder / "out"), "-q", *extra],
                              terminal_width=200)


def test_drop_is_the_default_everywhere():
    assert TRIANGULATE["undetermined"].default == "drop"
    assert inspect.signature(triangulate).parameters["undetermined"].default == "drop"
    assert inspect.signature(registration_start).parameters["undetermined"].default == "drop"
    assert TRIANGULATE["undetermined"].qgis_choices[0] == "drop"  # the dialog's first entry, its default


@pytest.mark.parametrize("total, left, refused", [(10, 9, None), (10, 5, None), (8, 6, None), (3, 2, None),
                                                 (10, 4, "would leave 4 of the 10 frames"),
                                                 (3, 1, "would leave 1 frame(s), fewer than the 2"),
                                                 (2, 0, "would leave 0 frame(s), fewer than the 2")])
def test_dropping_is_refused_below_two_frames_or_half_the_flight(total, left, refused):
    said = why_not_dropped(total, left)
    assert said is None if refused is None else refused in said


def test_a_sliver_frame_is_dropped_by_default_loudly(sb, tmp_path):
    name = sb.block.frames[4]
    frames, checks = write_block(tmp_path, _slivers(sb, [4]))
    res = _cli(tmp_path, frames, checks)
    assert res.exit_code == 0, res.output + res.stderr
    first = res.stdout.splitlines()[0]  # the first summary line, before the statistics
    assert first.startswith(f"1 of 10 frames dropped (undetermined): {name} — "), res.output
    assert "points cover" in first and first.endswith("; --undetermined fail stops the run instead"), first
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert [d["name"] for d in rep["dropped_frames"]] == [name] and "points cover" in rep["dropped_frames"][0]["reason"]
    assert rep["statistics"]["n_frames"] == 9
    adjusted = read_exterior_orientation(tmp_path / "out" / "exterior_orientation.txt")
    assert name not in adjusted and len(adjusted) == 9
    truth = dict(zip(sb.block.frames, sb.true_eo))
    for n, e in adjusted.items():  # the rest adjusted as well as without the dropped frame
        assert np.hypot(e.X - truth[n].X, e.Y - truth[n].Y) < 2 * sb.gsd, n
    assert "Frames left out (undetermined)" in (tmp_path / "out" / "report.html").read_text()


def test_with_fail_the_same_frame_stops_the_run(sb, tmp_path):
    name = sb.block.frames[4]
    frames, checks = write_block(tmp_path, _slivers(sb, [4]))
    res = _cli(tmp_path, frames, checks, "--undetermined", "fail")
    assert_one_line_error(res, f"the block does not determine frame(s) {name}")
    assert "leave them out (--undetermined drop)" in res.stderr
    assert not (tmp_path / "out" / "exterior_orientation.txt").exists()


def test_a_flight_mostly_undetermined_is_refused_naming_the_frames(sb, tmp_path):
    """Six of ten frames slivers: dropping them would leave four — refused, never a 'successful' smaller block."""
    cut = [0, 1, 2, 5, 6, 7]
    frames, checks = write_block(tmp_path, _slivers(sb, cut))
    res = _cli(tmp_path, frames, checks)
    assert_one_line_error(res, "the block does not determine frame(s) ")
    error = next(line for line in res.stderr.splitlines() if line.startswith("Error:"))
    for k in cut:
        assert sb.block.frames[k] in error, (sb.block.frames[k], error)
    assert "would leave 4 of the 10 frames" in error and "more than half" in error and "GCPs" in error
    assert "leave them out" not in error  # dropping is what was refused
    assert not (tmp_path / "out" / "exterior_orientation.txt").exists()

