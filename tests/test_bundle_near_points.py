"""Tie points pulled onto a projection centre are dropped before any statistic is computed with them.

The two rays of a wrong match can meet nowhere near the ground, and the adjustment can slide the point onto
one of its cameras: there the collinearity derivatives grow without bound (∝ 1/depth), the reduced camera
system loses its positive definiteness, and every frame's σ read "undetermined" (a rendered oblique block with
self-calibration: a two-ray point 4e-8 m from a projection centre gave the reduced matrix a diagonal of −4e15).
"""
from __future__ import annotations

import numpy as np

from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import NEAR_FRACTION, BundleOptions, _Run


def _run_with_a_point_at(offset_fraction: float):
    sb = simulate_block(seed=3, strips=2, frames_per_strip=3, point_spacing=150.0, blunder_fraction=0.0)
    run = _Run(sb.block, BundleOptions())
    b = run.block
    tie = np.flatnonzero(b.role == "tie")[0]
    obs = np.flatnonzero(b.obs_point == tie)
    j = b.obs_frame[obs[0]]
    depth = np.median(np.linalg.norm(run.X[b.obs_point] - run.C[b.obs_frame], axis=1))
    axis = run.R[j][2]  # the camera's viewing direction in the block frame: positive depth
    run.X[tie] = run.C[j] + np.sign(axis @ (run.X[tie] - run.C[j])) * offset_fraction * depth * axis
    return run, obs


def test_a_point_on_a_projection_centre_is_dropped():
    run, obs = _run_with_a_point_at(1e-9)
    assert run.drop_unusable() == 1
    assert not run.active[obs].any()


def test_a_point_near_but_beyond_the_limit_is_kept():
    run, obs = _run_with_a_point_at(2 * NEAR_FRACTION)
    assert run.drop_unusable() == 0
    assert run.active[obs].all()
