"""The angle under which a pair's rays meet at its points (fotogeo.stereo.rays.intersection_angles) and the DSM
report's per-pair figures of it (fotogeo.tools.dsm.matching: the median angle, the share under 5°)."""
from pathlib import Path

import numpy as np
import pytest

from fotogeo.stereo.rays import closest_points, intersection_angles
from fotogeo.tools.dsm.matching import angle_figures

from dsm_scenes import make_scene


def test_the_angle_of_two_rays_at_their_point():
    c1, c2 = np.array([-10.0, 0.0, 100.0]), np.array([10.0, 0.0, 100.0])
    P = np.array([[0.0, 0.0, 0.0], [0.0, 50.0, 0.0], [10.0, 0.0, 0.0]])
    g = intersection_angles(P, c1, c2)
    assert g[0] == pytest.approx(2 * np.degrees(np.arctan(10 / 100)))
    r = np.hypot(50.0, 100.0)                          # farther off the base: a narrower angle
    assert g[1] == pytest.approx(2 * np.degrees(np.arctan(10 / r)))
    c_a, c_b = c1 - P[2], c2 - P[2]
    assert g[2] == pytest.approx(np.degrees(np.arccos(c_a @ c_b / np.linalg.norm(c_a) / np.linalg.norm(c_b))))
    X, _ = closest_points(c1, P[:1] - c1, c2, P[:1] - c2)     # the rays of the triangulation meet at the point
    assert np.allclose(X, P[:1])
    assert np.isnan(intersection_angles(np.array([[np.nan, 0.0, 0.0], [-10.0, 0.0, 100.0]]), c1, c2)).all()


def test_the_reports_angle_figures_are_the_median_and_share_of_the_angles_counted():
    rng = np.random.default_rng(3)
    g = np.concatenate([rng.uniform(1.0, 5.0, 3000), rng.uniform(5.0, 20.0, 7000)])
    counts = np.bincount((g / 0.1).astype(int), minlength=1800)
    f = angle_figures(counts)
    assert f["ray_angle_median_deg"] == pytest.approx(np.median(g), abs=0.1)
    assert f["ray_angle_under_5deg"] == pytest.approx(0.3, abs=1e-4)
    assert angle_figures(None) == {} and angle_figures(np.zeros(1800, int)) == {}


def test_the_dsm_report_gives_each_frame_pairs_ray_angles(tmp_path):
    """Two consecutive nadir frames: the report's median angle is that of the rays at the point cloud's points
    (from the two projection centres), its share under 5° theirs."""
    laspy = pytest.importorskip("laspy", reason="laspy (a dependency of fotogeo) is not installed")
    from fotogeo.tools.dsm import dsm
    sc = make_scene("nadir", tmp_path / "scene")
    names = ("s1_01", "s1_02")
    imgs = [p for p in sc["images"] if Path(p).stem in names]
    rep = dsm(imgs, tmp_path / "d.tif", camera=sc["camera"], eo=sc["eo"], crs=sc["crs"],
              point_cloud=tmp_path / "p.las", report=tmp_path / "r.json")
    (p,) = [q for q in rep["pairs"] if q["kept"]]
    rows = {x.split()[0]: x.split() for x in Path(sc["eo"]).read_text().splitlines() if x and x[0] != "#"}
    c1, c2 = (np.array([float(v) for v in rows[n][1:4]]) for n in names)
    las = laspy.read(tmp_path / "p.las")
    g = intersection_angles(np.column_stack([las.x, las.y, las.z]), c1, c2)
    assert len(g) == p["points"] > 1000
    assert p["ray_angle_median_deg"] == pytest.approx(np.median(g), abs=0.1)
    assert p["ray_angle_under_5deg"] == pytest.approx(np.mean(g < 5.0), abs=1e-3)
    assert 0.8 * p["convergence_deg"] < p["ray_angle_median_deg"] < 1.2 * p["convergence_deg"]
