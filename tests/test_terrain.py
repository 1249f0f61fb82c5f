"""Terrain-aware registration of the real NGI frames: tie points + DEM → 3-D model → orthophoto."""
import json

import cv2
import numpy as np
import pytest
import rasterio
from pyproj import CRS

from fotogeo.io.camera import load_ngi_frame
from fotogeo.io.raster import read_dem
from fotogeo.errors import InputError, RasterError
from fotogeo.crs import transform_points
from fotogeo.pixels import pixel_centres, pixel_to_map, to_centre
from fotogeo.tools.register.tool import register
from auto_choice import assert_auto_choice
from ngi_truth import truth_points

F182, F184 = "3324c_2015_1004_05_0182", "3324c_2015_1004_05_0184"


def dense_truth(ngi, name, step=10):
    """Frame pixels, their true ground points (X, Y in EPSG:32735, Z)."""
    return truth_points(ngi, name, step)


def dense_rmse(model, px, truth, crs):
    """RMSE on the ground of ``model`` (ground in ``crs``, the output's: by default the reference's
    CRS, no longer UTM 35S) against the truth (EPSG:32735)."""
    XY = transform_points(CRS.from_epsg(32735), crs, truth[:, :2])
    on_ground = model.inverse(px, heights=truth[:, 2])[:, :2]
    return float(np.sqrt(np.mean(np.sum((on_ground - XY) ** 2, axis=1))))


@pytest.mark.parametrize("name,ortho,model", [(F182, "ngi_rgb_byte_1.tif", "auto"), (F184, "ngi_rgb_byte_2.tif", "dlt")])
def test_terrain_registration_within_one_ortho_pixel(data_dir, tmp_path, name, ortho, model):
    ngi = data_dir / "ngi"
    out = tmp_path / "ortho.tif"
    r = register(ngi / "ortho" / ortho, ngi / "frames" / f"{name}_RGB.tif", out, dem=ngi / "dem.tif",
                 model=model, camera=ngi / "interior_orientation.yaml", seed=0)
    px, truth = dense_truth(ngi, name)
    rmse = dense_rmse(r.model, px, truth, r.crs)
    assert rmse < 5.0, rmse  # one 5 m orthophoto pixel; the best homography is ~45 m here
    rep = json.loads(out.with_suffix(".json").read_text())
    if model == "auto":  # simplest candidate within 5 % of the best check RMSE
        assert_auto_choice(rep["terrain"], rep["check"]["n"])
    else:  # the model asked for, and no other candidate
        assert rep["terrain"]["chosen"] == model and [c["model"] for c in rep["terrain"]["candidates"]] == [model]
    assert rep["terrain"]["check_rmse_target_px"] < 2.0 and rep["check"]["n"] > 100
    with rasterio.open(out) as ds, rasterio.open(ngi / "ortho" / ortho) as ref:
        assert CRS.from_wkt(ds.crs.to_wkt()) == CRS.from_wkt(ref.crs.to_wkt())  # the reference's (tmerc lon_0=25)
    if name == F182:
        _compare_with_true_orthophoto(ngi, name, out)


