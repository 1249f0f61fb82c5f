"""Frame camera, exterior orientation, DEM sampling and the NGI true geometry."""
from __future__ import annotations

import math

import numpy as np
import pytest
from affine import Affine

from fotogeo.geometry.camera import (ExteriorOrientation, FrameCamera, OrientedFrame, angles_patb, nearest_rotation,
                                     rotation_patb)
from fotogeo.io.camera import load_ngi_frame, read_exterior_orientation, read_interior_orientation
from fotogeo.geometry.dem import Dem
from fotogeo.io.raster import read_dem
from fotogeo.errors import InputError
from fotogeo.pixels import pixel_centres, to_centre

FRAMES = [("3324c_2015_1004_05_0182", "ngi_rgb_byte_1.tif"), ("3324c_2015_1004_05_0184", "ngi_rgb_byte_2.tif")]
CAM = FrameCamera(120.0, (92.16, 165.888), (640, 1152))


# -- synthetic ------------------------------------------------------------------------------

def test_rotation_is_orthonormal_and_angles_round_trip():
    R = rotation_patb(-0.35, 0.3, -179.09)
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-14)
    assert np.isclose(np.linalg.det(R), 1.0)
    assert np.allclose(angles_patb(R), (-0.35, 0.3, -179.09), atol=1e-10)
    # R = Rx(ω) Ry(φ) Rz(κ): a pure κ rotates camera x towards world y (counter-clockwise)
    assert np.allclose(rotation_patb(0, 0, 90) @ [1, 0, 0], [0, 1, 0], atol=1e-15)


def _random_rotations(rng, n):
    return [rotation_patb(*rng.uniform([-180, -90, -180], [180, 90, 180])) for _ in range(n)]


def test_nearest_rotation_keeps_rotations_and_turns_reflections_and_noise_into_the_rotation():
    rng = np.random.default_rng(7)
    for R in _random_rotations(rng, 20):
        assert np.allclose(nearest_rotation(R), R, atol=1e-12)
        # a reflection with distinct singular values: U Vᵀ has det −1; the nearest rotation is R itself
        Q = nearest_rotation(R @ np.diag([3.0, 2.0, -1.0]))
        assert np.isclose(np.linalg.det(Q), 1.0) and np.allclose(Q, R, atol=1e-12)
        noisy = R + rng.normal(0.0, 0.01, (3, 3))
        Q = nearest_rotation(noisy)
        assert np.allclose(Q @ Q.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(Q), 1.0)
        assert math.degrees(math.acos(np.clip((np.trace(Q.T @ R) - 1) / 2, -1, 1))) < 2.0
        # no rotation near Q is closer to the noisy input (Frobenius)
        for S in _random_rotations(rng, 5):
            W = nearest_rotation(np.eye(3) + 0.05 * (S - np.eye(3)))
            assert np.linalg.norm(W @ Q - noisy) >= np.linalg.norm(Q - noisy) - 1e-12
    # Wahba: directions d and their rotated, noisy images u give R from Σ u dᵀ
    R = _random_rotations(rng, 1)[0]
    d = rng.normal(size=(50, 3))
    u = d @ R.T + rng.normal(0.0, 0.01, (50, 3))
    assert np.allclose(nearest_rotation(u.T @ d), R, atol=5e-3)
    with pytest.raises(InputError, match="square"):
        nearest_rotation(np.ones((3, 2)))


def test_projection_follows_readme_formula_plus_half_pixel():
    """README: x_cam = (R·diag(1,-1,-1))ᵀ(X-C); col = fx x/z + (w-1)/2 (centre convention)."""
    eo = ExteriorOrientation(100.0, 200.0, 5000.0, 1.2, -0.8, 33.0)
    frame = OrientedFrame(CAM, eo)
    rng = np.random.default_rng(1)
    P = np.column_stack([rng.uniform(-1500, 1500, 50) + 100, rng.uniform(-2500, 2500, 50) + 200,
                         rng.uniform(0, 800, 50)])
    R = eo.rotation @ np.diag([1.0, -1.0, -1.0])
    x = (P - eo.centre) @ R
    fx, fy = 120.0 * 640 / 92.16, 120.0 * 1152 / 165.888
    col_c = fx * x[:, 0] / x[:, 2] + (640 - 1) / 2
    row_c = fy * x[:, 1] / x[:, 2] + (1152 - 1) / 2
    assert np.allclose(frame.world_to_pixel(P), np.column_stack([col_c, row_c]) + 0.5, atol=1e-9)


def test_half_pixel_convention_nadir_and_corner():
    """A vertical camera images its nadir at the image centre (w/2, h/2) = corner convention."""
    frame = OrientedFrame(CAM, ExteriorOrientation(0.0, 0.0, 1000.0, 0.0, 0.0, 0.0))
    assert np.allclose(frame.world_to_pixel([[0.0, 0.0, 0.0]]), [[320.0, 576.0]])
    # the ray through the centre of the top-left pixel (0.5, 0.5) leaves the optical axis by
    # (319.5 / fx, 575.5 / fy) in normalised image coordinates; with PATB axes (y up, z back)
    # and no rotation, image left/top is world -X/+Y.
    g = frame.pixel_to_world_at([[0.5, 0.5]], 0.0)[0]
    assert np.allclose(g[:2], [-1000 * 319.5 / CAM.fx, 1000 * 575.5 / CAM.fy], atol=1e-9)


