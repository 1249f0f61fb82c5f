"""Attitude conventions (fotogeo.geometry.attitude): gimbal and aircraft-body yaw/pitch/roll ->
camera axes in ENU, and PATB angles in a projected CRS with the meridian convergence."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pyproj import Transformer

from fotogeo.geometry.attitude import (enu_rotation_from_patb, meridian_convergence, patb_in_map,
                                       rotation_from_body_ypr, rotation_from_ypr, ypr_from_rotation)
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame

E, N, U = np.eye(3)


def axes(R):
    """(image right, image up, optical axis) of a camera (OpenCV axes) -> ENU rotation."""
    return R[:, 0], -R[:, 1], R[:, 2]


@pytest.mark.parametrize("yaw, up, right", [(0, N, E), (90, E, -N), (180, -N, -E), (-90, -E, N), (270, -E, N)])
def test_gimbal_nadir_yaw_turns_the_image_top(yaw, up, right):
    r, u, z = axes(rotation_from_ypr(yaw, -90, 0))
    np.testing.assert_allclose(z, -U, atol=1e-12)
    np.testing.assert_allclose(u, up, atol=1e-12)
    np.testing.assert_allclose(r, right, atol=1e-12)


def test_gimbal_oblique_pitch_looks_along_the_yaw():
    r, u, z = axes(rotation_from_ypr(0, -60, 0))  # 60° below the horizon, towards north
    np.testing.assert_allclose(z, [0, math.cos(math.radians(60)), -math.sin(math.radians(60))], atol=1e-12)
    assert u[2] > 0 and u[1] > 0  # the image top is above the optical axis (the horizon side)
    np.testing.assert_allclose(r, E, atol=1e-12)
    _, _, z = axes(rotation_from_ypr(90, 0, 0))  # horizontal towards east
    np.testing.assert_allclose(z, E, atol=1e-12)


def test_gimbal_roll_lowers_the_right_side():
    r, u, z = axes(rotation_from_ypr(0, 0, 20))
    np.testing.assert_allclose(z, N, atol=1e-12)  # roll turns about the optical axis only
    assert r[2] == pytest.approx(-math.sin(math.radians(20)))


def test_body_convention_pix4d_examples():
    # Pix4D: yaw 0 nadir = image top north; yaw 90 = top east; pitch 90 = looking forward (north)
    r, u, z = axes(rotation_from_body_ypr(0, 0, 0))
    np.testing.assert_allclose([z, u, r], [-U, N, E], atol=1e-12)
    _, u, z = axes(rotation_from_body_ypr(90, 0, 0))
    np.testing.assert_allclose([z, u], [-U, E], atol=1e-12)
    _, _, z = axes(rotation_from_body_ypr(0, 90, 0))
    np.testing.assert_allclose(z, N, atol=1e-12)
    _, _, z = axes(rotation_from_body_ypr(0, 0, 10))  # right wing down: the belly camera looks left
    assert z[0] == pytest.approx(-math.sin(math.radians(10)))
    _, _, z = axes(rotation_from_body_ypr(0, 10, 0))  # nose up: the belly turns forward (pitch 90: ahead)
    assert z[1] == pytest.approx(math.sin(math.radians(10)))


@pytest.mark.parametrize("yaw, pitch", [(0, -90), (37, -60), (-120, -10), (200, 15)])
def test_body_equals_gimbal_with_pitch_plus_90_without_roll(yaw, pitch):
    np.testing.assert_allclose(rotation_from_body_ypr(yaw, pitch + 90, 0), rotation_from_ypr(yaw, pitch, 0),
                               atol=1e-12)


def test_ypr_round_trip_and_gimbal_lock(rng):
    for y, p, r in zip(rng.uniform(-179, 179, 50), rng.uniform(-89, 89, 50), rng.uniform(-179, 179, 50)):
        np.testing.assert_allclose(ypr_from_rotation(rotation_from_ypr(y, p, r)), (y, p, r), atol=1e-8)
    yaw, pitch, roll = ypr_from_rotation(rotation_from_ypr(30, -90, 0))
    assert (yaw, pitch, roll) == pytest.approx((30, -90, 0), abs=1e-9)
    R = rotation_from_ypr(30, -90, 0)
    assert R.T @ R == pytest.approx(np.eye(3), abs=1e-12) and np.linalg.det(R) == pytest.approx(1.0)


def _grid_azimuth_of_true_north(lon, lat, epsg):
    t = Transformer.from_crs(4326, epsg, always_xy=True)
    x0, y0 = t.transform(lon, lat)
    x1, y1 = t.transform(lon, lat + 1e-4)  # a step north along the meridian
    return math.degrees(math.atan2(x1 - x0, y1 - y0))


@pytest.mark.parametrize("lon, lat, epsg", [(143.9, 37.5, 32654), (138.1, 37.5, 32654), (143.9, -37.5, 32754),
                                            (29.5, 60.0, 32635)])
def test_convergence_sign_far_from_the_central_meridian(lon, lat, epsg):
    g = meridian_convergence(lon, lat, f"EPSG:{epsg}")
    assert abs(g) > 1.0  # 2.9° from the central meridian
    assert -g == pytest.approx(_grid_azimuth_of_true_north(lon, lat, epsg), abs=1e-4)
    # a nadir camera with its image top to true north: its top points along the grid azimuth of north
    om, ph, ka = patb_in_map(rotation_from_ypr(0, -90, 0), lon, lat, f"EPSG:{epsg}")
    assert (om, ph) == pytest.approx((0, 0), abs=1e-9) and ka == pytest.approx(g, abs=1e-9)
    eo = ExteriorOrientation(0, 0, 0, om, ph, ka)
    up_map = -eo.rotation_cv[:, 1]
    assert math.degrees(math.atan2(up_map[0], up_map[1])) == pytest.approx(-g, abs=1e-9)


def test_patb_round_trip(rng):
    for y, p, r in zip(rng.uniform(-180, 180, 20), rng.uniform(-90, 0, 20), rng.uniform(-20, 20, 20)):
        R = rotation_from_ypr(y, p, r)
        a = patb_in_map(R, 143.9, 37.5, "EPSG:32654")
        np.testing.assert_allclose(enu_rotation_from_patb(a, 143.9, 37.5, "EPSG:32654"), R, atol=1e-12)


def _frame(angles, C=(500000.0, 4150000.0, 100.0)):
    cam = FrameCamera(1000.0, (1000.0, 800.0), (1000, 800))
    return OrientedFrame(cam, ExteriorOrientation(*C, *angles))


def test_patb_projects_the_ground_where_the_ypr_says():
    lon, lat = 141.0, 37.5  # on UTM 54N's central meridian: grid = true north
    # nadir, yaw 90: a point east of the camera is imaged above the centre (image top = east)
    f = _frame(patb_in_map(rotation_from_ypr(90, -90, 0), lon, lat, "EPSG:32654"))
    col, row = f.world_to_pixel(np.array([[500030.0, 4150000.0, 0.0]]))[0]
    assert col == pytest.approx(500.0, abs=1e-6) and row == pytest.approx(400.0 - 300.0, abs=1e-6)
    # oblique, pitch −60 at yaw 0: the ground point 100 m / tan 60° north of the camera is the image centre
    f = _frame(patb_in_map(rotation_from_ypr(0, -60, 0), lon, lat, "EPSG:32654"))
    d = 100.0 / math.tan(math.radians(60))
    np.testing.assert_allclose(f.world_to_pixel(np.array([[500000.0, 4150000.0 + d, 0.0]]))[0], [500, 400], atol=1e-6)
    # the same camera sees a point farther north above the centre
    assert f.world_to_pixel(np.array([[500000.0, 4150000.0 + 3 * d, 0.0]]))[0, 1] < 400
