"""Bundle block adjustment (fotogeo.orientation.bundle*) on synthetic blocks with known truth."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fotogeo.errors import InputError, ModelError
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
from fotogeo.orientation import bundle_jacobian as bj
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block

DISTORTION = (-0.05, 0.0, 0.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def standard():
    sb = simulate_block(seed=0)
    return sb, adjust_block(sb.block)


def _eo_array(eos):
    return np.array([[e.X, e.Y, e.Z, e.omega, e.phi, e.kappa] for e in eos])


def test_jacobians_match_central_differences():
    rng = np.random.default_rng(5)
    cam = FrameCamera(50.0, (20.0, 30.0), (2000, 3000), (1003.0, 1496.0))
    interior = np.array([cam.focal_length, *cam.principal_point, -0.05, 0.01, -0.002, 3e-4, -2e-4])
    scale = bj.pixel_scale(cam)
    eos = [ExteriorOrientation(100.0 * j, 20.0 * j, 1000.0, *rng.normal(0, 3, 3)) for j in range(3)]
    R = np.stack([e.rotation_cv for e in eos])
    C = np.array([e.centre for e in eos])
    X = np.column_stack([rng.uniform(-150, 350, 12), rng.uniform(-200, 250, 12), rng.uniform(-40, 60, 12)])
    frame, point = np.repeat(np.arange(3), 12), np.tile(np.arange(12), 3)
    px, J_eo, J_p, J_int, _ = bj.project_with_jacobians(R, C, X, frame, point, interior, scale)
    assert np.allclose(px, bj.project(R, C, X, frame, point, interior, scale))

    h = 1e-6
    for k in range(3):  # projection centre of every frame at once (each observation has one frame)
        d = np.zeros(3)
        d[k] = h
        num = (bj.project(R, C + d, X, frame, point, interior, scale)
               - bj.project(R, C - d, X, frame, point, interior, scale)) / (2 * h)
        assert np.allclose(J_eo[:, :, k], num, rtol=1e-5, atol=1e-6)
    for k in range(3):  # multiplicative rotation increments R·exp([δθ]×)
        d = np.zeros((3, 3))
        d[:, k] = h
        num = (bj.project(R @ bj.rodrigues(d), C, X, frame, point, interior, scale)
               - bj.project(R @ bj.rodrigues(-d), C, X, frame, point, interior, scale)) / (2 * h)
        assert np.allclose(J_eo[:, :, 3 + k], num, rtol=1e-5, atol=1e-3)
    for k in range(3):  # ground points
        d = np.zeros(3)
        d[k] = h
        num = (bj.project(R, C, X + d, frame, point, interior, scale)
               - bj.project(R, C, X - d, frame, point, interior, scale)) / (2 * h)
        assert np.allclose(J_p[:, :, k], num, rtol=1e-5, atol=1e-6)
    for k in range(8):  # interior: f, ppx, ppy, k1, k2, k3, p1, p2
        step = 1e-7 if k >= 3 else 1e-5
        d = np.zeros(8)
        d[k] = step
        num = (bj.project(R, C, X, frame, point, interior + d, scale)
               - bj.project(R, C, X, frame, point, interior - d, scale)) / (2 * step)
        assert np.allclose(J_int[:, :, k], num, rtol=1e-5, atol=1e-4), bj.INTERIOR_NAMES[k]


def test_block_recovers_truth_at_the_noise_level(standard):
    sb, r = standard
    check = r.stats["check"]
    assert check["n"] >= 8
    assert check["rmse_planimetric_m"] < 0.5 * sb.gsd
    assert check["rmse_z_m"] < 1.5 * sb.gsd
    assert 0.8 < r.sigma0 < 1.2  # a priori σ = the simulated 0.3 px
    assert 0.15 < r.stats["image_rms_px"] < 0.3
    err = _eo_array(r.eo) - _eo_array(sb.true_eo)
    err[:, 5] = (err[:, 5] + 180) % 360 - 180
    assert np.all(np.abs(err[:, :3]) < 4 * r.eo_sigma[:, :3] + 0.05)
    assert np.all(np.abs(err[:, 3:]) < 0.2)
    # a-posteriori σ of the points: finite for every point kept, larger in height than in plan
    kept = np.isfinite(r.point_xyz).all(axis=1)
    assert np.isfinite(r.point_sigma[kept]).all()
    assert np.median(r.point_sigma[kept, 2]) > np.median(r.point_sigma[kept, 0])


def test_every_planted_blunder_is_caught(standard):
    sb, r = standard
    assert len(sb.blunders) >= 40
    assert np.all(r.status[sb.blunders] != "used")
    good = np.setdiff1d(np.arange(len(r.status)), sb.blunders)
    assert np.mean(r.status[good] != "used") < 0.05  # few good observations are lost
    assert all(b["w"] > 3.29 for b in r.blunders)


def test_self_calibration_recovers_focal_length_and_k1_with_gnss_centres():
    sb = simulate_block(seed=2, eo_noise=(0.05, 0.5), true_focal_length=30.15, true_distortion=DISTORTION)
    r = adjust_block(sb.block, BundleOptions(self_calibration=("f", "k1", "k2"), eo_sigma=(0.05, 10.0)))
    assert not r.fixed
    assert abs(r.camera.focal_length - 30.15) < max(3 * r.interior_sigma["f"], 0.01)  # nominal 30.0
    assert abs(r.distortion["k1"] - DISTORTION[0]) < 3 * r.interior_sigma["k1"] + 1e-3
    assert r.stats["check"]["rmse_planimetric_m"] < 0.5 * sb.gsd


def test_free_focal_length_over_flat_ground_is_held_fixed_and_reported():
    sb = simulate_block(seed=4, strips=2, frames_per_strip=6, relief=1.0, attitude_sd=0.3)
    r = adjust_block(sb.block, BundleOptions(self_calibration=("f", "k1")))
    fixed = {f["parameter"]: f for f in r.fixed}
    assert "f" in fixed and fixed["f"]["multiple_correlation"] > 0.999
    assert fixed["f"]["partner"].endswith("Z0") and abs(fixed["f"]["correlation"]) > 0.95
    assert "held fixed" in fixed["f"]["reason"]
    assert r.camera.focal_length == sb.block.camera.focal_length
    assert r.stats["check"]["rmse_planimetric_m"] < 0.5 * sb.gsd


def test_fewer_than_three_control_points_without_orientation_priors():
    b = simulate_block(seed=1, strips=2, frames_per_strip=4, n_control=2).block
    with pytest.raises(InputError, match="at least 3"):
        adjust_block(b)


def test_a_frame_no_tie_point_reaches_is_named():
    b = simulate_block(seed=1, strips=2, frames_per_strip=4).block
    far = dataclasses.replace(b.eo[0], X=b.eo[0].X + 50000.0)
    lonely = dataclasses.replace(b, frames=b.frames + ("far_away",), eo=b.eo + (far,))
    with pytest.raises(InputError, match="far_away"):
        adjust_block(lonely)


def test_geographic_crs_is_refused():
    b = simulate_block(seed=1, strips=2, frames_per_strip=4).block
    with pytest.raises(InputError, match="geographic"):
        adjust_block(dataclasses.replace(b, crs="EPSG:4326"))


def test_a_block_that_cannot_converge_stops_with_a_clear_error():
    b = simulate_block(seed=1, strips=2, frames_per_strip=4, blunder_fraction=0.0).block
    garbage = b.obs_pixel + np.random.default_rng(0).normal(0, 40, b.obs_pixel.shape)  # no real tie points
    with pytest.raises(ModelError, match="did not converge.*median image residual"):
        adjust_block(dataclasses.replace(b, obs_pixel=garbage))


def test_points_behind_the_cameras_are_refused_at_the_start():
    b = simulate_block(seed=1, strips=2, frames_per_strip=4).block
    below = tuple(dataclasses.replace(e, Z=-500.0) for e in b.eo)
    with pytest.raises(ModelError, match="behind their camera"):
        adjust_block(dataclasses.replace(b, eo=below))


def test_inverse_blocks_and_redundancy_numbers_equal_the_dense_inverse():
    """Σ_aa, Σ_bb and Q_a from the reduced system equal the blocks of the dense (JᵀPJ)⁻¹."""
    from fotogeo.orientation.bundle import _Run
    from fotogeo.orientation.bundle_lm import linearise
    from fotogeo.orientation.bundle_robust import posterior
    sb = simulate_block(seed=3, strips=2, frames_per_strip=3, point_spacing=150.0, blunder_fraction=0.0)
    run = _Run(sb.block, BundleOptions(self_calibration=("f", "k1")))
    pb, s = run.problem()
    _, J_c, J_p, _ = linearise(pb, s, pb.p0)
    n, nc, P = len(pb.st.point), pb.st.n_camera, pb.st.n_points
    J = np.zeros((2 * n, nc + 3 * P))
    idx = pb.st.index
    for a in range(n):
        J[2 * a:2 * a + 2, idx[a]] = J_c[a]
        J[2 * a:2 * a + 2, nc + 3 * pb.st.point[a]:nc + 3 * pb.st.point[a] + 3] = J_p[a]
    N = J.T @ (np.repeat(pb.p0, 2)[:, None] * J)
    N[nc:, nc:] += np.diag(pb.ctrl_w.reshape(-1))
    Ninv = np.linalg.inv(N)
    post = posterior(pb, s, pb.p0)
    assert np.allclose(post.S_inv, Ninv[:nc, :nc], rtol=1e-6, atol=1e-12 * np.abs(Ninv[:nc, :nc]).max())
    dense_bb = np.stack([Ninv[nc + 3 * i:nc + 3 * i + 3, nc + 3 * i:nc + 3 * i + 3] for i in range(P)])
    assert np.allclose(post.point_cofactor, dense_bb, rtol=1e-6, atol=1e-9 * np.abs(dense_bb).max())
    Q = J @ Ninv @ J.T
    r_dense = 1 - np.repeat(pb.p0, 2) * np.diag(Q)
    assert np.allclose(post.r.reshape(-1), r_dense, atol=1e-6)
    # the redundancy numbers of all observations (image and control) add up to the redundancy
    r_ctrl = 1 - pb.ctrl_w.reshape(-1) * np.diag(Ninv[nc:, nc:])
    assert np.isclose(post.r.sum() + r_ctrl[pb.ctrl_w.reshape(-1) > 0].sum(), post.redundancy, atol=1e-6)


def test_a_control_point_with_a_wrong_coordinate_is_rejected():
    sb = simulate_block(seed=5, blunder_fraction=0.0)
    b = sb.block
    ctrl = np.flatnonzero(b.role == "control")
    wrong = b.point_xyz.copy()
    wrong[ctrl[2], 0] += 1.5  # 1.5 m in X against a σ of 2 cm
    r = adjust_block(dataclasses.replace(b, point_xyz=wrong))
    assert r.roles[ctrl[2]] == "rejected"
    assert [x["point"] for x in r.blunders if x["kind"] == "control"] == [b.point_ids[ctrl[2]]]
    assert r.stats["n_control_rejected"] == 1
    assert r.stats["check"]["rmse_planimetric_m"] < 0.5 * sb.gsd


def test_residuals_within_their_a_priori_sigma_are_never_blunders():
    """Observations that fit far better than their σ (σ̂₀ ≪ 1, as LSM σ on the NGI pair) are tested with
    σ₀ = 1: the τ test's rescaling flagged 0.04-0.15 px residuals there; a planted 5 px error is still caught."""
    sb = simulate_block(seed=6, strips=2, frames_per_strip=4, noise=0.05, blunder_fraction=0.0)
    b = dataclasses.replace(sb.block, obs_sigma=np.full(len(sb.block.obs_frame), 1.0))
    clean = adjust_block(b)
    assert clean.sigma0 < 0.2
    assert clean.blunders == ()
    tie = np.flatnonzero(b.role[b.obs_point] == "tie")
    counts = np.bincount(b.obs_point, minlength=len(b.point_ids))
    planted = int(tie[np.argmax(counts[b.obs_point[tie]])])  # on a point of many rays: testable
    px = b.obs_pixel.copy()
    px[planted] += (3.0, 4.0)
    r = adjust_block(dataclasses.replace(b, obs_pixel=px))
    assert [x["observation"] for x in r.blunders] == [planted]
    assert r.status[planted] == "blunder"


