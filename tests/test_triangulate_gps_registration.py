"""``fotogeo triangulate`` with frames that carry GPS but no attitude, and ``--reference`` with ``--dem``
(issue 20): every frame is registered to the reference around its GPS position and starts from the GPS
position with the registration's attitude (:mod:`fotogeo.tools.triangulate.register`), not level.

The block (tests/rendered_oblique.py): 4 strips × 5 frames, gimbal −60° (30° off nadir), four look
directions, Brown distortion, ±8 m relief under 80 m, EXIF GPS with 2 m noise and no attitude in the files;
the reference is the ground texture the frames were rendered from at twice their nadir GSD, and the DEM they
were rendered on. Measured (seed 0): every frame within 0.049° and 0.10 m of the truth, 1075 tie tracks;
the level start (κ from the images) that the tool used before on the same files and reference ended
0.20° and 0.28 m off with 530 tracks (its level footprints chose fewer of the overlapping pairs).

Gimbal tags that are wrong are contradicted by the registration and replaced: on the 20-frame block of seed 2
(DJI_205's and DJI_405's tags 21.2° and 18.4° from the truth) the run ended with every frame within 0.030° and
0.069 m, where it refused those two frames before (their adjusted attitude 18–21° from the prior). The test runs
the smaller block of seed 3 (4 strips × 3 frames, half the run time): DJI_303's tag is 21.3° from the truth, every
other tag within 12°; measured: DJI_303 replaced, every frame within 0.022° and 0.063 m.

The 12-frame block of seed 0 without attitude (issue 32) dropped DJI_103 and DJI_303 and left DJI_202
unregistered: DJI_202's resection started from a DLT 119 px off on the nearly flat ground and diverged
(:mod:`fotogeo.models.collinearity` now starts from the better of the DLT and SQPnP), and its level start then
had κ measured on the pairs replace the registered κ of every frame (DJI_103's by 113°, DJI_303's by 106°;
:func:`~fotogeo.tools.triangulate.start.start_from_pairs` now moves only the frames whose attitude is unknown).
Measured with both fixes: 12 of 12 registered, every frame within 0.040° and 0.069 m; with the κ fix alone
(DJI_202 level-started): within 0.029° and 0.051 m. Each cause is checked alone, fast: by the last test here
and by ``test_collinearity_resection_of_an_oblique_frame_over_nearly_flat_ground`` (tests/test_models_spatial.py).
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.geometry.camera import ExteriorOrientation
from fotogeo.io.camera import read_exterior_orientation
from fotogeo.tools.triangulate.register import CONTRADICTED_DEG, with_registered_attitude
from rendered_oblique import angle_error, oblique_block, write_reference


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("gps_reg")
    block = oblique_block(tmp / "block", seed=0)
    ortho, dem = write_reference(block, tmp / "reference")
    out = tmp / "out"
    res = CliRunner().invoke(main, ["triangulate", *map(str, block["nadir"]), "--reference", str(ortho), "--dem",
                                    str(dem), "-o", str(out), "-q"])
    return block, res, out


@pytest.mark.slow
def test_gps_frames_without_attitude_start_from_their_registration(run):
    block, res, out = run
    assert res.exit_code == 0, res.output
    assert "attitude from registering the frames to the reference (--reference, --dem) for 20 of 20" in res.output
    start = json.loads((out / "report.json").read_text())["start"]
    assert "attitude from registering" in start["source"] and not start["level_start_frames"]
    rows = start["registration"]
    assert len(rows) == 20 and all(r["attitude"].startswith("registration") for r in rows)
    assert all(r["gps_offset_m"] < 10.0 for r in rows)  # the GPS (2 m noise) and the registration agree
    eos = read_exterior_orientation(out / "exterior_orientation.txt")
    for n, e in eos.items():
        # measured: at most 0.049° and 0.10 m (the level start before: 0.20° and 0.28 m)
        assert angle_error(e, block["truth"][n]) < 0.1, n
        assert np.linalg.norm(e.centre - block["truth"][n].centre) < 0.2, n


@pytest.mark.slow
def test_wrong_gimbal_tags_are_replaced_by_the_registration(tmp_path):
    block = oblique_block(tmp_path / "block", seed=3, per_strip=3)
    ortho, dem = write_reference(block, tmp_path / "reference")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["triangulate", *map(str, block["gimbal"]), "--reference", str(ortho), "--dem",
                                    str(dem), "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    assert "their attitude tags contradicted by it: DJI_303" in res.output
    rows = {r["name"]: r for r in json.loads((out / "report.json").read_text())["start"]["registration"]}
    replaced = {n for n, r in rows.items() if r["attitude"].startswith("registration")}
    assert replaced == {"DJI_303"}, replaced  # the other 11 tags agree and are kept
    eos = read_exterior_orientation(out / "exterior_orientation.txt")
    assert sorted(eos) == sorted(block["names"])  # no frame dropped
    for n, e in eos.items():  # measured: at most 0.022° and 0.063 m
        assert angle_error(e, block["truth"][n]) < 0.1 and np.linalg.norm(e.centre - block["truth"][n].centre) < 0.2, n


def test_an_attitude_tag_is_kept_unless_the_registration_contradicts_it():
    gps = ExteriorOrientation(100.0, 200.0, 380.0, 1.0, 2.0, 30.0)
    near = ExteriorOrientation(101.0, 199.0, 381.0, 1.5, 2.5, 33.0)
    far = ExteriorOrientation(101.0, 199.0, 381.0, 1.5, 2.5, 30.0 + CONTRADICTED_DEG + 5.0)
    assert with_registered_attitude(gps, near, False) == (gps, "")
    eo, why = with_registered_attitude(gps, far, False)
    assert eo.centre.tolist() == gps.centre.tolist() and eo.kappa == far.kappa and "from it" in why
    eo, why = with_registered_attitude(gps, near, True)  # no attitude in the files: the registration's, GPS position
    assert (eo.X, eo.Y, eo.Z, eo.omega, eo.phi, eo.kappa) == (100.0, 200.0, 380.0, 1.5, 2.5, 33.0)
    assert "no attitude" in why


def test_a_frame_the_reference_cannot_place_keeps_its_gps_level_start():
    from fotogeo.tools.triangulate.control import FrameFit
    from fotogeo.tools.triangulate.register import _over_gps, _row
    from fotogeo.tools.triangulate.sources import BlockStart

    class Model:  # a registration's fitted pose
        def __init__(self, eo):
            self.frame = type("F", (), {"eo": eo})()
            self.info = {"std": [1.0, 1.0, 1.0, 0.05, 0.05, 0.05], "sigma0": 0.4}

    names = ["a", "b"]
    gps = {"a": ExteriorOrientation(0.0, 0.0, 400.0, 0.0, 0.0, 90.0),
           "b": ExteriorOrientation(30.0, 0.0, 400.0, 0.0, 0.0, 90.0)}
    fits = {"a": FrameFit("a", Model(ExteriorOrientation(1.0, 2.0, 401.0, 3.0, -29.0, 178.0)), 200, 150),
            "b": FrameFit("b", reason="no matches with the reference")}
    problems = {"a": "", "b": "not registered to the reference (no matches with the reference)"}
    rows = [_row(n, fits[n], problems[n]) for n in names]
    reg = _over_gps(["a.tif", "b.tif"], names, [gps[n] for n in names], [True, True], fits, problems, rows, None)
    start = BlockStart(None, (0.0,) * 5, list(names), dict(gps), None, "", "--camera; orientation from the images' GPS",
                       sigmas={n: (5.0, 10.0, None) for n in names}, level={"a": True, "b": True}, registration=[],
                       over_gps=True)
    start.take_registration(reg)
    a, b = start.eos["a"], start.eos["b"]
    assert (a.X, a.Y, a.Z, a.omega, a.phi, a.kappa) == (0.0, 0.0, 400.0, 3.0, -29.0, 178.0)  # GPS centre, its attitude
    assert b == gps["b"] and start.level == {"a": False, "b": True}  # b: level, κ measured on the images
    assert reg.names == names and not reg.dropped  # nothing refused for b
    assert "for 1 of 2" in start.source and "not registered, level start with κ from the images: b" in start.source
    assert [r["status"] for r in start.registration] == ["start", "gps"]


def test_a_refusal_after_no_frame_registered_says_so_first():
    """GPS frames without attitude whose registration to the reference placed none: every frame starts level and the
    level pass has no frame of known attitude to measure them from, so the adjustment refuses by angle σ — the line
    says first that no frame registered (frames tried, matches/inliers, the reasons) and the fix."""
    from fotogeo.errors import ModelError
    from fotogeo.tools.triangulate.control import FrameFit
    from fotogeo.tools.triangulate.register import _over_gps, _row, saying_none_registered
    from fotogeo.tools.triangulate.sources import BlockStart

    names = ["a", "b", "c"]
    gps = {n: ExteriorOrientation(30.0 * k, 0.0, 400.0, 0.0, 0.0, 90.0) for k, n in enumerate(names)}
    fits = {"a": FrameFit("a", reason="no matches with the reference"),
            "b": FrameFit("b", matches=41, reason="only 5 inliers of 41 matches"),
            "c": FrameFit("c", matches=17, reason="only 5 inliers of 17 matches")}
    problems = {n: f"not registered to the reference ({fits[n].reason})" for n in names}
    rows = [_row(n, fits[n], problems[n]) for n in names]
    reg = _over_gps([f"{n}.tif" for n in names], names, [gps[n] for n in names], [True] * 3, fits, problems, rows,
                    None)
    start = BlockStart(None, (0.0,) * 5, list(names), dict(gps), None, "", "--camera; orientation from the images' GPS",
                       sigmas={n: (5.0, 10.0, None) for n in names}, level=dict.fromkeys(names, True),
                       registration=[], over_gps=True)
    start.take_registration(reg)
    with pytest.raises(ModelError) as info, saying_none_registered(start):
        raise ModelError("the block does not determine frame(s) a: angle σ 12.3° above 0.5°", frames=["a"])
    text = str(info.value)
    assert text.startswith("no frame registered to the reference (3 tried, matches/inliers: a 0/0, b 41/0, c 17/0; "
                           "a: no matches with the reference): the 3 frame(s) without attitude tags started level"), text
    assert "give a reference showing their ground" in text and "or GCPs; then: " in text
    assert text.endswith("then: the block does not determine frame(s) a: angle σ 12.3° above 0.5°")
    from fotogeo.errors import one_line
    assert len(text) < 800 and one_line(text) == text  # the CLI's one line keeps it whole
    assert list(info.value.frames) == ["a"]
    start.registration[1] = {**start.registration[1], "status": "start"}  # one frame registered: its refusal as is
    with pytest.raises(ModelError, match="^the block does not determine"), saying_none_registered(start):
        raise ModelError("the block does not determine frame(s) a: angle σ 12.3° above 0.5°")


def test_the_images_kappa_moves_only_the_frames_whose_attitude_is_unknown():
    """One frame left level (unregistered) must not turn the registered ones: κ measured on the pairs assumes a
    level camera. On main every frame's κ was replaced when any was level — on the 12-frame block of seed 0
    DJI_103's and DJI_303's registered κ by 113° and 106°, and the bundle dropped both; here frame 0 (30° off
    nadir, registered) took −99.4° for its −90°."""
    from fotogeo.geometry.camera import FrameCamera, OrientedFrame
    from fotogeo.tools.triangulate.start import start_from_pairs
    cam = FrameCamera(520.0, (640.0, 480.0), (640, 480), (320.0, 240.0))
    registered = ExteriorOrientation(0.0, 0.0, 80.0, 0.0, -30.0, -90.0)  # looking west
    level_truth = ExteriorOrientation(-20.0, 5.0, 80.0, 0.0, 0.0, 60.0)  # nadir, started at κ 0
    rng = np.random.default_rng(0)
    xyz = np.column_stack([rng.uniform(-60, 20, 400), rng.uniform(-30, 40, 400), np.zeros(400)])
    p0, p1 = (OrientedFrame(cam, e).world_to_pixel(xyz) for e in (registered, level_truth))
    seen = np.all((p0 >= 0) & (p0 < [640, 480]) & (p1 >= 0) & (p1 < [640, 480]), axis=1)
    start = (registered, ExteriorOrientation(-20.0, 5.0, 80.0, 0.0, 0.0, 0.0))
    eos, _, report = start_from_pairs(start, cam, [(0, 1, p0[seen], p1[seen])], estimate_kappa=[False, True],
                                      estimate_height=False)
    assert eos[0] == registered and report["kappa_from_images_deg"][0] is None
    assert abs(eos[1].kappa - 60.0) < 15.0  # measured 50.4° (the level assumption, frame 0 tilted)
