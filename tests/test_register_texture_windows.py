"""LSM windows chosen by texture when the matched keypoints are fewer than the LSM budget
(fotogeo.tools.register.texture, fotogeo.tools.register.points), used only once the matches alone make an
accepted fit (fotogeo.tools.register.local.matched_and_fitted)."""
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
import rasterio

from fotogeo.errors import MatchingError
from fotogeo.tools.register import local
from fotogeo.tools.register.points import TiePoints
from fotogeo.tools.register.texture import texture_points
from fotogeo.tools.register.tool import register
from known_warps import known_warp_bands


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
    assert lsm["refined"] > r.report["matches"]
    dense = float(np.sqrt(np.mean(np.hypot(*(r.model.forward(grid) - truth).T) ** 2))) / px
    assert dense <= 0.05, dense


def _found(rng, n_matches, n_windows):
    """Tie points of ``n_matches`` keypoint matches topped up by ``n_windows`` texture windows (``matched``)."""
    xy = rng.uniform(0, 400, (n_matches + n_windows, 2))
    counts = {"lsm": {"texture_windows": n_windows}}
    alone = TiePoints(xy[:n_matches], xy[:n_matches], counts)
    return TiePoints(xy, xy, counts, matched=alone)


def _fitter(matches_off, windows_off):
    """``fit(pts)``: every point a control point (a fifth check points) with a 0.05 px scatter; the model is
    ``matches_off`` px off the truth when fitted to the matches alone (< 100 points), else ``windows_off``."""
    def fit(pts):
        n = len(pts.src)
        off = matches_off if n < 100 else windows_off
        role = np.where(np.arange(n) % 5 == 0, "check", "control")
        res = np.random.default_rng(n).normal(0, 0.05, (n, 2)) + off
        model = SimpleNamespace(forward=lambda xy: xy + off)
        return pts, pts.ref_xy, SimpleNamespace(inliers=np.ones(n, bool), role=role, residual_m=res, z=None,
                                                model=model)
    return fit


def _decide(found, fit, monkeypatch, area_fallback=True):
    def no_windows(*args, **kwargs):
        raise MatchingError("no reliable window")
    monkeypatch.setattr(local, "area_tie_points", no_windows)
    opts = SimpleNamespace(area_fallback=area_fallback)
    prog = SimpleNamespace(stage=lambda *a: None)
    return local.matched_and_fitted("ref.tif", "tgt.tif", None, SimpleNamespace(width=400, height=400), opts, prog,
                                    lambda: found, fit, None, "lsm", 1.0)


def test_texture_windows_do_not_confirm_a_weak_fit_of_the_matches(rng, monkeypatch):
    # 8 matches (fewer than WEAK_INLIERS) + 150 windows at their homography's prediction: the decision is the 8's
    found = _found(rng, 8, 150)
    with pytest.raises(MatchingError, match="the feature fit of 8 inliers .* is not confirmed"):
        _decide(found, _fitter(0.0, 0.0), monkeypatch)
    pts, _, gf, _ = _decide(found, _fitter(0.0, 0.0), monkeypatch, area_fallback=False)  # kept, without windows
    assert len(pts.src) == int(gf.inliers.sum()) == 8
    assert found.counts["lsm"]["texture_windows_check"]["kept"] == "matches alone"


def test_texture_windows_refine_a_confirmed_fit_when_closer_to_its_check_points(rng, monkeypatch):
    found = _found(rng, 40, 110)
    pts, _, gf, _ = _decide(found, _fitter(0.1, 0.0), monkeypatch)
    assert len(pts.src) == 150 - 8  # the matches' 8 check points stay out of the fit with the windows
    c = found.counts["lsm"]["texture_windows_check"]
    assert c["kept"] == "with windows" and c["with_windows_rmse_px"] == 0 < c["matches_fit_rmse_px"]


def test_texture_windows_farther_from_the_check_points_are_dropped(rng, monkeypatch):
    # two dates: windows on changed ground pull the fit 0.4 px off where the matches' fit is 0.1 px off
    found = _found(rng, 40, 110)
    pts, _, gf, _ = _decide(found, _fitter(0.1, 0.4), monkeypatch)
    assert len(pts.src) == 40 and found.counts["lsm"]["texture_windows_check"]["kept"] == "matches alone"
