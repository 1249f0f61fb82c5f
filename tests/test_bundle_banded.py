"""The reduced camera system solved as a band (fotogeo.orientation.bundle_banded) equals the dense solution."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, _Run
from fotogeo.orientation.bundle_banded import solve_reduced
from fotogeo.orientation.bundle_lm import linearise
from fotogeo.orientation.bundle_normals import reduced_system


@pytest.mark.parametrize("free", [(), ("f", "k1", "b3")])
def test_banded_solution_equals_the_dense_one(free):
    sb = simulate_block(seed=2, strips=2, frames_per_strip=14, point_spacing=120.0, blunder_fraction=0.0)
    run = _Run(sb.block, BundleOptions(self_calibration=free))
    pb, s = run.problem()
    st = pb.st
    assert 6 * st.band_frames + 5 <= 6 * st.n_frames // 3  # a real band: the banded path is taken
    S, rhs, _ = reduced_system(st, linearise(pb, s, pb.p0)[0], 1e-3)
    x = solve_reduced(S, rhs, st.band_order, st.band_frames)
    dense = np.linalg.solve(S, rhs)
    assert np.allclose(x, dense, rtol=1e-8, atol=1e-10 * np.abs(dense).max())
    with pytest.raises(np.linalg.LinAlgError):
        solve_reduced(-S, rhs, st.band_order, st.band_frames)  # not positive definite


@pytest.mark.parametrize("free", [(), ("f", "k1", "b3")])
def test_selected_inverse_equals_the_dense_inverse_on_the_band_and_the_interior_rows(free):
    from fotogeo.orientation.bundle_banded import selected_inverse
    sb = simulate_block(seed=2, strips=2, frames_per_strip=14, point_spacing=120.0, blunder_fraction=0.0)
    run = _Run(sb.block, BundleOptions(self_calibration=free))
    pb, s = run.problem()
    st = pb.st
    S, _, _ = reduced_system(st, linearise(pb, s, pb.p0)[0], 0.0)
    Z = selected_inverse(S, st.band_order, st.band_frames)
    dense = np.linalg.inv(S)
    position = np.empty(st.n_frames, int)
    position[st.band_order] = np.arange(st.n_frames)
    n_eo = 6 * st.n_frames
    unknown = np.r_[(6 * position[:, None] + np.arange(6)).ravel(), np.full(len(free), -1)]  # in band order
    border = unknown < 0
    needed = (np.abs(unknown[:, None] - unknown[None, :]) <= 6 * st.band_frames + 5) | border[:, None] | border[None, :]
    scale = np.sqrt(np.outer(np.diag(dense), np.diag(dense)))
    assert np.allclose(Z[needed] / scale[needed], dense[needed] / scale[needed], atol=1e-8)
    assert np.all(Z[~needed] == 0) and (~needed).sum() > 0.3 * n_eo ** 2  # not formed: most of S⁻¹
    for j, l in st.pair_frames:  # every frame pair that shares points is inside the band
        assert abs(position[j] - position[l]) <= st.band_frames
