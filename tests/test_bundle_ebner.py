"""Ebner's (1976) additional parameters in the bundle adjustment: model, Jacobians, self-calibration."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
from fotogeo.orientation import bundle_jacobian as bj
from fotogeo.orientation.block_simulation import simulate_block, true_interior
from fotogeo.orientation.bundle import BundleOptions, adjust_block, expand_self_calibration

B_TRUE = np.zeros(12)
B_TRUE[[0, 2, 6, 10]] = [1.5, 1.0, -1.0, 0.8]  # affinity, a quadratic, two higher terms (px at the edge)
EBNER = tuple(f"b{i}" for i in range(1, 13))


def _setup():
    rng = np.random.default_rng(11)
    cam = FrameCamera(50.0, (20.0, 30.0), (2000, 3000), (1003.0, 1496.0))
    b = rng.normal(0, 1.0, 12)
    interior = true_interior(cam, (-0.05, 0.01, -0.002, 3e-4, -2e-4), b)
    eos = [ExteriorOrientation(100.0 * j, 20.0 * j, 1000.0, *rng.normal(0, 3, 3)) for j in range(3)]
    R, C = np.stack([e.rotation_cv for e in eos]), np.array([e.centre for e in eos])
    X = np.column_stack([rng.uniform(-150, 350, 12), rng.uniform(-200, 250, 12), rng.uniform(-40, 60, 12)])
    return cam, interior, R, C, X, np.repeat(np.arange(3), 12), np.tile(np.arange(12), 3)


def test_jacobians_with_ebner_terms_match_central_differences():
    cam, interior, R, C, X, frame, point = _setup()
    scale = bj.pixel_scale(cam)
    px, J_eo, J_p, J_int, _ = bj.project_with_jacobians(R, C, X, frame, point, interior, scale)
    assert np.allclose(px, bj.project(R, C, X, frame, point, interior, scale))
    assert J_int.shape[2] == len(bj.INTERIOR_NAMES) == 20
    for k in range(len(bj.INTERIOR_NAMES)):
        step = 1e-7 if 3 <= k < 8 else 1e-5
        d = np.zeros(len(interior))
        d[k] = step
        num = (bj.project(R, C, X, frame, point, interior + d, scale)
               - bj.project(R, C, X, frame, point, interior - d, scale)) / (2 * step)
        assert np.allclose(J_int[:, :, k], num, rtol=1e-5, atol=1e-4), bj.INTERIOR_NAMES[k]
    h = 1e-6
    for k in range(3):  # the chain E = I + dΔ/d(x, y) on the point and orientation derivatives
        d = np.zeros(3)
        d[k] = h
        num = (bj.project(R, C, X + d, frame, point, interior, scale)
               - bj.project(R, C, X - d, frame, point, interior, scale)) / (2 * h)
        assert np.allclose(J_p[:, :, k], num, rtol=1e-5, atol=1e-6)
        dr = np.zeros((3, 3))
        dr[:, k] = h
        num = (bj.project(R @ bj.rodrigues(dr), C, X, frame, point, interior, scale)
               - bj.project(R @ bj.rodrigues(-dr), C, X, frame, point, interior, scale)) / (2 * h)
        assert np.allclose(J_eo[:, :, 3 + k], num, rtol=1e-5, atol=1e-3)


def test_undistort_rays_removes_the_ebner_corrections():
    cam, interior, R, C, X, frame, point = _setup()
    scale = bj.pixel_scale(cam)
    px = bj.project(R, C, X, frame, point, interior, scale)
    c = bj.camera_coordinates(R, C, X, frame, point)
    rays = bj.undistort_rays(px, interior, scale)
    assert np.allclose(rays[:, :2], c[:, :2] / c[:, 2:], atol=1e-9)
    plain = bj.project(R, C, X, frame, point, interior[:8], scale)  # 8 values: no additional parameters
    assert 0.5 < np.abs(px - plain).max() < 10


def test_ebner_expands_to_its_twelve_parameters_in_order():
    assert expand_self_calibration(("ebner", "f")) == ("f",) + EBNER
    assert expand_self_calibration(("b3", "k1")) == ("k1", "b3")


@pytest.fixture(scope="module")
def systematic():
    sb = simulate_block(seed=0, true_additional=tuple(B_TRUE), blunder_fraction=0.0)
    return sb, adjust_block(sb.block), adjust_block(sb.block, BundleOptions(self_calibration=("ebner",)))


def test_block_with_systematic_image_errors_recovers_ebner_parameters(systematic):
    sb, plain, r = systematic
    kept = sorted(r.interior_sigma, key=EBNER.index)
    assert kept == ["b1", "b3", "b7", "b11"]  # exactly the planted error patterns
    for name in kept:
        true = B_TRUE[EBNER.index(name)]
        assert abs(r.distortion[name] - true) < 4 * r.interior_sigma[name] + 0.05, name
    fixed = {f["parameter"]: f for f in r.fixed}
    assert sorted(fixed, key=EBNER.index) == ["b2", "b4", "b5", "b6", "b8", "b9", "b10", "b12"]
    assert all(f["t"] < 3.0 and "not significant" in f["reason"] for f in fixed.values())
    assert all(r.distortion[name] == 0.0 for name in fixed)
    check = r.stats["check"]
    assert check["rmse_planimetric_m"] < 0.5 * sb.gsd and check["rmse_z_m"] < 1.5 * sb.gsd
    # without the additional parameters the same block is off by several GSD
    assert plain.stats["check"]["rmse_planimetric_m"] > 2 * sb.gsd and plain.stats["check"]["rmse_z_m"] > 5 * sb.gsd


def test_a_camera_without_systematic_errors_keeps_no_ebner_parameter():
    sb = simulate_block(seed=1, strips=2, frames_per_strip=6, blunder_fraction=0.0)
    r = adjust_block(sb.block, BundleOptions(self_calibration=("ebner",)))
    assert not r.interior_sigma and {f["parameter"] for f in r.fixed} == set(EBNER)
    assert not any(k.startswith("b") for k in r.distortion)  # all held at 0: not reported
    plain = adjust_block(sb.block)
    assert np.nanmedian(np.abs(r.point_xyz - plain.point_xyz)) < 0.05 * sb.gsd  # the same solution, up to the path
    for axis in ("rmse_planimetric_m", "rmse_z_m"):
        assert abs(r.stats["check"][axis] - plain.stats["check"][axis]) < 0.1 * sb.gsd
    kept = adjust_block(sb.block, BundleOptions(self_calibration=("ebner",), significance=0.0))
    assert len(kept.interior_sigma) == 12  # the rule switched off: all twelve estimated


def test_ebner_parameters_a_single_model_cannot_recover_are_held_by_the_correlation_rule():
    """Two frames: the points cover only the overlap, and some of the twelve patterns are
    indistinguishable there from each other or from the orientation (ϱ > 0.999)."""
    for seed in (1, 5):
        sb = simulate_block(seed=seed, strips=1, frames_per_strip=2, n_control=5, blunder_fraction=0.0)
        r = adjust_block(sb.block, BundleOptions(self_calibration=("ebner",)))
        by_correlation = [f for f in r.fixed if "multiple_correlation" in f]
        assert by_correlation and all(f["multiple_correlation"] > 0.999 for f in by_correlation)
        assert all("cannot be told" in f["reason"] and f["parameter"] in EBNER for f in by_correlation)
        assert r.stats["image_rms_px"] < 0.3