def _compare_with_true_orthophoto(ngi, name, out):
    """The output against an orthophoto rendered from the true geometry on the same grid:
    local shifts by phase correlation in 64x64 windows must be below 1 pixel RMSE."""
    dem = read_dem(ngi / "dem.tif")
    frame = load_ngi_frame(ngi, name)
    ngi_crs = CRS.from_wkt(dem.crs.to_wkt())
    with rasterio.open(out) as ds:
        ours = ds.read().astype(np.float32).mean(axis=0)
        valid = ds.read_masks(1) > 0
        t, (h, w), out_crs = ds.transform, ds.shape, CRS.from_wkt(ds.crs.to_wkt())
    x, y = pixel_centres(w, h)
    XY = transform_points(out_crs, ngi_crs, pixel_to_map(t, np.column_stack([x.ravel(), y.ravel()])))
    src = frame.world_to_pixel(np.column_stack([XY, dem.heights(XY)]))
    src = to_centre(np.where(np.isfinite(src), src, -1e6))
    with rasterio.open(ngi / "frames" / f"{name}_RGB.tif") as fs:
        fimg = fs.read().astype(np.float32).mean(axis=0)
    truth = cv2.remap(fimg, src[:, 0].reshape(h, w).astype(np.float32), src[:, 1].reshape(h, w).astype(np.float32),
                      cv2.INTER_LINEAR, borderValue=0)
    shifts = []
    win = cv2.createHanningWindow((64, 64), cv2.CV_32F)
    for r0 in range(0, h - 64, 64):
        for c0 in range(0, w - 64, 64):
            a, b = ours[r0:r0 + 64, c0:c0 + 64], truth[r0:r0 + 64, c0:c0 + 64]
            if not valid[r0:r0 + 64, c0:c0 + 64].all() or (b == 0).any() or a.std() < 5:
                continue
            (dx, dy), resp = cv2.phaseCorrelate(a, b, win)
            if resp > 0.2:
                shifts.append((dx, dy))
    s = np.array(shifts)
    assert len(s) > 50
    rms = float(np.sqrt(np.mean(np.sum(s ** 2, axis=1))))
    assert rms < 1.0, (rms, len(s))


def test_sentinel2_reference_with_dem(data_dir, tmp_path):
    ngi = data_dir / "ngi"
    r = register(ngi / "sentinel2_b432_byte.tif", ngi / "frames" / f"{F182}_RGB.tif", tmp_path / "s2.tif",
                 dem=ngi / "dem.tif", model="dlt", seed=0)
    px, truth = dense_truth(ngi, F182)
    # measured 7.1 m (0182, DLT); 10.2 m with an earlier SURF: 1.2 Sentinel-2 pixels is the bound
    assert dense_rmse(r.model, px, truth, r.crs) < 12.0
    assert r.report["output_grid"]["resolution"] == pytest.approx(10.0, rel=0.02)


def _write_dem(path, data, transform, crs):
    with rasterio.open(path, "w", driver="GTiff", width=data.shape[1], height=data.shape[0], count=1,
                       dtype="float32", transform=transform, crs=crs, nodata=-9999) as ds:
        ds.write(data.astype(np.float32), 1)


def test_dem_bad_inputs_and_holes(data_dir, tmp_path):
    ngi = data_dir / "ngi"
    ref, tgt = ngi / "ortho" / "ngi_rgb_byte_1.tif", ngi / "frames" / f"{F182}_RGB.tif"
    with rasterio.open(ngi / "dem.tif") as ds:
        z, t, crs = ds.read(1, masked=True).filled(-9999), ds.transform, ds.crs
    # a DEM without CRS
    nocrs = tmp_path / "nocrs.tif"
    _write_dem(nocrs, z, t, None)
    with pytest.raises((InputError, RasterError), match="CRS"):
        register(ref, tgt, tmp_path / "a.tif", dem=nocrs, model="dlt")
    # a DEM far from the images
    far = tmp_path / "far.tif"
    _write_dem(far, z, t * t.translation(-5000, -5000), crs)
    with pytest.raises(InputError, match="heights for only"):
        register(ref, tgt, tmp_path / "b.tif", dem=far, model="dlt")
    assert not list(tmp_path.glob("a.*")) and not list(tmp_path.glob("b.*"))
    # a nodata hole under part of the tie points: those are skipped and counted
    holed = z.copy()
    hr, hc = holed.shape[0] // 2, holed.shape[1] // 2
    holed[hr - 15:hr + 15, hc - 15:hc + 15] = -9999
    hole = tmp_path / "hole.tif"
    _write_dem(hole, holed, t, crs)
    r = register(ref, tgt, tmp_path / "c.tif", dem=hole, model="dlt", seed=0)
    assert r.report["terrain"]["tie_points_without_height"] > 0
    with pytest.raises(InputError, match="terrain model"):
        register(ref, tgt, tmp_path / "d.tif", model="dlt")
