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
