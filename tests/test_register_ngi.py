"""Registration of the real NGI frames and the Sentinel-2 scenes (../shared/data).

Truth for the raw frames: camera + exterior orientation + DEM (fotogeo.geometry.camera), checked
against the orthophotos in tests/test_camera.py. Relief makes any homography approximate,
so the dense-grid error is compared with the best homography that exists (least squares to
the truth grid); the difference is what matching and fitting lose.
"""
import json

import numpy as np
import pytest
import rasterio
from pyproj import CRS

from fotogeo.crs import transform_points
from fotogeo.models import Projective
from fotogeo.pixels import pixel_centres
from fotogeo.tools.register.tool import register
from ngi_truth import FRAMES, truth_points



def truth_grid(ngi, name, step=10):
    """Frame pixels on a dense grid and their true ground positions in EPSG:32735."""
    px, xyz = truth_points(ngi, name, step)
    return px, xyz[:, :2]


@pytest.mark.parametrize("name,ortho", FRAMES)
def test_frame_registers_close_to_the_best_homography(data_dir, tmp_path, name, ortho):
    ngi = data_dir / "ngi"
    out = tmp_path / "frame.tif"
    r = register(ngi / "ortho" / ortho, ngi / "frames" / f"{name}_RGB.tif", out, seed=0)
    grid, truth = truth_grid(ngi, name)
    # the default output CRS is the reference's (tmerc lon_0=25, not UTM): the truth goes there
    with rasterio.open(ngi / "ortho" / ortho) as ref:
        ref_crs, ref_t = CRS.from_wkt(ref.crs.to_wkt()), ref.transform
    truth = transform_points(CRS.from_epsg(32735), ref_crs, truth)
    dense = float(np.sqrt(np.mean(r.model.residuals(grid, truth) ** 2)))
    best = float(np.sqrt(np.mean(Projective.estimate(grid, truth).residuals(grid, truth) ** 2)))
    # relief: even the best homography is tens of metres off; ours must come within 1.3x of it
    assert 30 < best < 70
    assert dense < 1.3 * best, (dense, best)
    with rasterio.open(out) as ds:
        assert CRS.from_wkt(ds.crs.to_wkt()) == ref_crs and ds.count == 3 and ds.res == (5.0, 5.0)
        # on the reference's pixel grid: the origin a whole number of reference pixels away
        off = np.array([(ds.transform.c - ref_t.c) / 5.0, (ds.transform.f - ref_t.f) / 5.0])
        assert np.allclose(off, np.round(off), atol=1e-6), off
    rep = json.loads(out.with_suffix(".json").read_text())
    assert rep["output_grid"]["aligned_to_reference"] and rep["output_crs_rule"].startswith("auto: the reference's")
    assert rep["check"]["n"] > 50 and rep["inliers"] > 200


def test_sentinel2_other_sensor_to_orthophoto(data_dir, tmp_path):
    """10 m Sentinel-2 (other sensor, season) registered to the 5 m orthophoto of tile 1."""
    ngi = data_dir / "ngi"
    out = tmp_path / "s2.tif"
    r = register(ngi / "ortho" / "ngi_rgb_byte_1.tif", ngi / "sentinel2_b432_byte.tif", out, seed=0)
    rep = r.report
    assert rep["inliers"] > 50
    # both are orthoimages of one valley, but on different DEMs and 10 m vs 5 m: the check
    # residuals are the tie points' noise plus the orthoimages' own disagreement, measured
    # 9-19 m over SURF versions; two Sentinel-2 pixels is the honest bound
    assert rep["check"]["rmse_m"] < 20.0, rep["check"]


def test_sentinel2_two_dates_with_clouds(data_dir, tmp_path):
    """Same sensor, two dates, one band, clouds and zero fill (nodata given explicitly)."""
    s2 = data_dir / "s2_pair"
    out = tmp_path / "s2pair.tif"
    r = register(s2 / "ref_S2A_20160608T153121_T33UUU_sub.jp2", s2 / "tgt_S2A_20160529T153631_T33UUU_sub.jp2",
                 out, reference_nodata=0, target_nodata=0, model="affine", seed=0)
    rep = r.report
    assert rep["output_crs"] == "EPSG:32633" and rep["inliers"] > 200
    assert rep["check"]["rmse_px"] < 1.5, rep["check"]
    # the target is already on the same 10 m grid, misregistered by about a pixel at most:
    # the fitted model must be close to the identity map of the target's georeference
    with rasterio.open(s2 / "tgt_S2A_20160529T153631_T33UUU_sub.jp2") as ds:
        t = ds.transform
    grid = np.column_stack([pixel_centres(20, 30)[0].ravel(), pixel_centres(20, 30)[1].ravel()]) * 100
    geo = np.column_stack([t.a * grid[:, 0] + t.c, t.e * grid[:, 1] + t.f])
    d = np.hypot(*(r.model.forward(grid) - geo).T)
    assert np.sqrt(np.mean(d ** 2)) < 20.0  # two 10 m pixels


def test_match_only_layer_and_cli(data_dir, tmp_path):
    import geopandas as gpd
    from click.testing import CliRunner

    from fotogeo.cli import main
    ngi = data_dir / "ngi"
    out = tmp_path / "tp.gpkg"
    r = CliRunner().invoke(main, ["match", str(ngi / "ortho" / "ngi_rgb_byte_1.tif"),
                                  str(ngi / "frames" / f"{FRAMES[0][0]}_RGB.tif"), "-o", str(out), "-q"])
    assert r.exit_code == 0, r.output
    tp = gpd.read_file(out, layer="tie_points")
    assert len(tp) > 500 and tp.inlier.sum() > 200 and tp.crs is not None
    # inliers sit at their reference pixels' map positions
    with rasterio.open(ngi / "ortho" / "ngi_rgb_byte_1.tif") as ds:
        t = ds.transform
    np.testing.assert_allclose(tp.geometry.x, t.a * tp.ref_col + t.c, atol=1e-6)
