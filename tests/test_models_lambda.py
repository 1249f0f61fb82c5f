"""The RFM's λ from one decomposition equals leave-one-out cross-validation with a solve per λ,
and a fit gives the same coefficients whatever the BLAS thread count (issue 24)."""
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from fotogeo.models import MODELS
from fotogeo.models import tikhonov as rfm
from fotogeo.models.polynomial import terms_3d
from fotogeo.models.threads import blas_threads_for


def reference_cv(A, l, L, grid):
    """The plain algorithm: for every λ an SVD of [A; λL], PRESS and the one-standard-error rule
    (on one BLAS thread, as the fit under test: the reference must not depend on the threads either)."""
    with blas_threads_for(*A.shape):
        return _reference_cv(A, l, L, grid)


def _reference_cv(A, l, L, grid):
    n = len(l)
    smax = np.linalg.norm(A, 2)
    cands = []
    for k in grid:
        lam = smax * 10.0 ** k
        M = np.vstack([A, lam * L])
        U, S, Vt = np.linalg.svd(M, full_matrices=False)
        if S[-1] <= S[0] * 1e-13:
            continue
        p = Vt.T @ ((U.T @ np.concatenate([l, np.zeros(len(L))])) / S)
        hii = np.sum(U[:n] ** 2, axis=1)
        r = l - A @ p
        e2 = (r / (1 - hii)) ** 2
        cands.append((e2.sum(), np.sqrt(n) * e2.std(), p, 10.0 ** k))
    # the one-standard-error rule, scores within rfm.TIE (relative) being equal: the larger λ is the minimum among
    # equal ones, a score equal to the limit is within it (the last bits of a score depend on the BLAS)
    gmin = min(c[0] for c in cands)
    se = max((c for c in cands if c[0] <= gmin * (1 + rfm.TIE)), key=lambda c: c[3])[1]
    limit = gmin + rfm.SE_FACTOR * se + rfm.TOLERANCE * gmin
    best = max((c for c in cands if c[0] <= limit * (1 + rfm.TIE)), key=lambda c: c[3])
    return best[2], best[3]


def frame_design(n, noise, seed):
    """The rfm-common design of a pinhole camera (plus a radial term) seen from random ground points."""
    rng = np.random.default_rng(seed)
    s = rng.uniform(-1, 1, (n, 3))
    den = 1 + 0.05 * s[:, 0] - 0.03 * s[:, 1] + 0.02 * s[:, 2]
    d = np.column_stack([(0.9 * s[:, 0] + 0.1 * s[:, 2]) / den, (0.8 * s[:, 1] - 0.05 * s[:, 2]) / den])
    d += 0.02 * d * (d ** 2).sum(1, keepdims=True) + rng.normal(0, noise, d.shape)
    (A, l, L, _), = MODELS["rfm-common"]._blocks(terms_3d(s), d)
    return A, l, L


@pytest.mark.parametrize("n,noise,seed", [(30, 1e-3, 0), (60, 1e-3, 1), (400, 1e-4, 2), (400, 1e-2, 3)])
def test_one_decomposition_gives_the_loo_choice(n, noise, seed):
    A, l, L = frame_design(n, noise, seed)
    p_ref, rel_ref = reference_cv(A, l, L, rfm._LOG_GRID)
    p, lam, rel, dof, _ = rfm.tikhonov_cv(A, l, L)
    assert rel == rel_ref
    # predictions in normalised image coordinates (±1): 1e-10 is 1e-6 px on a 20000 px image; the
    # coefficients move with the rounding of the memory layout (5e-10 of 0.9 measured), far less
    assert np.abs(A @ p - A @ p_ref).max() <= 1e-10
    assert np.allclose(p, p_ref, rtol=1e-7, atol=1e-8 * np.abs(p_ref).max())
    assert 11 <= dof <= A.shape[1]
    # the same with the x rows and the y rows factorised apart
    blocks = [(slice(0, n), np.flatnonzero(np.any(A[:n] != 0, 0))), (slice(n, 2 * n), np.flatnonzero(np.any(A[n:] != 0, 0)))]
    p2, _, rel2, dof2, _ = rfm.tikhonov_cv(A, l, L, row_blocks=blocks)
    # the same tolerances as against the reference: predictions to 1e-10, coefficients to their conditioning
    # (1.5e-8 relative measured on n=60, seed 1, at λ = 3e-4 σ_max; predictions 1.3e-12 apart)
    assert rel2 == rel_ref and np.abs(A @ p2 - A @ p).max() <= 1e-10
    assert np.allclose(p2, p, rtol=1e-7, atol=1e-8 * np.abs(p).max())
    assert dof2 == pytest.approx(dof, rel=1e-9)


