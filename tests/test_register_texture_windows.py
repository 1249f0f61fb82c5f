"""LSM windows chosen by texture when the matched keypoints are fewer than the LSM budget
(fotogeo.tools.register.texture, fotogeo.tools.register.points)."""
import warnings

import numpy as np
import rasterio

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
    assert lsm["consistent"] <= r.report["matches"]  # the matches consistent with the fit, not the texture windows
    dense = float(np.sqrt(np.mean(np.hypot(*(r.model.forward(grid) - truth).T) ** 2))) / px
    assert dense <= 0.05, dense
