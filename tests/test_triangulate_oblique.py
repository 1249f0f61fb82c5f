"""A rendered oblique drone block (issue 20): ``fotogeo triangulate`` never exits 0 with a frame more than 1°
wrong that it does not flag.

The block (tests/rendered_oblique.py): 4 strips × 5 frames flown north, east, south and west across one
area, gimbal −60°, Brown distortion, ±8 m relief under 80 m; DJI-like files with EXIF GPS (2 m noise)
and the calibration in ``DewarpData``. No GCPs: the block's absolute attitude can only come from the
GPS positions (and the gimbal angles when the files have them) — 2 m of GPS noise over a 150 m block
turns the whole block by about 1° (measured: 0.97° from these GPS positions by a Helmert fit of the
true centres to them). The contract checked:

* **from the gimbal angles** (5° noise): the run ends; the block is right inside (after the one
  rotation the GPS noise gives it, every frame within 0.25° of the truth) and every frame's angle
  error is within 3 σ of the angle σ it reports; a frame more than 1° off is flagged (the warning
  that its attitude rests on its prior);
* **from the gimbal angles, three seeds** (0, 1, 2; and ``--undetermined drop``): the run refuses naming the
  frames, or no frame is more than 1° wrong inside the block (and a block more than 1.5° off is warned).
  Measured: seed 0 right (20 frames within 0.14°); seed 1 refuses DJI_301 (25.7 m from its GPS: it exited 0
  about 20° wrong before the prior test);
* **seed 2, the wrong gimbal tags**: DJI_205 and DJI_405 are right but their gimbal tags 21° and 18° from the
  truth — the prior test cannot tell a wrong tag from wrong ties, and the run refused them; now each is
  re-started from the block without its attitude prior (tools/triangulate/determinacy.py) and kept because it
  then passes every check: all 20 frames, within 0.026° of the truth inside the block (measured);
* **from a level start** (no attitude in the files; κ measured on the images): the run either puts
  every frame within 1° of the truth, or fails with one line naming the frames — measured: it
  refuses, the block's attitude σ (0.59–0.60° with the GPS σ of 2 m; 1.7° with the default 5/10 m)
  being above the 0.5° limit.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.geometry.camera import nearest_rotation
from fotogeo.io.camera import read_exterior_orientation
from rendered_oblique import angle_error, oblique_block

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    return oblique_block(tmp_path_factory.mktemp("oblique"), seed=0)


def _run(frames, out, *args):
    res = CliRunner().invoke(main, ["triangulate", *map(str, frames), "-o", str(out), "-q", *args])
    return res, (read_exterior_orientation(out / "exterior_orientation.txt") if res.exit_code == 0 else None)


def _warnings(res) -> str:
    """The warnings of a ``--json`` run (``-q`` hides them on stderr)."""
    return " ".join(json.loads(res.stdout).get("warnings", []))


def _block_rotation(truth, adjusted, names):
    """The rotation (3x3) that best turns the true centres onto the adjusted ones (Helmert, no scale)."""
    A = np.array([truth[n].centre for n in names])
    B = np.array([adjusted[n].centre for n in names])
    return nearest_rotation((A - A.mean(0)).T @ (B - B.mean(0))).T


def _errors(block, adjusted):
    return {n: angle_error(e, block["truth"][n]) for n, e in adjusted.items()}


def _inner_errors(block, adjusted):
    """Every frame's angle error (°) once the one rotation of the whole block is removed."""
    R = _block_rotation(block["truth"], adjusted, list(adjusted))
    out = {}
    for n, e in adjusted.items():
        M = (R.T @ e.rotation).T @ block["truth"][n].rotation
        out[n] = float(np.degrees(np.arccos(np.clip((np.trace(M) - 1) / 2, -1, 1))))
    return out


@pytest.fixture(scope="module")
def blocks(tmp_path_factory, block):
    """``seed -> block``, each rendered once (seed 0 is the module's ``block``)."""
    made = {0: block}

    def get(seed):
        if seed not in made:
            made[seed] = oblique_block(tmp_path_factory.mktemp(f"oblique{seed}"), seed=seed)
        return made[seed]
    return get


@pytest.fixture(scope="module")
def gimbal_runs(tmp_path_factory, blocks):
    """``(seed, mode) -> (result, adjusted, folder)``: the run from the gimbal angles with ``--undetermined mode``,
    each made once (seed 0 with ``fail`` and seed 2 with ``drop``, the default, serve two tests each)."""
    made = {}

    def get(seed, mode):
        if (seed, mode) not in made:
            out = tmp_path_factory.mktemp(f"gimbal{seed}{mode}") / "out"
            made[seed, mode] = (*_run(blocks(seed)["gimbal"], out, "--undetermined", mode, "--json"), out)
        return made[seed, mode]
    return get