def test_pixel_world_round_trip_on_plane_and_behind_camera():
    frame = OrientedFrame(CAM, ExteriorOrientation(10.0, 20.0, 3000.0, 2.0, -3.0, 45.0))
    xy = np.column_stack(pixel_centres(640, 1152)).reshape(2, -1).T[::97]
    P = frame.pixel_to_world_at(xy, 123.0)
    assert np.allclose(P[:, 2], 123.0)
    assert np.abs(frame.world_to_pixel(P) - xy).max() < 1e-6
    assert np.isnan(frame.world_to_pixel([[10.0, 20.0, 4000.0]])).all()  # above the camera
    assert np.abs(frame.pixel_to_world(xy, 123.0) - P).max() < 1e-9  # constant-height "DEM"


def test_dem_bilinear_is_exact_on_a_plane_with_gradient_and_nan_outside():
    t = Affine(10.0, 0.0, 1000.0, 0.0, -10.0, 5000.0)
    x, y = pixel_centres(30, 20)
    X, Y = t.a * x + t.c, t.e * y + t.f
    dem = Dem(3.0 + 0.2 * X - 0.1 * Y, t)
    rng = np.random.default_rng(2)
    XY = np.column_stack([rng.uniform(1005, 1295, 200), rng.uniform(4805, 4995, 200)])
    h, gx, gy = dem.heights_and_gradient(XY)
    assert np.allclose(h, 3.0 + 0.2 * XY[:, 0] - 0.1 * XY[:, 1], atol=1e-9)
    assert np.allclose(gx, 0.2) and np.allclose(gy, -0.1)
    assert np.isnan(dem.heights([[999.0, 4900.0], [1100.0, 5001.0]])).all()
    data = dem.data.copy()
    data[5, 5] = np.nan
    holed = Dem(data, t)
    assert np.isnan(holed.heights([[1000 + 55.0, 5000 - 55.0]]))[0]


def test_ray_dem_intersection_on_synthetic_relief():
    t = Affine(20.0, 0.0, -4000.0, 0.0, -20.0, 4000.0)  # covers the footprint with a margin
    x, y = pixel_centres(400, 400)
    X, Y = t.a * x + t.c, t.e * y + t.f
    dem = Dem(400 + 250 * np.sin(X / 400.0) * np.cos(Y / 300.0), t)
    frame = OrientedFrame(CAM, ExteriorOrientation(0.0, 0.0, 4000.0, 3.0, -2.0, 10.0))
    xy = np.random.default_rng(3).uniform([0, 0], [640, 1152], (5000, 2))
    P = frame.pixel_to_world(xy, dem)
    assert np.isfinite(P).all()
    assert np.abs(P[:, 2] - dem.heights(P[:, :2])).max() < 1e-5
    assert np.abs(frame.world_to_pixel(P) - xy).max() < 1e-6
    far = OrientedFrame(CAM, ExteriorOrientation(50000.0, 0.0, 4000.0, 0.0, 0.0, 0.0))
    assert np.isnan(far.pixel_to_world(xy[:10], dem)).all()  # rays that never meet the DEM


def test_dem_open_errors(tmp_path):
    from fotogeo.errors import RasterError

    with pytest.raises(RasterError, match="cannot read DEM"):
        read_dem(tmp_path / "missing.tif")


def test_readers(tmp_path):
    (tmp_path / "io.yaml").write_text("Cam A:\n  type: pinhole\n  im_size: [100, 200]\n  focal_len: 50.0\n"
                                      "  sensor_size: [10.0, 20.0]\n  cx: 0.01\n  cy: -0.02  # comment\n")
    cam = read_interior_orientation(tmp_path / "io.yaml")["Cam A"]
    assert cam.image_size == (100, 200) and cam.focal_length == 50.0
    assert np.allclose(cam.principal_point, (50 + 2.0, 100 - 4.0))
    assert np.isclose(cam.fx, 500.0) and np.isclose(cam.fy, 500.0)
    (tmp_path / "eo.txt").write_text("# name X Y Z o p k\nimg1 1 2 3 0.1 0.2 0.3\n")
    assert read_exterior_orientation(tmp_path / "eo.txt")["img1"] == ExteriorOrientation(1, 2, 3, 0.1, 0.2, 0.3)
    (tmp_path / "bad.txt").write_text("img1 1 2 3 0.1 0.2\n")
    with pytest.raises(InputError, match="expected 'name X Y Z omega phi kappa'"):
        read_exterior_orientation(tmp_path / "bad.txt")


# -- NGI truth --------------------------------------------------------------------------------

