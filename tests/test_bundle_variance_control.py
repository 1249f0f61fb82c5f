"""The image points' variance component with ground control in the block (fotogeo.orientation.bundle): tie points
given 0.1 px for 0.3 px of noise push their misfit into the control points (a few at centimetres read σ̂ ≈ 2
beside the images' 3), which must not stop the images' σ from being estimated — the adjustment then equals the
one with the right σ given."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.orientation.bundle_variance import images_too_strong


@pytest.fixture(scope="module")
def sb():
    return simulate_block(seed=5, strips=2, frames_per_strip=6, point_spacing=40.0, blunder_fraction=0.0)


def _adjust(sb, image_sigma, estimate=True):
    block = dataclasses.replace(sb.block, obs_sigma=np.full(len(sb.block.obs_frame), image_sigma))
    return adjust_block(block, BundleOptions(snooping=False, estimate_image_sigma=estimate))


def test_control_carrying_the_images_misfit_does_not_block_the_estimate(sb):
    given = _adjust(sb, 0.1, estimate=False).stats["variance_components"]
    assert given["image"]["sigma0"] > 2.5 and given["control"]["sigma0"] > 1.5  # both read too high ...
    assert images_too_strong(given)  # ... and the images' σ is the one to estimate
    right = _adjust(sb, 0.3)
    estimated = _adjust(sb, 0.1)
    image = estimated.stats["variance_components"]["image"]
    assert image["factor"] == pytest.approx(3.0, rel=0.1) and image["sigma0"] == pytest.approx(1.0, abs=0.05)
    assert np.allclose(estimated.eo_sigma, right.eo_sigma, rtol=0.1)
    for key in ("rmse_planimetric_m", "rmse_z_m"):
        assert estimated.stats["check"][key] == pytest.approx(right.stats["check"][key], rel=0.05)


def test_a_prior_far_off_is_not_hidden_by_widening_the_images():
    groups = {"image": {"sigma0": 1.8, "redundancy": 150.0}, "position_prior": {"sigma0": 3.5, "redundancy": 6.0},
              "control": {"sigma0": float("nan"), "redundancy": 0.4}}
    assert not images_too_strong(groups)


def test_a_larger_sigma_on_little_redundancy_does_not_block_the_estimate():
    """The 300-frame block of benchmarks/bundle_bench.py with 0.1 px given for 0.3 px: image σ̂ 2.98 on 255 928 of
    redundancy, control 3.80 on 2.4 — no evidence that the control's σ is wrong (F = 1.63 < 2.6)."""
    groups = {"image": {"sigma0": 2.977, "redundancy": 255927.6}, "control": {"sigma0": 3.796, "redundancy": 2.44}}
    assert images_too_strong(groups)
    groups["control"]["redundancy"] = 40.0  # the same ratio on 40 of redundancy says the control is off
    assert not images_too_strong(groups)
