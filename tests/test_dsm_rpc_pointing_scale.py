"""The relative pointing correction's consensus in the tie points' own scale (review of issue 30's change): tie
points of a large image are found on an overview averaged over k x k blocks (k = ⌈longer side / TIE_SIDE⌉) and
multiplied back, so their scatter is k times SIFT's (NMAD 0.28 px on the ventoux pair, k = 1). A fixed 3 px
consensus then kept a chance subset of them or refused the pair: now ``3·k`` px (:func:`agreement_px`).

The pair here: a 20 000 px scene (k = 14), RPC-like models with nearly parallel epipolar curves (a satellite
pair: 200 px long, fanning by up to 1°), the right image off by ``TAU`` px; the tie points scattered by σ 8 px in
source pixels (what 0.57 overview pixels make at k = 14) among false ones off by up to ±300 px."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from fotogeo.errors import InputError
from fotogeo.tools.dsm import rpc_pairs

SIDE, TAU, ZLO, ZHI = 20000, np.array([0.0, 5.0]), 0.0, 400.0


class _Left:
    def inverse(self, p, z):
        return np.column_stack([p, np.broadcast_to(z, len(p))])


class _Right:
    def forward(self, P):
        return np.column_stack([P[:, 0] + 0.5 * P[:, 2], P[:, 1] + 8.7e-7 * P[:, 0] * P[:, 2]])


def _pointing(monkeypatch, n_true, n_false, sigma=8.0, seed=0, spread=300.0):
    """``pointing`` of the pair above, its tie points given on overviews of the 20 000 px images."""
    rng = np.random.default_rng(seed)
    n = n_true + n_false
    p1 = rng.uniform(0, SIDE, (n, 2))
    z = rng.uniform(ZLO, ZHI, n)
    p2 = _Right().forward(_Left().inverse(p1, z)) + TAU + rng.normal(0, sigma, (n, 2))
    p2[n_true:] += rng.uniform(-spread, spread, (n_false, 2))
    k = -(-SIDE // rpc_pairs.TIE_SIDE)
    s = SIDE / (SIDE // k)  # the overview's pixel size in source pixels (``overview``)
    monkeypatch.setattr(rpc_pairs, "overview", lambda src: (None, (s, s)))
    monkeypatch.setattr(rpc_pairs, "tie_points", lambda g1, g2: (p1 / s, p2 / s))
    sources = [SimpleNamespace(path=f"/in/{name}.tif", width=SIDE, height=SIDE) for name in ("left", "right")]
    return rpc_pairs.pointing(_Left(), _Right(), sources, ZLO, ZHI), s


@pytest.mark.parametrize("n_true, n_false, seed", [(40, 20, 0), (15, 5, 1), (200, 50, 2)])
def test_large_images_tie_points_agree_in_their_own_scale(monkeypatch, n_true, n_false, seed):
    """The correction across the (nearly parallel) lines within three standard errors (3·σ/√n) of the truth,
    every true tie but one kept."""
    got, s = _pointing(monkeypatch, n_true, n_false, seed=seed)
    assert s > 13
    assert abs(got["tau"][1] - TAU[1]) < 3 * 8.0 / np.sqrt(n_true), got["tau"]
    assert got["n"] >= n_true - 1, got["n"]


def test_too_few_agreeing_names_the_threshold_in_the_tie_points_scale(monkeypatch):
    """6 true ties among 40 false ones off by up to ±3000 px (a thin overlap): refused, saying within how many
    pixels (3 px times the overview's 14)."""
    with pytest.raises(InputError, match=r"^images 'left' and 'right': only \d of their 46 tie points agree on one "
                                         r"relative pointing correction \(within 42 px; 10 needed\)") as info:
        _pointing(monkeypatch, 6, 40, seed=3, spread=3000.0)
    assert "\n" not in str(info.value)


def test_too_few_tie_points_names_the_images(monkeypatch):
    with pytest.raises(InputError, match=r"^images 'left' and 'right': only 6 tie points between them: they may not "
                                         r"overlap"):
        _pointing(monkeypatch, 6, 0)


def test_the_refit_trims_to_the_ties_scatter_not_to_the_consensus_threshold():
    """100 ties of σ 8 px among 100 false ones within ±300 px, the consensus at 42 px (k = 14): the refit keeps the
    ties within 3·1.4826·MAD (about 24 px) of τ, not every false one within 42 px; τ within 3·σ/√100 of the
    truth. With the refit's floor at the consensus threshold (before): a false tie 39.5 px off kept."""
    from fotogeo.stereo.affine_epipolar import curve_offsets, pointing_correction
    rng = np.random.default_rng(4)
    p1 = rng.uniform(0, SIDE, (200, 2))
    q_lo, q_hi = (_Right().forward(_Left().inverse(p1, z)) for z in (ZLO, ZHI))
    z = rng.uniform(ZLO, ZHI, 200)
    p2 = _Right().forward(_Left().inverse(p1, z)) + TAU + rng.normal(0, 8.0, (200, 2))
    p2[100:] += rng.uniform(-300, 300, (100, 2))
    tau, inl, _ = pointing_correction(p2, q_lo, q_hi, threshold=42.0)
    off_truth = np.abs(curve_offsets(p2 - TAU, q_lo, q_hi)[0])
    assert abs(tau[1] - TAU[1]) < 3 * 8.0 / 10, tau
    assert inl[:100].sum() >= 97 and off_truth[inl].max() < 30.0, (inl[:100].sum(), off_truth[inl].max())