def test_load_ngi_frame(data_dir):
    f = load_ngi_frame(data_dir / "ngi", "3324c_2015_1004_05_0182")
    assert f.name == "3324c_2015_1004_05_0182_RGB"
    assert f.camera.image_size == (640, 1152) and math.isclose(f.eo.kappa, -179.086702)
    assert load_ngi_frame(data_dir / "ngi", "3324c_2015_1004_05_0182_RGB.tif") == f
    with pytest.raises(InputError, match="known frames"):
        load_ngi_frame(data_dir / "ngi", "nope")


def test_ngi_round_trip_with_dem(data_dir):
    f = load_ngi_frame(data_dir / "ngi", "3324c_2015_1004_05_0182")
    dem = read_dem(data_dir / "ngi" / "dem.tif")
    xy = np.random.default_rng(4).uniform([0, 0], [640, 1152], (20000, 2))
    P = f.pixel_to_world(xy, dem)
    assert np.isfinite(P).all()
    assert np.abs(f.world_to_pixel(P) - xy).max() < 1e-6
    assert np.abs(P[:, 2] - dem.heights(P[:, :2])).max() < 1e-5
    assert np.abs(f.pixel_to_world(f.world_to_pixel(P), dem) - P).max() < 1e-4  # metres


def _ortho_shifts(frame, dem, ortho_path, frame_path, pixel_offset=(0.0, 0.0), win=64):
    """Resample the frame onto the orthophoto grid through ``frame`` and the DEM; return the
    local shifts (ortho px) between orthophoto and resampled frame by windowed phase correlation."""
    cv2 = pytest.importorskip("cv2")
    import rasterio

    with rasterio.open(ortho_path) as o:
        O, t = o.read().astype(np.float32), o.transform
    valid, O = (O > 0).all(axis=0), O.mean(axis=0)
    with rasterio.open(frame_path) as fr:
        F = fr.read().astype(np.float32).mean(axis=0)
    x, y = pixel_centres(O.shape[1], O.shape[0])
    XY = np.column_stack([(t.a * x + t.b * y + t.c).ravel(), (t.d * x + t.e * y + t.f).ravel()])
    px = frame.world_to_pixel(np.column_stack([XY, dem.heights(XY)])) + pixel_offset
    m = to_centre(px).astype(np.float32).reshape(O.shape + (2,))
    R = cv2.remap(F, m[..., 0], m[..., 1], cv2.INTER_LINEAR, borderValue=float("nan"))
    ok = valid & np.isfinite(R)
    hann = cv2.createHanningWindow((win, win), cv2.CV_32F)
    shifts = []
    for r0 in range(0, O.shape[0] - win, win // 2):
        for c0 in range(0, O.shape[1] - win, win // 2):
            if ok[r0:r0 + win, c0:c0 + win].all():
                a, b = O[r0:r0 + win, c0:c0 + win], R[r0:r0 + win, c0:c0 + win]
                (dx, dy), resp = cv2.phaseCorrelate(a - a.mean(), b - b.mean(), hann)
                if resp > 0.2:
                    shifts.append((dx, dy))
    return np.array(shifts)


@pytest.mark.data
@pytest.mark.parametrize("name,ortho", FRAMES)
def test_true_geometry_agrees_with_orthophoto(data_dir, name, ortho):
    """README: frame resampled with the true geometry matches its orthophoto, 0.8 px RMSE, median 0.46."""
    ngi = data_dir / "ngi"
    frame, dem = load_ngi_frame(ngi, name), read_dem(ngi / "dem.tif")
    s = _ortho_shifts(frame, dem, ngi / "ortho" / ortho, ngi / "frames" / f"{name}_RGB.tif")
    d = np.hypot(*s.T)
    assert len(s) > 500
    assert np.sqrt(np.mean(d ** 2)) < 1.0 and np.median(d) < 0.6
    assert np.abs(s.mean(axis=0)).max() < 0.25  # no systematic (e.g. half-pixel) offset


@pytest.mark.data
def test_orthophoto_check_detects_errors(data_dir):
    """The check above can fail: a 10 m shifted camera, or a half-pixel convention slip."""
    ngi = data_dir / "ngi"
    name, ortho = FRAMES[0]
    frame, dem = load_ngi_frame(ngi, name), read_dem(ngi / "dem.tif")
    e = frame.eo
    moved = OrientedFrame(frame.camera, ExteriorOrientation(e.X + 10, e.Y, e.Z, e.omega, e.phi, e.kappa))
    s = _ortho_shifts(moved, dem, ngi / "ortho" / ortho, ngi / "frames" / f"{name}_RGB.tif")
    assert np.median(np.hypot(*s.T)) > 1.5
    s = _ortho_shifts(frame, dem, ngi / "ortho" / ortho, ngi / "frames" / f"{name}_RGB.tif",
                      pixel_offset=(-0.5, -0.5))  # as if the README formula were used without +0.5
    assert np.hypot(*s.mean(axis=0)) > 0.4
