"""``fotogeo triangulate`` with ``--reference`` orthophotos and ``--dem`` but neither ``--eo`` nor ``--gcps``
(issue 20): every frame registered to the reference gives the start (:mod:`fotogeo.tools.triangulate.register`).

Real data: the NGI frames 0182/0184 (no GPS, an approximate georeference in the files) against the two
orthophoto tiles and the DEM; truth: ``ngi/exterior_orientation.txt`` from a professional aerial
triangulation, never given to the tool. A frame the reference cannot place (noise with the same
georeference) is named and refused, or dropped with ``undetermined="drop"``.
"""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from fotogeo.errors import MatchingError
from fotogeo.geometry.camera import ExteriorOrientation
from fotogeo.io.camera import read_exterior_orientation
from fotogeo.tools.triangulate import triangulate
from fotogeo.tools.triangulate.control import FrameFit
from fotogeo.tools.triangulate.register import pose_problem
from ngi_triangulation import NAMES, orientation_errors


def _inputs(ngi):
    return {"camera": ngi / "interior_orientation.yaml", "reference": sorted((ngi / "ortho").glob("*.tif")),
            "dem": ngi / "dem.tif"}


def _run(frames, ngi, folder, **kw):
    i = _inputs(ngi)
    return triangulate(frames, i["camera"], kw.pop("eo", None), None, folder, reference=i["reference"], dem=i["dem"],
                       **kw)


@pytest.fixture(scope="module")
def runs(data_dir, tmp_path_factory):
    """The block started from registration, and the same block from a 20 m / 0.5° --eo (the EO-given run)."""
    from ngi_triangulation import perturbed
    from fotogeo.io.block import write_exterior_orientation
    ngi = data_dir / "ngi"
    tmp = tmp_path_factory.mktemp("reg_start")
    frames = [ngi / "frames" / f"{n}.tif" for n in NAMES]
    true = read_exterior_orientation(ngi / "exterior_orientation.txt")
    rng = np.random.default_rng(0)
    write_exterior_orientation(tmp / "eo.txt", NAMES, [perturbed(true[n], rng, 20.0, 0.5) for n in NAMES])
    rep = _run(frames, ngi, tmp / "reg")
    rep_eo = _run(frames, ngi, tmp / "eo", eo=tmp / "eo.txt")
    return {"true": true, "rep": rep, "eo": read_exterior_orientation(tmp / "reg" / "exterior_orientation.txt"),
            "eo_given": read_exterior_orientation(tmp / "eo" / "exterior_orientation.txt"), "rep_eo": rep_eo,
            "json": json.loads((tmp / "reg" / "report.json").read_text())}


def test_the_start_comes_from_registration_and_is_reported(runs):
    start = runs["json"]["start"]
    assert "registering every frame to the reference" in start["source"]
    assert start["crs_rule"] == "the reference orthophoto's CRS (--reference)"  # no --crs given: the reference's
    rows = {r["name"]: r for r in start["registration"]}
    assert set(rows) == set(NAMES) and all(r["status"] == "start" for r in rows.values())
    for n, r in rows.items():
        e = orientation_errors(ExteriorOrientation(*r["pose"]), runs["true"][n])
        # measured: 3.5 / 3.0 m and 0.033 / 0.008° (both tiles in one collinearity fit, > 2000 inliers each)
        assert r["inliers"] > 500 and e["position_m"] < 8.0 and e["angle_deg"] < 0.1, (n, r, e)
    assert runs["rep"]["automatic_control"] > 100 and not runs["rep"]["dropped_frames"]


def test_adjusted_block_is_as_good_as_the_eo_given_run(runs, data_dir):
    from fotogeo.geometry.camera import OrientedFrame
    from fotogeo.io.camera import load_camera
    from fotogeo.io.raster import read_dem
    from ngi_triangulation import dense_grid, ground_rmse
    ngi = data_dir / "ngi"
    cam, dem = load_camera(ngi / "interior_orientation.yaml"), read_dem(ngi / "dem.tif")
    stated = {q["name"]: q for q in runs["rep"]["frame_quality"]}
    for n in NAMES:
        e = orientation_errors(runs["eo"][n], runs["true"][n])
        # measured (input-derived control σ 2.5 m / 12 m): 0182 3.41 m and 0.033°, 0184 6.11 m and 0.060° from the
        # professional triangulation (Gaussian-layer SURF: 2.59 / 5.22 m, 0.015 / 0.044°); the first run's 3.74 m
        # for 0184 came from data snooping culling 21 good tie observations (then fixed in the bundle); no control σ
        # brings it back (0.5 m / 1 m: 5.86 m; per-point slope and curvature σ_z: 5.95 m) — the centre and φ trade
        # along the pair's weak direction
        assert e["position_m"] < 6.5 and e["angle_deg"] < 0.065, (n, e)
        # ... within the precision the run states (σ scaled by max(σ0, 1): 6.37 / 6.03 m, 0.071 / 0.068°)
        assert e["position_m"] < 1.5 * stated[n]["position_sigma_m"], (n, e, stated[n])
        assert e["angle_deg"] < 1.5 * stated[n]["angle_sigma_deg"], (n, e, stated[n])
        # report.json's σ (what ortho --uncertainty propagates) is the same honest one: σ0 < 1 no longer scales it
        # below the a-priori precision (it read 2.0 m / 0.021° with σ0 0.33)
        sigma = next(f["sigma"] for f in runs["rep"]["frames"] if f["name"] == n)
        assert max(sigma["X0"], sigma["Y0"], sigma["Z0"]) == pytest.approx(stated[n]["position_sigma_m"], rel=1e-9)
        assert runs["rep"]["covariance_scale"] == max(runs["rep"]["sigma0"], 1.0)
        # ... and on the ground as the professional orientation: every 10th pixel on its true height,
        # 1.08 / 1.54 m RMSE in plan (0.17 / 0.24 of a frame pixel; the first run: 1.19 / 1.51 m)
        px, truth = dense_grid(cam, runs["true"][n], dem)
        frame = OrientedFrame(cam, runs["eo"][n])
        assert ground_rmse(lambda p, z: frame.pixel_to_world_at(p, z)[:, :2], px, truth) < 1.8, n
        # the same solution as from a 20 m / 0.5° --eo: detection, matching and thinning do not see the start, so the
        # same tracks reach LSM; LSM starts from the start's local affinity, and a track on the edge of converging
        # may converge in one run only (Gaussian-layer SURF: 51 and 50 of 66; box filters: 54 of 72 in both), which
        # moves this pair along its weak direction by a fraction of its σ: 0.17 / 0.11 m and 0.002° (box: 0.0003 m)
        ma, mb = runs["rep"]["matching"], runs["rep_eo"]["matching"]
        assert ma["tracks_matched"] == mb["tracks_matched"] and ma["thinning"] == mb["thinning"], (ma, mb)
        assert abs(ma["lsm"]["converged"] - mb["lsm"]["converged"]) <= 1, (ma["lsm"], mb["lsm"])
        g = orientation_errors(runs["eo"][n], runs["eo_given"][n])
        assert g["position_m"] < 0.05 * stated[n]["position_sigma_m"], (n, g, stated[n])
        assert g["angle_deg"] < 0.05 * stated[n]["angle_sigma_deg"], (n, g, stated[n])