def test_fixed_lambda_solution_equals_the_cv_solution():
    A, l, L = frame_design(200, 1e-3, 4)
    p, _, rel, _, _ = rfm.tikhonov_cv(A, l, L)
    assert np.allclose(rfm.tikhonov_at(A, l, L, rel), p, rtol=1e-8, atol=1e-10 * np.abs(p).max())


def test_rfm_fit_matches_reference_lambda_on_a_frame():
    """A whole fit: the λ kept in the iteration is the one cross-validation picks at the end."""
    rng = np.random.default_rng(5)
    ground = rng.uniform(-1, 1, (300, 3)) * [1000, 1000, 50] + [5e5, 6e6, 300]
    den = 1 + 1e-4 * (ground[:, 2] - 300)
    px = np.column_stack([(ground[:, 0] - 5e5) / den, (ground[:, 1] - 6e6) / den]) + rng.normal(0, 0.3, (300, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = MODELS["rfm"].estimate(ground, px)
    assert np.sqrt(np.mean((m.forward(ground) - px) ** 2)) < 0.35
    assert len(m.info["lambda_rel"]) == 1 and np.isfinite(m.info["dof"][0])


FIT_IN_A_PROCESS = r"""
import json, sys, warnings
import numpy as np
sys.path.insert(0, sys.argv[1])
from test_models_lambda import frame_design
from fotogeo.models import MODELS
from fotogeo.models import tikhonov
A, l, L = frame_design(60, 1e-3, 1)
p = tikhonov.tikhonov_cv(A, l, L)[0]
rng = np.random.default_rng(6)
ground = rng.uniform(-1, 1, (60, 3)) * [1000, 1000, 80] + [5e5, 6e6, 300]
den = 1 + 1e-4 * (ground[:, 2] - 300)
px = np.column_stack([(ground[:, 0] - 5e5) / den, (ground[:, 1] - 6e6) / den]) + rng.normal(0, 0.3, (60, 2))
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    model = MODELS["rfm-common"].estimate(ground, px)
grid = rng.uniform(-1, 1, (400, 3)) * [1000, 1000, 80] + [5e5, 6e6, 300]
print(json.dumps({"p": [x.hex() for x in p], "params": [x.hex() for x in model.params],
                  "forward": model.forward(grid).ravel().tolist()}))
"""


def _fit_with_blas_threads(threads: int) -> dict:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": str(threads), "OMP_NUM_THREADS": str(threads)}
    tests = str(Path(__file__).parent)
    out = subprocess.run([sys.executable, "-c", FIT_IN_A_PROCESS, tests], env=env, capture_output=True, text=True,
                         check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def test_a_fit_does_not_depend_on_the_blas_threads():
    """The case that failed on another 2-core machine (issue 24: coefficients 0.9 apart under
    OPENBLAS_NUM_THREADS=2 and 1) and a whole rfm-common fit, each in a fresh process: the same
    coefficients (to the rounding of the process's memory layout, which alone moves them by up to
    5e-10 of 0.9 here) and the same predictions to 1e-6 px."""
    one, two = _fit_with_blas_threads(1), _fit_with_blas_threads(2)
    for key in ("p", "params"):
        a, b = (np.array([float.fromhex(x) for x in run[key]]) for run in (one, two))
        assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max(), key
    assert np.abs(np.subtract(one["forward"], two["forward"])).max() <= 1e-6


def test_the_lambda_choice_does_not_hang_on_the_last_bits():
    """Scores that differ only in their last bits (another BLAS) give the same λ: equal minima choose the larger
    λ, a score at the limit is within it, whatever the rounding."""
    rng = np.random.default_rng(0)
    lam = 10.0 ** np.arange(-4.0, 1.01, 0.25)
    score = 1.0 + np.abs(lam - 0.1)  # a minimum at λ = 0.1 …
    score[lam == 0.1] = score[lam == 10 ** -0.75] = 1.0  # … shared by two λ
    se = np.full(len(lam), 0.02)
    limit = 1.0 + 0.02 * rfm.SE_FACTOR + rfm.TOLERANCE
    score[lam == 10 ** 0.25] = limit  # a score exactly at the limit
    want = rfm.choose(score, se, lam)
    assert lam[want] == pytest.approx(10 ** 0.25)
    for _ in range(200):
        noisy = score * (1 + rng.uniform(-1e-12, 1e-12, len(score)))
        assert rfm.choose(noisy, se * (1 + rng.uniform(-1e-12, 1e-12, len(se))), lam) == want
