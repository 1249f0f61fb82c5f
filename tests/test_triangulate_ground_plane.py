"""The ground grid of guided matching (fotogeo/tools/triangulate/ground.py, guided.py) without rendering: which pairs
are matched on the ground and why, where converging axes meet, and that a tile's cells go back to the frame's
pixels. Fast: orientations only (the rendered sets are in test_triangulate_converging.py)."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.geometry.attitude import patb_in_map, rotation_from_ypr
from fotogeo.geometry.camera import ExteriorOrientation
from fotogeo.tools.triangulate import ground, guided
from rendered_converging import CRS, GROUND, camera, shots
from rendered_oblique import _lonlat

DIST = (-0.05, 0.015, 0.0, 0.0003, -0.0002)


def _eo(centre, ypr):
    lon, lat = _lonlat(centre[:2], CRS)
    return ExteriorOrientation(*centre, *patb_in_map(rotation_from_ypr(*ypr), lon, lat, CRS))


def _converging(off_nadir=30.0, seed=0):
    return [_eo(c, ypr) for _, c, ypr in shots(np.random.default_rng(seed), off_nadir)]


def _nadir(xs):
    return [_eo(np.array([500000.0 + x, 4420000.0, GROUND + 60.0]), (0.0, -90.0, 0.0)) for x in xs]


def test_converging_axes_meet_on_the_ground_and_parallel_ones_nowhere():
    for off in (30.0, 38.0, 45.0):
        assert abs(guided.axes_height(_converging(off)) - GROUND) < 3.0
    assert abs(guided.axes_height(_converging(30.0)[:3]) - GROUND) < 3.0  # three views
    assert guided.axes_height(_nadir([0.0, 20.0, 40.0])) is None


def test_pairs_are_matched_on_the_ground_by_overlap_and_the_report_says_why():
    cam = camera((600, 400))
    eos = _converging(30.0) + _nadir([0.0, 15.0]) + _nadir([900.0])
    pairs = [(0, 1), (0, 2), (1, 3), (4, 5), (4, 6), (0, 6)]
    good = (60, np.zeros((40, 2)), np.zeros((40, 2)))
    found = [None, (30, np.zeros((20, 2)), np.zeros((20, 2))), None, good, None, None]
    fps = [ground.footprint(cam, eo, GROUND) for eo in eos]
    todo, rows = guided.choose_pairs(pairs, found, eos, fps)
    assert 3 not in rows  # a nadir pair with 40 plain inliers is left alone
    assert {pairs[k] for k in todo} == {(0, 1), (0, 2), (1, 3)}
    assert all("optical axes" in rows[k]["why"] for k in todo)
    assert [rows[k]["ground_overlap"] for k in todo] == sorted((rows[k]["ground_overlap"] for k in todo),
                                                              reverse=True)
    for k in (4, 5):  # far apart on the ground: considered, not matched, and said so
        assert "plain inliers" in rows[k]["why"] or "optical axes" in rows[k]["why"]
        assert rows[k]["ground_overlap"] < guided.MIN_GROUND_OVERLAP and "share" in rows[k]["skipped"]


def test_a_tile_is_a_window_of_the_block_grid_and_its_cells_go_back_to_the_frame():
    cam = camera((600, 400))
    eos = _converging(45.0)
    fps = [ground.footprint(cam, eo, GROUND) for eo in eos]
    grid = ground.block_grid(cam, eos, fps, GROUND, 2 ** 17)
    xy = np.random.default_rng(1).uniform(0, 300, (50, 2))
    for eo, fp in zip(eos, fps):
        window, offset = ground.tile(grid, fp)
        own = ground.grid_to_pixels(cam, DIST, eo, GROUND, window, xy)
        assert np.allclose(own, ground.grid_to_pixels(cam, DIST, eo, GROUND, grid, xy + offset), atol=1e-6)
        # the lattice map of the resampling agrees with the exact projection inside the frame
        cols, rows = window[3], window[4]
        gx, gy = np.meshgrid(np.arange(cols) + 0.5, np.arange(rows) + 0.5)
        exact = ground.grid_to_pixels(cam, DIST, eo, GROUND, window, np.column_stack([gx.ravel(), gy.ravel()]))
        inside = np.isfinite(exact).all(1) & (exact >= 0).all(1) & (exact < cam.image_size).all(1)
        err = np.hypot(*(ground._pixel_map(cam, DIST, eo, GROUND, window)[inside] - exact[inside]).T)
        assert inside.sum() > 0.2 * cols * rows and np.nanmax(err) < 0.15, np.nanmax(err)


def _partly_level(names, eos, unknown):
    """A start whose frames ``unknown`` start level (attitude unknown, κ from the images), the others registered."""
    from fotogeo.tools.triangulate.sources import BlockStart
    return BlockStart(camera((600, 400)), (0.0,) * 5, list(names), dict(zip(names, eos)), CRS, "", "the images' GPS",
                      level={n: n in unknown for n in names})


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")  # frames carry no geotransform
def test_a_level_frame_keeps_only_its_own_pairs_off_the_ground_plane(tmp_path, monkeypatch):
    """Issue 32: a frame left level (unregistered, κ measured on the images) switched the ground plane off for the
    whole block (on the rendered 12-frame oblique block of seed 0 with 4 frames left level: 4,503 tie inliers, 6,877
    per pair). Now the decision is per pair: the start's own record of the level frames reaches the guided
    matching, which skips (and says why) the pairs holding one, and measures its plane on the others only."""
    import rasterio
    from fotogeo.tools.triangulate import match
    cam, eos = camera((600, 400)), _converging(30.0)
    names = [f"f{k}" for k in range(len(eos))]
    frames = []
    for n in names:
        frames.append(tmp_path / f"{n}.tif")
        with rasterio.open(frames[-1], "w", driver="GTiff", width=600, height=400, count=1, dtype="uint8") as ds:
            ds.write(np.zeros((1, 400, 600), np.uint8))
    seen = {}

    def no_matches(infos, pairs, *args, guide=None):
        seen["pairs"], seen["guide"] = pairs, guide
        return [None] * len(pairs), [], None
    monkeypatch.setattr(match, "_pair_results", no_matches)
    match.block_tie_points(frames, cam, eos, GROUND, start=_partly_level(names, eos, {"f1"}).measure(GROUND))
    assert seen["guide"] is not None, "the ground plane was switched off for the whole block"  # so on int16
    known = seen["guide"][2]
    assert known == [True, False, True, True]

    pairs, found = seen["pairs"], [None] * len(seen["pairs"])
    fps = [ground.footprint(cam, eo, GROUND) for eo in eos]
    todo, rows = guided.choose_pairs(pairs, found, eos, fps, known)
    assert {pairs[k] for k in todo} == {p for p in pairs if 1 not in p} and len(todo) == 3
    for k in set(rows) - set(todo):
        assert pairs[k][0] == 1 or pairs[k][1] == 1
        assert rows[k]["skipped"] == "attitude unknown (level start, κ from the images): frame 1"
    # every candidate pair holds the level frame: nothing is resampled, the plain results stay, no plane measured
    level_pairs = [p for p in pairs if 1 in p]
    out, tried, z = guided.guided_results(None, level_pairs, [None] * len(level_pairs), cam, None, eos, GROUND, None,
                                          1.0, None, 2 ** 16, known=known)
    assert out == [None] * len(level_pairs) and z is None and all("attitude unknown" in r["skipped"] for r in tried)


def _level_ties(rng, cam, known, truth, n=600, wrong=0.2):
    """Ties of a frame of known attitude ``known`` with a frame whose true orientation is ``truth``: ground points
    seen by ``known`` on ±8 m of relief, 0.5 px of noise in the other frame, a fraction ``wrong`` of them anywhere."""
    from fotogeo.geometry.camera import OrientedFrame
    xyz = OrientedFrame(cam, known).pixel_to_world_at(rng.uniform(0, cam.image_size, (n, 2)), rng.uniform(-8, 8, n))
    p0, p1 = (OrientedFrame(cam, e).world_to_pixel(xyz) for e in (known, truth))
    seen = np.all((p1 >= 0) & (p1 < cam.image_size), axis=1)
    p0, p1 = p0[seen], p1[seen] + rng.normal(0, 0.5, (seen.sum(), 2))
    bad = rng.random(len(p1)) < wrong
    p1[bad] = rng.uniform(0, cam.image_size, (bad.sum(), 2))
    return p0, p1


def test_a_level_frame_takes_the_attitude_its_ties_with_known_frames_measure():
    """Issue 32: a frame left level in an oblique block starts 30° off; its ties with the frames of known attitude
    measure it (their rays through the plane, Wahba/Kabsch). Here 0.12° from the truth (the level start 29.4°) with a
    fifth of the ties wrong and ±8 m of relief off the plane; without the trimming of wrong ties (mutation) 2.7°."""
    from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
    from rendered_oblique import angle_error
    cam = FrameCamera(520.0, (640.0, 480.0), (640, 480), (320.0, 240.0))
    known = ExteriorOrientation(0.0, 0.0, 80.0, 0.0, -30.0, -90.0)
    truth = ExteriorOrientation(-20.0, 5.0, 80.0, 10.0, -25.0, -70.0)
    level = ExteriorOrientation(-20.0, 5.0, 80.0, 0.0, 0.0, -60.0)  # its κ from the images, 10° off
    p0, p1 = _level_ties(np.random.default_rng(0), cam, known, truth)
    eos, measured = guided.measured_attitudes(cam, None, [known, level], [(0, 1)], [(0, p0, p1)], [True, False], 0.0)
    assert measured == [False, True]
    assert eos[0] == known and eos[1].centre.tolist() == level.centre.tolist()
    assert angle_error(level, truth) > 25.0 and angle_error(eos[1], truth) < 0.3, angle_error(eos[1], truth)
    few, _ = guided.measured_attitudes(cam, None, [known, level], [(0, 1)], [(0, p0[:8], p1[:8])], [True, False], 0.0)
    assert few[1] == level  # too few ties: left as it was


def test_a_level_frame_is_measured_on_the_dem_when_there_is_one():
    """Issue 32 (the 12-frame block of seed 4 dropped DJI_401): the known frames' rays met a plane, while the ground
    under steep obliques lay up to 30 m off it, so the ties' ground points were metres off and the attitudes they
    measured 2.6–61° wrong (DJI_401 60.9°: it then lost every tie point). On the DEM given to triangulate they are
    measured within 3.6° there. Here a frame looking south at what a frame looking east sees, over ±22 m of relief:
    on the DEM 0.001° from the truth, on the plane of the mean height 2.7° (the mutation: terrain ignored)."""
    from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
    from rendered_oblique import angle_error
    cam = FrameCamera(520.0, (640.0, 480.0), (640, 480), (320.0, 240.0))
    known = ExteriorOrientation(0.0, 0.0, 80.0, 0.0, -30.0, -90.0)  # looks east
    truth = ExteriorOrientation(46.0, 46.0, 80.0, -30.0, 0.0, 180.0)  # looks south at the same ground
    level = ExteriorOrientation(46.0, 46.0, 80.0, 0.0, 0.0, 190.0)

    def heights(xy):
        xy = np.asarray(xy)
        return 12.0 * np.sin(xy[:, 0] / 9.0) + 10.0 * np.cos(xy[:, 1] / 7.0)
    rng = np.random.default_rng(3)
    p0 = rng.uniform(0, cam.image_size, (1500, 2))
    xyz = OrientedFrame(cam, known).pixel_to_world(p0, heights)
    p1 = OrientedFrame(cam, truth).world_to_pixel(xyz)
    seen = np.all((p1 >= 0) & (p1 < cam.image_size), axis=1) & np.isfinite(xyz).all(axis=1)
    p0, p1 = p0[seen], p1[seen] + rng.normal(0, 0.5, (seen.sum(), 2))
    args = (cam, None, [known, level], [(0, 1)], [(0, p0, p1)], [True, False], float(np.mean(xyz[seen, 2])))
    on_plane = angle_error(guided.measured_attitudes(*args)[0][1], truth)
    on_dem = angle_error(guided.measured_attitudes(*args, terrain=heights)[0][1], truth)
    assert on_dem < 0.1 and on_plane > 1.5, (on_dem, on_plane)


def test_a_level_frame_tied_only_to_level_frames_is_measured_once_they_are():
    """Issue 32: with the reference blanked under several frames, a level frame's neighbours can all be level
    too (its ties only with them); it is measured in a second round, on the ties with the frames the first round
    measured (on int18 it stayed level: one round, ties with frames known from the start only). A third level frame
    with no ties stays as it was."""
    from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
    from rendered_oblique import angle_error
    cam = FrameCamera(520.0, (640.0, 480.0), (640, 480), (320.0, 240.0))
    known = ExteriorOrientation(0.0, 0.0, 80.0, 0.0, -30.0, -90.0)
    first = ExteriorOrientation(-20.0, 5.0, 80.0, 10.0, -25.0, -70.0)
    second = ExteriorOrientation(-35.0, 12.0, 81.0, 20.0, -5.0, -20.0)
    rng = np.random.default_rng(2)
    p0, p1 = _level_ties(rng, cam, known, first)
    q1, q2 = _level_ties(rng, cam, first, second, wrong=0.1)
    q1 = q1 + rng.normal(0, 0.5, q1.shape)
    level = [ExteriorOrientation(e.X, e.Y, e.Z, 0.0, 0.0, e.kappa + 8.0) for e in (first, second, second)]
    eos, measured = guided.measured_attitudes(cam, None, [known, *level], [(0, 1), (1, 2), (0, 3)],
                                              [(0, p0, p1), (0, q1, q2), None], [True, False, False, False], 0.0)
    assert measured == [False, True, True, False] and eos[3] == level[2]
    assert angle_error(level[1], second) > 20.0
    assert angle_error(eos[1], first) < 0.3 and angle_error(eos[2], second) < 0.5, \
        (angle_error(eos[1], first), angle_error(eos[2], second))
    assert eos[2].centre.tolist() == level[1].centre.tolist()


def test_the_pairs_of_a_measured_level_frame_are_matched_on_the_ground_plane(monkeypatch):
    """Issue 32: once its attitude is measured, a level frame's pairs with frames of known attitude go through the
    ground-plane matching (on main they stayed plain, and the bundle dropped the frame: 3 tie points after LSM on
    the rendered 12-frame block of seed 0 with the reference zeroed under DJI_303); a pair of two frames still
    level, and the pairs of frames known from the start, are not matched again."""
    from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
    cam = FrameCamera(520.0, (640.0, 480.0), (640, 480), (320.0, 240.0))
    known = ExteriorOrientation(0.0, 0.0, 80.0, 0.0, -30.0, -90.0)
    truth = ExteriorOrientation(-20.0, 5.0, 80.0, 10.0, -25.0, -70.0)
    level = ExteriorOrientation(-20.0, 5.0, 80.0, 0.0, 0.0, -60.0)
    p0, p1 = _level_ties(np.random.default_rng(1), cam, known, truth)
    eos = [known, known, level, level]
    pairs = [(0, 1), (0, 2), (1, 2), (2, 3)]
    found = [(9, p0, p0), (9, p0, p1), (9, p0, p1), None]
    seen = {}

    def record(infos, pairs, found, camera, distortion, eos, height, *args, known=None):
        seen.update(pairs=pairs, known=known, eos=eos)
        return [(1, np.zeros((50, 2)), np.zeros((50, 2)))] * len(pairs), [{"pair": list(p)} for p in pairs], None
    monkeypatch.setattr(guided, "guided_results", record)
    out, tried, new, measured = guided.level_pass(None, pairs, found, cam, None, eos, 0.0, [True, True, False, False],
                                                  None, 1.0, None, 2 ** 16)
    assert measured == [False, False, True, False] and new[2] != level and new[3] == level
    assert seen["pairs"] == [(0, 2), (1, 2)] and seen["known"] == [True, True, True, False] and seen["eos"] == new
    assert out[0] is found[0] and out[3] is None and len(out[1][1]) == len(out[2][1]) == 50
    assert [r["pair"] for r in tried] == [[0, 2], [1, 2]]


def test_a_hill_higher_than_the_cameras_outside_the_block_does_not_refuse_the_level_pass():
    """Review of s19: the level pass gave the whole DEM to ``pixel_to_world``, whose search bracket is the DEM's
    height range; a regional DEM with one hill 2 km away higher than the drone (150 m, cameras at 80 m) refused the
    block ("the DEM reaches 151.8, above the projection centre"; int19 622ee5c raised ModelError here). The rays of
    a frame the DEM rises above somewhere are intersected below its centre: the level frame is measured on the DEM
    as without the hill."""
    from affine import Affine

    from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
    from fotogeo.geometry.dem import Dem
    from rendered_oblique import angle_error
    cam = FrameCamera(520.0, (640.0, 480.0), (640, 480), (320.0, 240.0))
    known = ExteriorOrientation(0.0, 0.0, 80.0, 0.0, -30.0, -90.0)
    truth = ExteriorOrientation(46.0, 46.0, 80.0, -30.0, 0.0, 180.0)
    level = ExteriorOrientation(46.0, 46.0, 80.0, 0.0, 0.0, 190.0)
    X, Y = np.meshgrid(np.arange(-200, 2200, 2.0) + 1.0, np.arange(300, -300, -2.0) - 1.0)
    relief = 12.0 * np.sin(X / 25.0) + 10.0 * np.cos(Y / 20.0)
    hill = 150.0 * np.exp(-((X - 2000.0) ** 2 + Y ** 2) / 200.0 ** 2)
    grid = Affine(2.0, 0, -200, 0, -2.0, 300)
    rng = np.random.default_rng(3)
    p0 = rng.uniform(0, cam.image_size, (1500, 2))
    xyz = OrientedFrame(cam, known).pixel_to_world(p0, Dem(relief, grid))
    p1 = OrientedFrame(cam, truth).world_to_pixel(xyz)
    seen = np.all((p1 >= 0) & (p1 < cam.image_size), axis=1) & np.isfinite(xyz).all(axis=1)
    args = (cam, None, [known, level], [(0, 1)], [(0, p0[seen], p1[seen])], [True, False], 0.0)
    eos, measured = guided.measured_attitudes(*args, terrain=Dem(relief + hill, grid))
    assert measured == [False, True] and angle_error(eos[1], truth) < 0.1, angle_error(eos[1], truth)