@pytest.fixture(scope="module")
def with_noise_frame(data_dir, tmp_path_factory):
    """The two frames and a third that no reference can place: noise under frame 0182's georeference."""
    import rasterio
    ngi = data_dir / "ngi"
    tmp = tmp_path_factory.mktemp("noise")
    src = ngi / "frames" / f"{NAMES[0]}.tif"
    noise = tmp / "noise_frame.tif"
    with rasterio.open(src) as ds:
        profile = ds.profile
        shape = (ds.count, ds.height, ds.width)
    with rasterio.open(noise, "w", **profile) as out:
        out.write(np.random.default_rng(1).integers(0, 256, shape, dtype=np.uint8))
    frames = [ngi / "frames" / f"{n}.tif" for n in NAMES] + [noise]
    return ngi, tmp, frames


def test_a_frame_the_reference_cannot_place_is_named_and_refused(with_noise_frame):
    ngi, tmp, frames = with_noise_frame
    with pytest.raises(MatchingError, match=r"no approximate orientation for frame\(s\) noise_frame: .*--undetermined drop"):
        _run(frames, ngi, tmp / "refused", undetermined="fail")
    assert not (tmp / "refused").exists()


def test_with_undetermined_drop_it_is_dropped_and_the_rest_adjusted(with_noise_frame):
    ngi, tmp, frames = with_noise_frame
    rep = _run(frames, ngi, tmp / "dropped", undetermined="drop")
    assert [d["name"] for d in rep["dropped_frames"]] == ["noise_frame"]
    assert "not registered" in rep["dropped_frames"][0]["reason"]
    rows = {r["name"]: r for r in rep["start"]["registration"]}
    assert rows["noise_frame"]["status"] == "dropped" and rows[NAMES[0]]["status"] == "start"
    eos = read_exterior_orientation(tmp / "dropped" / "exterior_orientation.txt")
    assert set(eos) == set(NAMES)
    shutil.rmtree(tmp / "dropped")


class _Model:
    def __init__(self, eo, std):
        self.frame = type("F", (), {"eo": eo})()
        self.info = {"std": std, "sigma0": 1.0}


class _Flat:
    def heights(self, xy):
        return np.full(len(xy), 500.0)


def test_pose_problem_refuses_an_undetermined_or_underground_pose():
    eo = ExteriorOrientation(0.0, 0.0, 3000.0, 0.0, 0.0, 0.0)
    good = FrameFit("a", _Model(eo, [1.0, 1.0, 1.0, 0.01, 0.01, 0.02]), 100, 80)
    assert pose_problem(good, _Flat()) == ""
    loose = FrameFit("a", _Model(eo, [1.0, 1.0, 1.0, 0.01, 3.0, 0.02]), 30, 21)
    assert "does not determine the attitude" in pose_problem(loose, _Flat())
    free = FrameFit("a", _Model(eo, [1.0, np.nan, np.nan, np.nan, np.nan, 0.02]), 30, 21)  # GCPs on a line
    assert "does not determine the attitude (angle σ undetermined from 21 inliers)" in pose_problem(free, _Flat())
    unplaced = FrameFit("a", _Model(eo, [np.nan, 1.0, 1.0, 0.01, 0.01, 0.02]), 30, 21)  # angles finite
    assert pose_problem(unplaced, _Flat()) == ("its registration does not determine the position (position σ "
                                               "undetermined from 21 inliers)")
    low = FrameFit("a", _Model(ExteriorOrientation(0.0, 0.0, 100.0, 0.0, 0.0, 0.0), [1.0] * 3 + [0.01] * 3), 100, 80)
    assert "below the terrain" in pose_problem(low, _Flat())
    assert "no matches" in pose_problem(FrameFit("a", reason="no matches with the reference"), _Flat())
