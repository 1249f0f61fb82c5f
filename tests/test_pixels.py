"""The pixel-coordinate convention, tested at the half pixel (see fotogeo/pixels.py)."""
import cv2
import numpy as np
import rasterio
from affine import Affine
from rasterio.transform import xy as rio_xy

from fotogeo.pixels import from_centre, map_to_pixel, pixel_centres, pixel_to_map, to_centre


def test_centre_of_top_left_pixel_is_half_half():
    t = Affine(5.0, 0, 1000.0, 0, -5.0, 2000.0)
    # rasterio's own centre of pixel (row 0, col 0)
    X, Y = rio_xy(t, 0, 0, offset="center")
    np.testing.assert_allclose(pixel_to_map(t, [[0.5, 0.5]]), [[X, Y]])
    np.testing.assert_allclose(pixel_to_map(t, [[0.0, 0.0]]), [[1000.0, 2000.0]])
    np.testing.assert_allclose(map_to_pixel(t, [[X, Y]]), [[0.5, 0.5]])


def test_conversions_are_inverse_and_half_pixel():
    p = np.array([[0.5, 0.5], [10.25, 3.75]])
    np.testing.assert_allclose(to_centre(p), [[0.0, 0.0], [9.75, 3.25]])
    np.testing.assert_allclose(from_centre(to_centre(p)), p)
    x, y = pixel_centres(3, 2, col_off=10, row_off=20)
    assert x[0, 0] == 10.5 and y[0, 0] == 20.5 and x[1, 2] == 12.5 and y[1, 2] == 21.5


def test_resampling_identity_and_half_pixel_shift(tmp_path):
    from fotogeo.io.warp import warp_to_grid
    rng = np.random.default_rng(0)
    data = rng.integers(0, 255, (1, 40, 50), dtype=np.uint8)
    t = Affine(2.0, 0, 100.0, 0, -2.0, 500.0)
    src = tmp_path / "src.tif"
    with rasterio.open(src, "w", driver="GTiff", width=50, height=40, count=1, dtype="uint8",
                       crs="EPSG:32635", transform=t) as ds:
        ds.write(data)
    out = tmp_path / "same.tif"
    warp_to_grid(src, out, lambda XY: map_to_pixel(t, XY), crs="EPSG:32635", transform=t, width=50,
                 height=40, resampling="nearest", nodata=0, overviews=False)
    with rasterio.open(out) as ds:
        np.testing.assert_array_equal(ds.read(), data)
    # shift the grid by half a pixel to the right: bilinear = mean of horizontal neighbours
    t2 = t * Affine.translation(0.5, 0)
    out2 = tmp_path / "half.tif"
    warp_to_grid(src, out2, lambda XY: map_to_pixel(t, XY), crs="EPSG:32635", transform=t2, width=49,
                 height=40, resampling="bilinear", nodata=0, overviews=False)
    with rasterio.open(out2) as ds:
        got = ds.read(1).astype(float)
    expect = (data[0, :, :-1].astype(float) + data[0, :, 1:]) / 2
    ok = got > 0
    assert ok.mean() > 0.95
    assert np.abs(got[ok] - expect[ok]).max() <= 1.0


def test_opencv_remap_uses_centre_convention():
    """Guards the one boundary: cv2.remap samples array index (x, y) at centre coordinates."""
    a = np.arange(20, dtype=np.float32).reshape(4, 5)
    mx = np.array([[2.0]], np.float32)
    my = np.array([[1.0]], np.float32)
    assert cv2.remap(a, mx, my, cv2.INTER_LINEAR)[0, 0] == a[1, 2]


def test_sift_offset_correction_on_a_rotated_self_match(data_dir):
    """OpenCV's SIFT keypoints sit +0.25 px off; fotogeo corrects it (tiepoints.SIFT_OFFSET).
    Under a 180° rotation a corner-convention point x maps to W − x, so matched pairs must
    satisfy x1 + x2 = W (and y1 + y2 = H) on average."""
    from fotogeo.features.match import match_descriptors
    from fotogeo.features.detect import detect
    with rasterio.open(data_dir / "ngi" / "ortho" / "ngi_rgb_byte_1.tif") as ds:
        img = ds.read(2, window=((200, 712), (100, 612))).astype(np.float32)
    rot = img[::-1, ::-1].copy()
    for det in ("sift", "surf"):
        a, b = detect(img, None, det, max_keypoints=2000), detect(rot, None, det, max_keypoints=2000)
        m = match_descriptors(a.descriptors, b.descriptors, laplacian1=a.laplacian, laplacian2=b.laplacian)
        s = a.xy[m.pairs[:, 0]] + b.xy[m.pairs[:, 1]] - [512, 512]
        good = np.hypot(*s.T) < 2
        assert good.sum() > 100, det
        np.testing.assert_allclose(np.median(s[good], axis=0), [0, 0], atol=0.06, err_msg=det)