@pytest.mark.parametrize("seed, mode", [(0, "fail"), (1, "fail"), (1, "drop"), (2, "fail"), (2, "drop")])
def test_from_the_gimbal_angles_it_refuses_or_every_frame_is_right(blocks, gimbal_runs, seed, mode):
    """Issue 20 item 4, never wrong in silence: on every seed, either the run refuses naming the frames, or
    no frame is more than 1° wrong inside the block and a block more than 1.5° off is warned. Before the prior
    test (bundle_quality.prior_contradicted_frames), seed 1 exited 0 with DJI_301 20° wrong, and seed 0 with
    --undetermined drop with DJI_405 23° wrong under a 1.1° σ."""
    block = blocks(seed)
    res, adjusted, out = gimbal_runs(seed, mode)
    if res.exit_code != 0:
        assert res.exit_code in (1, 2) and res.stderr.startswith("Error: ") and res.stderr.count("\n") == 1, res.stderr
        assert "frame(s) DJI_" in res.stderr, res.stderr
        assert not (out / "exterior_orientation.txt").exists()
        return
    worst = max(_inner_errors(block, adjusted).items(), key=lambda kv: kv[1])
    assert worst[1] < 1.0, (seed, mode, worst, res.output)
    if max(_errors(block, adjusted).values()) > 1.5:
        assert "keep an angle σ above" in _warnings(res), res.stdout  # -q hides it, --json keeps it


def test_seed_2_restarts_the_frames_whose_gimbal_tags_are_wrong_and_keeps_every_frame(blocks, gimbal_runs):
    """Issue 20: a frame whose attitude prior alone its tie points contradict is re-oriented by resection from the
    block and adjusted without that prior; it is kept only if it then passes every check. Seed 2 was refused
    (DJI_205, DJI_405: gimbal tags 21.2° and 18.4° from the truth); now every frame is kept, inside the block
    within 0.026° of the truth (measured), each angle error within 1.25 of its σ (measured). The run is the default
    one (``--undetermined drop``), shared with the parametrised test above."""
    block = blocks(2)
    res, adjusted, out = gimbal_runs(2, "drop")
    assert res.exit_code == 0, res.output + res.stderr
    rep = json.loads((out / "report.json").read_text())
    assert sorted(r["name"] for r in rep["restarted_frames"]) == ["DJI_205", "DJI_405"], rep["restarted_frames"]
    assert res.output.count("re-started (attitude prior contradicted): DJI_") == 2, res.output
    assert sorted(adjusted) == sorted(block["names"]) and rep["dropped_frames"] == []
    for r in rep["restarted_frames"]:  # the tags are 21.2° and 18.4° off: the adjusted frame is that far from them
        assert 15 < r["prior_offset_deg"] < 25 and r["angle_sigma_in_block_deg"] < 0.5, r
    inner = _inner_errors(block, adjusted)
    assert max(inner.values()) < 0.25, inner
    sigma = {q["name"]: q["angle_sigma_deg"] for q in rep["frame_quality"]}
    for n, error in _errors(block, adjusted).items():
        assert error < 3 * sigma[n], (n, error, sigma[n])


def test_from_the_gimbal_angles_the_block_is_right_inside_and_its_sigma_honest(block, gimbal_runs):
    """The run with ``--undetermined fail``, shared with the parametrised test: on this seed the block determines
    every frame, so it is the default run (``drop``) too — a frame it did not determine fails it."""
    res, adjusted, out = gimbal_runs(0, "fail")
    assert res.exit_code == 0, res.output + res.stderr
    rep = json.loads((out / "report.json").read_text())
    sigma = {q["name"]: q["angle_sigma_deg"] for q in rep["frame_quality"]}
    errors = _errors(block, adjusted)
    assert sorted(adjusted) == sorted(block["names"]) and rep["dropped_frames"] == []
    R = _block_rotation(block["truth"], adjusted, list(adjusted))
    for n, e in adjusted.items():
        M = (R.T @ e.rotation).T @ block["truth"][n].rotation  # the frame against the truth, block rotation removed
        inner = np.degrees(np.arccos(np.clip((np.trace(M) - 1) / 2, -1, 1)))
        # measured 0.025-0.058°, the weakest frame (DJI_401: 18 points on 18 % of the frame) 0.148°
        assert inner < 0.25, (n, inner)
        assert errors[n] < 3 * sigma[n], (n, errors[n], sigma[n])  # measured 1.30-1.42° against σ 1.05-1.06°
    if max(errors.values()) > 1.0:
        assert "keep an angle σ above" in _warnings(res), res.stdout  # flagged, never silent


def test_from_a_level_start_it_converges_within_a_degree_or_refuses(block, tmp_path):
    res, adjusted = _run(block["nadir"], tmp_path / "out", "--eo-sigma-position", "2", "--eo-sigma-height", "2",
                         "--undetermined", "drop")
    if res.exit_code == 0:
        worst = max(_errors(block, adjusted).items(), key=lambda kv: kv[1])
        assert worst[1] < 1.0, (worst, res.output)
    else:
        assert res.exit_code in (1, 2) and res.stderr.startswith("Error: ") and res.stderr.count("\n") == 1, res.stderr
        assert "does not determine frame(s) DJI_" in res.stderr or "reached by no tie point" in res.stderr
        assert not (tmp_path / "out" / "exterior_orientation.txt").exists()