def test_points_whose_rays_meet_at_a_grazing_angle_are_found():
    """_narrow_rays: two rays meeting at 1° (below MIN_RAY_ANGLE_DEG) mark their point, at 5° not; a point with one
    active ray (a control point's) is never marked."""
    from fotogeo.orientation.bundle import MIN_RAY_ANGLE_DEG, _narrow_rays
    d = 100.0
    C = np.array([[0.0, 0.0, d], [d * np.tan(np.radians(1.0)), 0.0, d], [d * np.tan(np.radians(5.0)), 0.0, d]])
    X = np.zeros((3, 3))  # three points at the origin
    frame = np.array([0, 1, 0, 2, 0, 1])
    point = np.array([0, 0, 1, 1, 2, 2])
    active = np.array([True, True, True, True, True, False])
    assert MIN_RAY_ANGLE_DEG > 1.0
    assert _narrow_rays(X, C, frame, point, active, 3).tolist() == [True, False, False]


def test_covariances_are_never_scaled_below_the_a_priori_precision():
    """σ0 < 1 (residuals smaller than their stated σ) keeps the a-priori precision: every σ and covariance is
    scaled by max(σ0, 1), and both are stated; σ0 > 1 scales them up as before. Every stated σ (images and
    control) times k leaves the solution as it is and multiplies the cofactors by k²."""
    import dataclasses

    def stated(k):  # no culling, no Huber weights: they see the stated σ, and the solution would differ
        b = sb.block
        return adjust_block(dataclasses.replace(b, obs_sigma=b.obs_sigma * k, point_sigma=b.point_sigma * k),
                            BundleOptions(snooping=False, huber_k=1e9, skip_c=1e9, estimate_image_sigma=False))
    sb = simulate_block(seed=5, strips=2, frames_per_strip=5, blunder_fraction=0.0)  # the global σ0 rule alone
    honest, pessimistic, optimistic = stated(1.0), stated(3.0), stated(0.5)
    assert 0.8 < honest.sigma0 < 1.2 and 0.25 < pessimistic.sigma0 < 0.4 and 1.6 < optimistic.sigma0 < 2.4
    assert pessimistic.stats["covariance_scale"] == 1.0 and "not by sigma0" in pessimistic.stats["covariance_rule"]
    assert optimistic.stats["covariance_scale"] == optimistic.sigma0
    cofactor = honest.eo_sigma / max(honest.sigma0, 1.0)  # √diag(Q) of the honest statement
    # the pessimistic statement's σ are its own a-priori precision, 3 x the cofactor's (scaled by σ0 they would be
    # σ0 x 3 x √Q, the honest σ: a claim the stated σ of the observations never backed)
    np.testing.assert_allclose(pessimistic.eo_sigma, 3.0 * cofactor, rtol=1e-6)
    np.testing.assert_allclose(optimistic.eo_sigma, optimistic.sigma0 * 0.5 * cofactor, rtol=1e-6)
    cov = np.sqrt(np.diagonal(pessimistic.eo_covariance, axis1=1, axis2=2))
    np.testing.assert_allclose(cov[:, :3], pessimistic.eo_sigma[:, :3], rtol=1e-9)


def test_a_focal_length_held_fixed_keeps_its_free_estimate():
    """GNSS centres of σ 20 m over flat ground (2 % of the flying height): the focal length is held fixed for its
    correlation, at the camera's 30 mm while the images were taken with 33 mm; its entry keeps the estimate it had
    while free, which points to the true focal length (what a caller compares the camera's value with)."""
    sb = simulate_block(seed=4, strips=2, frames_per_strip=6, relief=1.0, attitude_sd=0.3, true_focal_length=33.0,
                        eo_noise=(20.0, 0.5))
    r = adjust_block(sb.block, BundleOptions(self_calibration=("f", "k1"), eo_sigma=(20.0, 10.0)))
    held = {f["parameter"]: f for f in r.fixed}["f"]
    assert r.camera.focal_length == 30.0 and held["multiple_correlation"] > 0.999
    assert abs(held["estimate"] - 33.0) < 3 * held["sigma"] and held["sigma"] < 0.3, held
