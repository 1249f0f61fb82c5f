"""The GCP picker's live preview (fotogeo.tools.gcp.preview.preview_warp): an affine case against the exact
inverse mapping, transparency where the image does not reach, "needs N more", and the NGI frame warped with
DLT on the DEM against its orthophoto (the right GCPs agree with it, shifted GCPs do not)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
import rasterio
from test_gcp_fit import FRAME, MAP_CRS, ngi, pick, truth  # noqa: F401 - fixtures

from fotogeo.tools.gcp.preview import output_size, preview_warp


def affine_case(tmp_path):
    """A 200 x 100 px random texture and 6 GCPs of x = 1000 + 2 col, y = 5000 − 2 row (EPSG:32735)."""
    rng = np.random.default_rng(3)
    pixels = cv2.GaussianBlur(rng.integers(0, 256, (100, 200)).astype(np.uint8), (5, 5), 1.5)
    path = tmp_path / "texture.tif"
    with rasterio.open(path, "w", driver="GTiff", width=200, height=100, count=1, dtype="uint8") as ds:
        ds.write(pixels, 1)
    gcps = [{"id": str(k), "col": c, "row": r, "x": 1000 + 2 * c, "y": 5000 - 2 * r, "z": None, "role": "control"}
            for k, (c, r) in enumerate([(10, 10), (190, 12), (20, 90), (180, 85), (100, 50), (60, 30)])]
    return path, pixels, gcps


def read_rgba(result):
    return np.fromfile(result["output"], np.uint8).reshape(result["height"], result["width"], 4)


def test_affine_preview_is_the_exact_inverse_mapping(tmp_path):
    path, pixels, gcps = affine_case(tmp_path)
    out = tmp_path / "preview.rgba"
    # the canvas: x 1000..1400, y 4800..5000 (the whole image) at 1 map unit per output pixel
    r = preview_warp(gcps, "affine", crs=MAP_CRS, image=str(path), extent=[1000, 4800, 1400, 5000],
                     extent_crs=MAP_CRS, size=[400, 200], output=str(out))
    assert r["ok"] and (r["width"], r["height"]) == (400, 200) and r["model"] == "affine"
    rgba = read_rgba(r)
    # output pixel (i, j) has its centre at x = 1000 + j + ½, y = 5000 − i − ½: col = (j + ½) / 2, row = (i + ½) / 2
    j, i = np.meshgrid(np.arange(400, dtype=np.float32), np.arange(200, dtype=np.float32))
    expected = cv2.remap(pixels, (j + 0.5) / 2 - 0.5, (i + 0.5) / 2 - 0.5, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)
    inner = (slice(2, -2), slice(2, -2))
    assert np.abs(rgba[..., 0][inner].astype(int) - expected[inner]).max() <= 1
    assert (rgba[..., 0] == rgba[..., 2]).all() and (rgba[..., 3][inner] == 255).all()


def test_preview_is_transparent_beyond_the_image_and_waits_for_enough_points(tmp_path):
    path, _, gcps = affine_case(tmp_path)
    out = tmp_path / "preview.rgba"
    # a canvas twice as wide, the image on its left half only
    r = preview_warp(gcps, "affine", crs=MAP_CRS, image=str(path), extent=[1000, 4800, 1800, 5000],
                     extent_crs=MAP_CRS, size=[1600, 400], output=str(out))
    rgba = read_rgba(r)
    assert (r["width"], r["height"]) == (1024, 256)  # the long side bounded, the shape kept
    assert (rgba[:, 520:, 3] == 0).all() and (rgba[5:-5, 5:500, 3] == 255).all()
    assert r["covered"] == pytest.approx(0.5, abs=0.01)
    few = preview_warp(gcps[:2], "affine", crs=MAP_CRS, image=str(path), extent=[1000, 4800, 1800, 5000],
                       extent_crs=MAP_CRS, size=[100, 100], output=str(tmp_path / "none.rgba"))
    assert not few["ok"] and "1 more" in few["message"] and not (tmp_path / "none.rgba").exists()


def test_output_size_keeps_the_canvas_shape():
    assert output_size(2048, 1024) == (1024, 512) and output_size(640, 480) == (640, 480)


def correlation(a, b, valid):
    a, b = a[valid].astype(float), b[valid].astype(float)
    return float(np.corrcoef(a, b)[0, 1])


def test_ngi_frame_preview_agrees_with_its_orthophoto(ngi, truth, tmp_path):  # noqa: F811
    from fotogeo.crs import parse_crs
    from fotogeo.io.raster import read_decimated, open_raster
    ortho = open_raster(ngi / "ortho" / "ngi_rgb_byte_1.tif", "orthophoto")
    bands, mask, _ = read_decimated(ortho, ortho.width * ortho.height)
    grey = bands[:3].mean(axis=0)
    # a window of the orthophoto inside the frame's footprint, in the orthophoto's own CRS (the canvas CRS here)
    t = ortho.transform
    c0, r0, n = ortho.width // 2 - 200, ortho.height // 2 - 150, 300
    extent = [t.c + c0 * t.a, t.f + (r0 + n) * t.e, t.c + (c0 + n) * t.a, t.f + r0 * t.e]
    window = grey[r0:r0 + n, c0:c0 + n]
    kwargs = dict(crs=MAP_CRS, image=str(ngi / "frames" / f"{FRAME}_RGB.tif"), extent=extent,
                  extent_crs=parse_crs(ortho.crs, "ortho").to_wkt(), size=[n, n], dem=str(ngi / "dem.tif"))
    gcps = pick(truth, 20, 0, noise_px=0.3)
    right = preview_warp(gcps, "dlt", output=str(tmp_path / "right.rgba"), **kwargs)
    shifted = [{**g, "x": g["x"] + 60.0} for g in gcps]  # 12 orthophoto pixels east
    wrong = preview_warp(shifted, "dlt", output=str(tmp_path / "wrong.rgba"), **kwargs)
    a, b = read_rgba(right), read_rgba(wrong)
    valid = (a[..., 3] > 0) & (b[..., 3] > 0) & mask[r0:r0 + n, c0:c0 + n]
    assert valid.mean() > 0.9
    good, bad = correlation(a[..., :3].mean(axis=2), window, valid), correlation(b[..., :3].mean(axis=2), window, valid)
    assert good > 0.9 and bad < good - 0.2, (good, bad)
