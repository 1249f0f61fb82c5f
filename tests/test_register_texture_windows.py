"""LSM windows chosen by texture when the matched keypoints are fewer than the LSM budget
(fotogeo.tools.register.texture, fotogeo.tools.register.points), used only once the matches alone make an
accepted fit (fotogeo.tools.register.local.matched_and_fitted)."""
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
import rasterio

from fotogeo.errors import MatchingError
from fotogeo.pixels import pixel_to_map
from fotogeo.tools.register import local
from fotogeo.tools.register.points import TiePoints
from fotogeo.tools.register.texture import texture_points
from fotogeo.tools.register.tool import register
from known_warps import known_warp_bands
from rotated_pairs import apply, make_case


def test_texture_points_are_textured_spread_inside_the_valid_area_and_away_from_taken(rng):
    img = np.full((120, 160), 50.0, np.float32)
    img[:, 80:] = rng.normal(100, 30, (120, 80))  # texture on the right half only
    img[:10, :] = np.nan
    taken = np.array([[120.5, 60.5]])
    xy = texture_points(img, taken, 40, 5)
    assert 10 <= len(xy) <= 40
    assert (xy[:, 0] > 80 - 5).all()  # not on the flat half
    assert (xy[:, 1] > 10 + 5).all() and (xy[:, 1] < 120 - 5).all() and (xy[:, 0] < 160 - 5).all()
    d = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1)) + np.eye(len(xy)) * 99
    assert d.min() >= 11 - 1e-9 and np.hypot(*(xy - taken).T).min() >= 11 - 1e-9
    assert len(texture_points(img, taken, 0, 5)) == 0
    assert len(texture_points(np.full((30, 30), np.nan, np.float32), taken, 5, 5)) == 0


def test_few_keypoint_matches_are_topped_up_by_textured_windows(data_dir, tmp_path):
    # a SWIR-only Landsat target against RGB, rotated and scaled: SURF matches about 60 points, the LSM budget is 150
    ref, tgt, grid, truth = known_warp_bands(data_dir, "landsat", "r45_s1.2_p", "ref3_tgtS", tmp_path)
    with rasterio.open(ref) as ds:
        px = abs(ds.transform.a)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = register(ref, tgt, tmp_path / "out.tif", seed=0)
    lsm = r.report["lsm"]
    assert lsm["texture_windows"] > 0 and lsm["tried"] <= lsm["budget"]
    assert lsm["of"] == r.report["matches"] + lsm["texture_windows"] == sum(lsm["status"].values())
    assert lsm["refined"] > r.report["matches"] and lsm["texture_windows_used"] is True
    dense = float(np.sqrt(np.mean(np.hypot(*(r.model.forward(grid) - truth).T) ** 2))) / px
    assert dense <= 0.05, dense


def _found(rng, n_matches, n_windows):
    """Tie points of ``n_matches`` keypoint matches topped up by ``n_windows`` texture windows (``matched``)."""
    xy = rng.uniform(0, 400, (n_matches + n_windows, 2))
    counts = {"lsm": {"texture_windows": n_windows}}
    alone = TiePoints(xy[:n_matches], xy[:n_matches], counts)
    return TiePoints(xy, xy, counts, matched=alone)


def _fit(pts):
    """A fit keeping every point as a control point with a 0.05 px scatter."""
    n = len(pts.src)
    res = np.random.default_rng(n).normal(0, 0.05, (n, 2))
    return pts, pts.ref_xy, SimpleNamespace(inliers=np.ones(n, bool), role=np.array(["control"] * n), residual_m=res,
                                            z=None)


def _decide(found, monkeypatch, area_fallback=True):
    def no_windows(*args, **kwargs):
        raise MatchingError("no reliable window")
    monkeypatch.setattr(local, "area_tie_points", no_windows)
    opts = SimpleNamespace(area_fallback=area_fallback)
    prog = SimpleNamespace(stage=lambda *a: None)
    return local.matched_and_fitted("ref.tif", "tgt.tif", None, SimpleNamespace(width=400, height=400), opts, prog,
                                    lambda: found, _fit, None, "lsm", 1.0)


def test_texture_windows_do_not_confirm_a_weak_fit_of_the_matches(rng, monkeypatch):
    # 8 matches (fewer than WEAK_INLIERS) + 150 windows at their homography's prediction: the decision is the 8's
    found = _found(rng, 8, 150)
    with pytest.raises(MatchingError, match="the feature fit of 8 inliers .* is not confirmed"):
        _decide(found, monkeypatch)
    pts, _, gf, _ = _decide(found, monkeypatch, area_fallback=False)  # kept as asked, without the windows
    assert len(pts.src) == int(gf.inliers.sum()) == 8
    assert found.counts["lsm"]["texture_windows_used"] is False


def test_texture_windows_refine_a_fit_the_matches_confirm(rng, monkeypatch):
    found = _found(rng, 40, 110)
    pts, _, gf, _ = _decide(found, monkeypatch)
    assert len(pts.src) == int(gf.inliers.sum()) == 150
    assert found.counts["lsm"]["texture_windows_used"] is True


def test_texture_windows_that_did_not_converge_stay_out_of_the_fit(data_dir, tmp_path):
    """Two dates (s2_pair), rotated 25°: most texture windows land on changed ground and do not converge. They must
    not make the fit fall back to every match (unrefined windows sit at the rough homography's prediction), and
    with so few converged none is used (the few that converge made a 1500 px two-date chip worse)."""
    ref, tgt, H, check = make_case(data_dir, "s2pair_r25_s1.1", tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = register(ref, tgt, tmp_path / "out.tif", seed=0)
    lsm = r.report["lsm"]
    assert lsm["texture_windows"] > 0 and lsm["texture_windows_converged"] < 0.25 * lsm["texture_windows"]
    assert lsm["texture_windows_used"] is False and lsm["fit_uses"] == "the converged points"
    with rasterio.open(ref) as ds:
        t = ds.transform
    err = np.hypot(*(r.model.forward(check) - pixel_to_map(t, apply(H, check))).T) / abs(t.a)
    assert np.sqrt(np.mean(err ** 2)) < 0.1
