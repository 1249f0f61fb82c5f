"""``fit_terrain(model="auto")`` chooses by spatially blocked cross-validation, not by interleaved check points.

Rendered cases: a pinhole frame over rolling terrain; tie points over the inner part of the image whose
errors are a smooth field (wavelengths 120-400 px, the kind a reference's own geometric errors or a
DEM's give) plus white noise. The truth is known on a grid over the whole image, so each candidate's
error away from the tie points can be measured. Where the frame is a pinhole (the DLT is exact) the
RFMs follow the error field and win at the interleaved check points, yet are worse on the grid: the
rule must keep the DLT. Where the frame has radial distortion (the DLT cannot be right) the rule must
still take the polynomial RFM.
"""
import warnings

import numpy as np
import pytest

from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from fotogeo.models import DLT, get_model
from fotogeo.orientation.terrain import blocked_cv_rmse, choose_parsimonious, fit_terrain

W, H = 900, 700
FRAME = OrientedFrame(FrameCamera(12.0, (10.8, 8.4), (W, H)), ExteriorOrientation(1500.0, 1200.0, 3500.0, 2.0, -1.5,
                                                                                   170.0), "t")


def _surface(X, Y):
    return 80 * np.sin(X / 600.0) + 60 * np.cos(Y / 450.0)


def _ground(px):
    """The terrain point seen at each pixel (ray-surface intersection by fixed-point iteration)."""
    Z = np.zeros(len(px))
    for _ in range(30):
        XY = FRAME.pixel_to_world_at(px, Z)[:, :2]
        Z = _surface(XY[:, 0], XY[:, 1])
    return np.column_stack([XY, Z])


def _field(px, rng, amp, k=12):
    """A smooth random error field (pixels) of RMS about ``amp``: ``k`` plane waves of 120-400 px."""
    out = np.zeros_like(px)
    for _ in range(k):
        lam, th, ph = rng.uniform(120, 400), rng.uniform(0, np.pi), rng.uniform(0, 2 * np.pi, 2)
        d = px @ np.array([np.cos(th), np.sin(th)]) * 2 * np.pi / lam
        out += np.column_stack([np.sin(d + ph[0]), np.sin(d + ph[1])])
    return out * amp / np.sqrt(k)


def _distort(px, k1):
    """Radial distortion about the image centre, ``k1`` per (half-width)²."""
    c = np.array([W / 2, H / 2])
    r2 = np.sum(((px - c) / (W / 2)) ** 2, axis=1, keepdims=True)
    return c + (px - c) * (1 + k1 * r2)


def _case(seed, k1, n=1200):
    """Tie points (observed pixels, ground) and the truth on a grid over the whole image."""
    rng = np.random.default_rng(seed)
    px = np.column_stack([rng.uniform(90, W - 90, n), rng.uniform(70, H - 70, n)])  # not up to the edges
    obs = _distort(px, k1) + _field(px, rng, 0.5) + rng.normal(0, 0.15, (n, 2))
    gx, gy = np.meshgrid(np.arange(5.0, W, 20.0), np.arange(5.0, H, 20.0))
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    return obs, _ground(px), _ground(grid), _distort(grid, k1)


def _choose(seed, k1):
    obs, ground, grid_ground, grid_px = _case(seed, k1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_terrain(obs, ground, model="auto", threshold_m=30.0, min_sigma_m=3.0)
        control = fit.role == "control"
        dense = {}
        for c in fit.candidates:  # every candidate's true error over the whole image
            m = get_model(c["model"]).estimate(ground[control], obs[control])
            dense[c["model"]] = float(np.sqrt(np.mean(np.sum((m.forward(grid_ground) - grid_px) ** 2, axis=1))))
    return fit, dense


@pytest.mark.parametrize("seed", [0, 1])
def test_a_flexible_model_that_fits_interleaved_check_points_is_not_chosen(seed):
    fit, dense = _choose(seed, 0.0)
    # the case is what it claims: the check points favour an RFM that is worse than the DLT on the grid
    by_check = choose_parsimonious(fit.candidates, "check_rmse_px")[0]
    assert by_check != "dlt" and dense[by_check] > 3 * dense["dlt"], (by_check, dense)
    assert fit.model.name == "dlt" and fit.compared == "blocked_cv_rmse_px", (fit.model.name, fit.candidates)
    assert dense["dlt"] == min(dense.values()) and dense["dlt"] < 0.3, dense  # 0.5 px field, 0.15 px noise
    assert "blocked cross-validation" in fit.chosen_because and "interleave" in fit.chosen_because


def test_a_truly_needed_higher_order_model_is_still_chosen():
    # k1 = 0.02: up to 14 px at the corners, 9 px at the edges' middle. (At half that, 0.01, the blocked
    # cross-validation of seed 0 sees the polynomial RFM only 3 % better than the DLT and keeps the DLT: a
    # distortion of a few pixels under a 0.5 px error field is within the parsimony tolerance.)
    fit, dense = _choose(0, 0.02)
    assert fit.model.name != "dlt" and fit.model.name.startswith("rfm"), fit.candidates
    assert dense[fit.model.name] < 0.7 * dense["dlt"], dense  # and it is truer than the DLT away from the ties
    assert dense[fit.model.name] <= 1.2 * min(dense.values()), dense


def test_blocked_cv_rmse_is_the_noise_for_an_exact_model_and_infinite_when_a_fold_cannot_be_fitted():
    rng = np.random.default_rng(3)
    px = np.column_stack([rng.uniform(0, W, 400), rng.uniform(0, H, 400)])
    ground = _ground(px)
    noisy = px + rng.normal(0, 0.2, px.shape)
    cv = blocked_cv_rmse(DLT, ground, noisy)
    assert 0.2 * np.sqrt(2) * 0.9 < cv < 0.2 * np.sqrt(2) * 1.3, cv  # exact model: the noise, plus a little
    # 7 points: every fold leaves at most 6, the DLT's minimum; any region with two leaves 5 and cannot be fitted
    assert blocked_cv_rmse(DLT, ground[:7], noisy[:7]) == float("inf")


def test_too_few_control_points_fall_back_to_the_check_rmse_and_say_so():
    obs, ground, _, _ = _case(4, 0.0, n=70)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_terrain(obs, ground, model="auto", threshold_m=30.0, min_sigma_m=3.0)
    assert fit.compared == "check_rmse_px" and "fewer than 60 control points" in fit.chosen_because
    assert all("blocked_cv_rmse_px" not in c for c in fit.candidates)
