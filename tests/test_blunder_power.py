"""The blunder test's power (fotogeo.orientation.blunders): the minimal detectable blunder (MDB) per point, the
check of a given click σ against the residuals, and the rates on an NGI frame the benchmark's documented run did
not tune on (0184), on seeds of their own.

The tolerances allow for the small samples: a rate measured over 100 sets in benchmarks/blunder_bench.py is
asserted here over 25–30 sets, a few binomial standard deviations below it.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from blunder_bench import Scene, flagged, one_set, pool, truths  # noqa: E402

from fotogeo.models import get_model  # noqa: E402
from fotogeo.orientation.blunders import BETA, _Fit, detect_blunders, noncentrality  # noqa: E402

NOISE = 0.8


def test_a_blunder_of_the_mdb_is_found_with_the_stated_power(blunder_scene):
    """Plant a blunder of exactly the point's MDB in its least favourable direction: the point test (χ²(2), σ
    given, the Bonferroni level of 15 points) finds it in 1 − β = 80 % of 2000 noise draws (± 3 %). The model is
    linear (affine with height), so the deletion statistic of every draw is ``v_kᵀ R_k⁻¹ v_k`` with ``v = (I − H) y``
    (its equality with the drop of the sum of squares is tests/test_blunders.py's)."""
    from fotogeo.orientation.design import free_directions, jacobian
    truth, points = blunder_scene
    cls = get_model("affine-height")
    ground, clean, _ = one_set(points, truth["affine-height"], 15, 0.0, 0.0, np.random.default_rng(7))
    test = detect_blunders(cls, ground, clean + np.random.default_rng(8).normal(0, NOISE, clean.shape), sigma=NOISE)
    fit = _Fit(cls, ground, clean, np.ones(15, bool), None, {})
    k = int(np.nanargmax(test.mdb))  # the weakest point: its least favourable direction matters most
    lam, vec = np.linalg.eigh(fit.R[k])
    assert test.mdb[k] == pytest.approx(NOISE * np.sqrt(noncentrality(0.01 / 15, None) / lam[0]), rel=0.05)
    J = jacobian(fit.model, ground, free_directions(fit.model))
    Q, _ = np.linalg.qr(J)
    y = np.random.default_rng(9).normal(0, NOISE, (2000, 30))
    y[:, 2 * k:2 * k + 2] += test.mdb[k] * vec[:, 0]  # along the smaller redundancy
    v = (y - (y @ Q) @ Q.T)[:, 2 * k:2 * k + 2]
    T = np.einsum("da,ab,db->d", v, np.linalg.inv(fit.R[k]), v)
    assert np.mean(T / NOISE ** 2 > chi2.isf(0.01 / 15, 2)) == pytest.approx(1 - BETA, abs=0.03)


def test_the_note_says_when_the_given_sigma_disagrees_with_the_residuals(blunder_scene):
    truth, points = blunder_scene
    cls = get_model("dlt")
    ground, pix, _ = one_set(points, truth["dlt"], 20, 0.0, NOISE, np.random.default_rng(21))
    right = detect_blunders(cls, ground, pix, sigma=NOISE)
    assert "looks too" not in right.note() and "are found with 80 % probability" in right.note()
    assert np.isfinite(right.mdb).sum() >= 18 and (right.mdb[np.isfinite(right.mdb)] > 2 * NOISE).all()
    too_large = detect_blunders(cls, ground, pix, sigma=2.0)
    assert "the σ given looks too large" in too_large.note()
    too_small = detect_blunders(cls, ground, pix, sigma=0.3)
    assert "the σ given looks too small" in too_small.note()


def test_without_sigma_the_mdb_is_larger_than_with_it(blunder_scene):
    """Estimating σ costs power: the F test's MDB exceeds the χ² test's at every point (same σ scale)."""
    truth, points = blunder_scene
    cls = get_model("dlt")
    ground, pix, _ = one_set(points, truth["dlt"], 15, 0.0, NOISE, np.random.default_rng(22))
    given, estimated = detect_blunders(cls, ground, pix, sigma=NOISE), detect_blunders(cls, ground, pix)
    ok = np.isfinite(given.mdb) & np.isfinite(estimated.mdb)
    assert ok.sum() >= 12
    assert (estimated.mdb[ok] / estimated.sigma > given.mdb[ok] / NOISE).all()


@pytest.fixture(scope="module")
def ngi0184(data_dir):
    scene = Scene("ngi:0184")
    return truths(scene.dem, scene.frame), pool(scene.dem, 1500, frame=scene.frame), scene.size


def _rates(scene, n, blunder, seed, trials, sigma=NOISE, name="dlt"):
    truth, points, size = scene
    cls = get_model(name)
    rng = np.random.default_rng(seed)
    anything = alone = able = alone_able = 0
    for _ in range(trials):
        ground, pix, k = one_set(points, truth[name], n, blunder, NOISE, rng, size)
        test = detect_blunders(cls, ground, pix, sigma=sigma)
        hit = flagged(test)
        anything += bool(hit.any())
        if blunder:
            ok = bool(np.nan_to_num(test.mdb[k], nan=np.inf) <= blunder)
            alone += bool(hit[k] and hit.sum() == 1)
            able += ok
            alone_able += ok and bool(hit[k] and hit.sum() == 1)
    return anything / trials, alone / trials, able, alone_able


@pytest.mark.parametrize("n", [8, 15])
def test_held_out_frame_clean_gcps_flag_nothing(ngi0184, n):
    """1 % false alarms per fit by design; at most 1 of 25 here."""
    anything, *_ = _rates(ngi0184, n, 0.0, seed=40 + n, trials=25)
    assert anything <= 1 / 25


def test_held_out_frame_a_5px_blunder_among_15_is_flagged_alone(ngi0184):
    """Flagged alone in most sets, and in most of those where 5 px is at least the point's MDB (the test's
    80 % power there, plus the margin most such points have)."""
    _, alone, able, alone_able = _rates(ngi0184, 15, 5.0, seed=4015, trials=30)
    assert alone >= 0.65
    assert able >= 15 and alone_able / able >= 0.8
