"""Brown's distortion, one model for the bundle, the orthophoto and the SfM lens check (fotogeo.geometry.brown).

The forward model is checked against OpenCV's ``projectPoints`` (the convention fotogeo follows: normalised
coordinates, y down, ``distCoeffs`` ``(k1, k2, p1, p2, k3)``), its inverse against the forward model, and every place
that distorts a ray is checked to give the same pixels as the one model."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from fotogeo.geometry import brown
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
from fotogeo.io.sfm_lens import border_displacement
from fotogeo.orientation import bundle_jacobian as bj
from fotogeo.orientation.adjusted_frame import AdjustedFrame

LENSES = [(-0.06, 0.02, -0.003, 4e-4, -3e-4), (0.08, -0.01, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1e-3, 0.0),
          (0.0, 0.0, 0.0, 0.0, -2e-3)]


def _opencv(x, y, coeffs):
    k1, k2, k3, p1, p2 = coeffs
    pts = np.column_stack([x, y, np.ones_like(x)])
    img, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), np.eye(3), np.array([k1, k2, p1, p2, k3]))
    return img[:, 0, 0], img[:, 0, 1]


@pytest.mark.parametrize("coeffs", LENSES)
def test_the_forward_model_is_opencvs(coeffs):
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-0.8, 0.8, 500), rng.uniform(-0.6, 0.6, 500)
    _, _, xd, yd = brown.distort(x, y, coeffs)
    ox, oy = _opencv(x, y, coeffs)
    assert np.abs(xd - ox).max() < 1e-12 and np.abs(yd - oy).max() < 1e-12
    out = (np.empty_like(x), np.empty_like(y))  # in place: the same numbers
    brown.distort(x, y, coeffs, out=out)
    assert np.array_equal(out[0], xd) and np.array_equal(out[1], yd)


@pytest.mark.parametrize("coeffs", LENSES)
def test_undistort_inverts_distort(coeffs):
    rng = np.random.default_rng(2)
    x, y = rng.uniform(-0.7, 0.7, 500), rng.uniform(-0.5, 0.5, 500)
    _, _, xd, yd = brown.distort(x, y, coeffs)
    ux, uy = brown.undistort(xd, yd, coeffs, iterations=20)
    assert np.abs(ux - x).max() < 1e-9 and np.abs(uy - y).max() < 1e-9


def test_the_coefficients_of_a_mapping_or_a_sequence():
    assert brown.coefficients({"k1": -0.1, "p2": 2e-4, "k3": None}) == (-0.1, 0.0, 0.0, 0.0, 2e-4)
    assert brown.coefficients([1, 2, 3, 4, 5]) == (1.0, 2.0, 3.0, 4.0, 5.0)


@pytest.mark.parametrize("coeffs", LENSES)
def test_the_bundle_the_orthophoto_and_the_lens_check_distort_alike(coeffs):
    """The bundle's projection, the orthophoto's grid and the SfM lens check's border displacement are the one
    model: the bundle's and the grid's pixels agree to rounding with OpenCV's, the border displacement with the
    displacement OpenCV gives at the same border points."""
    cam = FrameCamera(8.8, (13.2, 8.8), (5472, 3648), (2740.5, 1820.25))
    dist = dict(zip(brown.TERMS, coeffs))
    frame = AdjustedFrame(cam, ExteriorOrientation(10.0, 20.0, 100.0, 2.0, -3.0, 40.0), dist)
    X, Y = np.linspace(-40, 60, 40), np.linspace(-30, 70, 30)
    Z = np.random.default_rng(3).normal(0, 2, (30, 40))
    grid = frame.forward_grid(X, Y, Z)
    XX, YY = np.meshgrid(X, Y)
    c = frame.frame.world_to_camera(np.column_stack([XX.ravel(), YY.ravel(), Z.ravel()]))
    fx, fy = bj.pixel_scale(cam)[:2] * cam.focal_length
    ox, oy = _opencv(c[:, 0] / c[:, 2], c[:, 1] / c[:, 2], coeffs)
    ox, oy = fx * ox + cam.principal_point[0], fy * oy + cam.principal_point[1]
    bundle = bj.project_camera(c, frame.interior, frame.scale)
    for px in (bundle, np.column_stack([grid[0].ravel(), grid[1].ravel()])):
        assert np.abs(px[:, 0] - ox).max() < 1e-8 and np.abs(px[:, 1] - oy).max() < 1e-8
    w, h = cam.image_size
    t = np.linspace(0.0, 1.0, 33)
    u = np.concatenate([t * w, t * w, np.zeros_like(t), np.full_like(t, w)])
    v = np.concatenate([np.zeros_like(t), np.full_like(t, h), t * h, t * h])
    x, y = (u - cam.principal_point[0]) / fx, (v - cam.principal_point[1]) / fy
    ox, oy = _opencv(x, y, coeffs)
    expected = np.max(np.hypot(fx * (ox - x), fy * (oy - y)))
    assert border_displacement(w, h, fx, fy, cam.principal_point, dist) == pytest.approx(expected, rel=1e-9)


def test_guided_matching_and_ideal_pixels_read_the_terms_as_brown_does():
    """The two readers of a camera's distortion in triangulate (guided matching, ideal pixels) had their own
    copies of the term order; they now go through :func:`brown.coefficients`: a dict with a None term reads 0."""
    from fotogeo.geometry.camera import FrameCamera
    from fotogeo.tools.triangulate.guided import _distortion_terms
    from fotogeo.tools.triangulate.pairs import ideal_pixels
    terms = {"k1": -0.05, "k2": None, "p2": 1e-4}
    assert _distortion_terms(terms) == (-0.05, 0.0, 0.0, 0.0, 1e-4)
    assert _distortion_terms(None) == () and _distortion_terms([0.1, 0, 0, 0, 0, 9.0]) == (0.1, 0.0, 0.0, 0.0, 0.0)
    camera = FrameCamera(focal_length=20.0, sensor_size=(10.0, 8.0), image_size=(1000, 800))
    ideal = ideal_pixels(camera, terms)
    assert ideal is not None and np.isfinite(ideal(np.array([[100.0, 200.0]]))).all()
    assert ideal_pixels(camera, {"k1": None}) is None
