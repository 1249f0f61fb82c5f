"""Never wrong in silence (issue 20): every adjusted frame is checked for points, spread and angle σ.

A frame tied by three points fits them exactly whatever its orientation: σ0 and the image RMS stay
small. The tool must refuse such a block (or drop the frame when asked), never report it as a success.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fotogeo.errors import ModelError
from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.orientation.bundle_quality import (frame_quality, position_limits, prior_contradicted_frames,
                                               undetermined_frames)
from fotogeo.tools.triangulate import adjust_determined

CAMERA = FrameCamera(6.0, (4.0, 6.0), (400, 600))
KW = {"min_frame_points": 6, "max_angle_sigma": 0.5, "undetermined": "fail"}


def _starved(sb, frame_index: int, keep_points: int, kappa_error: float = 0.0):
    """``sb``'s block with frame ``frame_index`` reduced to ``keep_points`` tie observations near its centre
    and its approximate κ off by ``kappa_error``°."""
    b = sb.block
    sel = np.flatnonzero((b.obs_frame == frame_index) & (b.role[b.obs_point] == "tie"))
    centre = np.array(CAMERA.image_size) / 2
    sel = sel[np.argsort(np.hypot(*(b.obs_pixel[sel] - centre).T))]
    drop = np.zeros(len(b.obs_frame), bool)
    drop[sel[keep_points:]] = True
    drop |= (b.obs_frame == frame_index) & (b.role[b.obs_point] != "tie")
    eo = list(b.eo)
    eo[frame_index] = dataclasses.replace(eo[frame_index], kappa=eo[frame_index].kappa + kappa_error)
    return dataclasses.replace(b, eo=tuple(eo), obs_frame=b.obs_frame[~drop], obs_point=b.obs_point[~drop],
                               obs_pixel=b.obs_pixel[~drop], obs_sigma=b.obs_sigma[~drop])


@pytest.fixture(scope="module")
def sb():
    return simulate_block(seed=2, strips=2, frames_per_strip=4, camera=CAMERA, point_spacing=40.0, margin=3.0,
                          blunder_fraction=0.0, n_check=5)


def test_a_well_tied_block_passes(sb):
    result = adjust_block(sb.block, BundleOptions(snooping=False))
    q = frame_quality(result, sb.block)
    assert undetermined_frames(q) == {}
    assert (q.points >= 20).all() and (q.spread > 0.3).all() and (q.angle_sigma < 0.1).all()
    assert (q.multi_ray_points > 0).all()


def test_a_frame_tied_by_three_points_is_refused_by_name(sb):
    block = _starved(sb, 5, 3, kappa_error=25.0)
    with pytest.raises(ModelError, match=f"does not determine frame\\(s\\) {sb.block.frames[5]}: 3 points.*"
                                         f"--undetermined drop"):
        adjust_determined(block, BundleOptions(snooping=False), KW, None)


def test_an_undetermined_frame_is_dropped_on_request_and_the_rest_adjusted(sb):
    block = _starved(sb, 5, 3, kappa_error=25.0)
    result, kept, q, dropped, _ = adjust_determined(block, BundleOptions(snooping=False), {**KW, "undetermined": "drop"},
                                                 None)
    assert [d["name"] for d in dropped] == [sb.block.frames[5]]
    assert sb.block.frames[5] not in kept.frames and len(kept.frames) == len(sb.block.frames) - 1
    truth = dict(zip(sb.block.frames, sb.true_eo))
    for name, e in zip(kept.frames, result.eo):
        t = truth[name]
        assert abs((e.kappa - t.kappa + 180) % 360 - 180) < 0.1
        assert np.hypot(e.X - t.X, e.Y - t.Y) < 2 * sb.gsd  # the datum of 8 noisy GCPs


def test_clustered_points_fail_the_spread_test(sb):
    block = _starved(sb, 2, 8)  # 8 points, all near the image centre
    result = adjust_block(block, BundleOptions(snooping=False))
    bad = undetermined_frames(frame_quality(result, block))
    assert sb.block.frames[2] in bad and "cover" in bad[sb.block.frames[2]]


def test_a_frame_without_angle_sigma_is_never_passed_by_its_prior(sb):
    """A NaN angle σ (a singular reduced system; seen on a rendered oblique block with rays meeting at 1.3°)
    fails the frame even when its angles have a prior — it was passed as determined before."""
    result = adjust_block(sb.block, BundleOptions(snooping=False))
    q = frame_quality(result, sb.block)
    sigma = q.angle_sigma.copy()
    sigma[2] = np.nan
    bad = undetermined_frames(dataclasses.replace(q, angle_sigma=sigma), angle_prior=np.ones(len(sigma), bool))
    assert list(bad) == [sb.block.frames[2]] and "no angle σ" in bad[sb.block.frames[2]]


def _held_by_truth(sb, frame_index: int, kappa_error: float, angle_sigma: float = 2.0, shift: float = 0.0,
                   position_sigma: float = np.inf):
    """``sb``'s block started from the true orientations, frame ``frame_index``'s κ off by ``kappa_error``° and its
    X by ``shift`` m, with ``(block, options)`` holding every frame's angles by a prior of ``angle_sigma``° and its
    position by ``position_sigma`` m (free by default)."""
    eo = list(sb.true_eo)
    eo[frame_index] = dataclasses.replace(eo[frame_index], kappa=eo[frame_index].kappa + kappa_error,
                                          X=eo[frame_index].X + shift)
    sigma = np.tile([position_sigma] * 3 + [angle_sigma] * 3, (len(eo), 1))
    return dataclasses.replace(sb.block, eo=tuple(eo)), BundleOptions(snooping=False, eo_sigma=sigma)


def test_a_frame_its_ties_turn_far_from_its_attitude_prior_is_named(sb):
    """The prior test (Baarda's w on the prior's residual): 20° between the adjusted attitude and a 2° prior is
    named; the block whose priors agree with its ties passes it."""
    block, opts = _held_by_truth(sb, 3, 20.0)
    result = adjust_block(block, opts)
    bad = prior_contradicted_frames(result, block, opts.eo_sigma)
    assert list(bad) == [sb.block.frames[3]], bad
    assert "adjusted attitude 20" in bad[sb.block.frames[3]] and "disagree" in bad[sb.block.frames[3]]
    block, opts = _held_by_truth(sb, 3, 0.0)
    assert prior_contradicted_frames(adjust_block(block, opts), block, opts.eo_sigma) == {}


def test_a_frame_whose_attitude_prior_alone_is_contradicted_is_restarted_from_the_block(sb):
    """A wrong attitude tag (20° in κ) under right ties: the frame is re-oriented by resection from the block, its
    attitude prior dropped, and kept — adjusted to the truth — because it then passes every check. It was refused
    before (the prior test cannot tell a wrong tag from wrong ties)."""
    block, opts = _held_by_truth(sb, 3, 20.0)
    result, kept, q, dropped, restarted = adjust_determined(block, opts, KW, None)
    name = sb.block.frames[3]
    assert dropped == [] and [r["name"] for r in restarted] == [name], restarted
    assert "re-oriented by resection" in restarted[0]["reason"] and 19.5 < restarted[0]["prior_offset_deg"] < 20.5
    assert restarted[0]["angle_sigma_in_block_deg"] < KW["max_angle_sigma"]
    truth = dict(zip(sb.block.frames, sb.true_eo))
    for n, e in zip(kept.frames, result.eo):
        assert abs((e.kappa - truth[n].kappa + 180) % 360 - 180) < 0.1, n
    assert np.isfinite(opts.eo_sigma[3, 3:]).all()  # the caller's priors are not changed


def test_a_frame_contradicted_in_position_too_is_refused_or_dropped_alone(sb):
    """Wrong ties pull a frame's centre from its GNSS as well (the rendered oblique block, seed 1): a frame whose
    position is contradicted is never re-started — refused by name, or dropped alone."""
    block, opts = _held_by_truth(sb, 3, 20.0, shift=30.0, position_sigma=1.0)
    with pytest.raises(ModelError, match=f"frame\\(s\\) {sb.block.frames[3]}: adjusted attitude.*adjusted "
                                         f"position.*check their attitude.*--undetermined drop"):
        adjust_determined(block, opts, KW, None)
    result, kept, q, dropped, restarted = adjust_determined(block, opts, {**KW, "undetermined": "drop"}, None)
    assert [d["name"] for d in dropped] == [sb.block.frames[3]] and restarted == []


def _pair_only(sb, j: int, k: int, third_ray_sigma=None):
    """``sb``'s block with frame ``j`` tied only to frame ``k``: its points lose every other ray (its control
    points are gone), except — with ``third_ray_sigma`` (px) — one tie point keeping its other rays at that σ."""
    b = sb.block
    mine = np.unique(b.obs_point[b.obs_frame == j])
    ties = mine[b.role[mine] == "tie"]
    keep = ~np.isin(b.obs_point, mine) | (np.isin(b.obs_point, ties) & np.isin(b.obs_frame, [j, k]))
    sigma = b.obs_sigma.copy()
    if third_ray_sigma is not None:
        third = next(p for p in ties if np.count_nonzero(b.obs_point == p) >= 3)
        other = (b.obs_point == third) & ~np.isin(b.obs_frame, [j, k])
        keep |= other
        sigma[other] = third_ray_sigma
    return dataclasses.replace(b, obs_frame=b.obs_frame[keep], obs_point=b.obs_point[keep],
                               obs_pixel=b.obs_pixel[keep], obs_sigma=sigma[keep])


@pytest.mark.parametrize("third_ray_sigma, shown", [(None, "position σ undetermined"), (50.0, "position σ 8")])
def test_a_frame_whose_pair_scale_is_free_is_refused_by_its_position_sigma(sb, third_ray_sigma, shown):
    """Issue 20: the end frame of a strip whose points have only two rays, its own and its neighbour's — the pair's
    scale is free, the frame slides along the base. Its angles are determined (σ 0.15°, under the 0.5° limit), so
    it passed before: its position σ read 0 m (a negative diagonal of the singular system clipped to 0); with one
    third ray measured to 50 px it reads 81.7 m. The position test (σ ≤ D̄ · tan 0.5°, 9.1 m at 1 040 m) refuses
    it."""
    block = _pair_only(sb, 3, 2, third_ray_sigma)
    result = adjust_block(block, BundleOptions(snooping=False))
    q = frame_quality(result, block)
    assert q.angle_sigma[3] < 0.5 and q.points[3] >= 20 and q.spread[3] > 0.3  # every older test passes
    bad = undetermined_frames(q)
    assert list(bad) == [sb.block.frames[3]] and bad[sb.block.frames[3]].startswith(shown), bad
    assert "× tan 0.5°" in bad[sb.block.frames[3]] and "--eo-sigma-position" in bad[sb.block.frames[3]]
    with pytest.raises(ModelError, match=f"frame\\(s\\) {sb.block.frames[3]}: position σ"):
        adjust_determined(block, BundleOptions(snooping=False), KW, None)


def test_a_gnss_prior_holds_a_position_the_images_do_not(sb):
    """The same frame with GNSS priors (σ 20 m, above the 9.1 m bound) passes: its position is as good as its
    GPS — the eBee frames (tests/test_triangulate_drone.py), σ 15–23 m against bounds of 0.8–1.0 m, are held
    so."""
    block = _pair_only(sb, 3, 2)
    opts = BundleOptions(snooping=False, eo_sigma=(20.0, np.inf))
    result = adjust_block(block, opts)
    q = frame_quality(result, block)
    assert q.position_sigma[3] > position_limits(q)[3]
    assert undetermined_frames(q) != {}
    assert undetermined_frames(q, position_prior=np.ones(8, bool)) == {}
    assert adjust_determined(block, opts, KW, None)[3] == []


def test_the_worst_frame_line_never_prints_nan(monkeypatch, tmp_path):
    """A σ that is not finite ranks the frame worst and reads 'undetermined' (it printed 'nan' and, NaN never
    comparing larger, was not even the frame named)."""
    from click.testing import CliRunner

    import fotogeo.tools.triangulate as package
    from fotogeo.cli import main
    stats = {"n_frames": 2, "n_points": 9, "n_observations": 18, "image_rms_px": 0.1, "n_blunders": 0,
             "check": {}, "control": {}}
    rows = [{"name": "A", "angle_sigma_deg": 0.2, "position_sigma_m": 0.1, "points": 9, "multi_ray_points": 0},
            {"name": "B", "angle_sigma_deg": float("nan"), "position_sigma_m": float("nan"), "points": 9,
             "multi_ray_points": 0}]
    rep = {"statistics": stats, "sigma0": 1.0, "frame_quality": rows, "fixed_parameters": [], "folder": "out"}
    monkeypatch.setattr(package, "triangulate", lambda *a, **k: rep)
    res = CliRunner().invoke(main, ["triangulate", "a.tif", "b.tif", "-o", str(tmp_path / "o"), "-q"])
    assert res.exit_code == 0, res.output
    assert "worst frame B: angle sigma undetermined deg, position sigma undetermined m" in res.output
    assert "nan" not in res.output


def test_a_singular_direction_reads_undetermined_whatever_its_rounding():
    """The inverse of a singular system holds, in the free direction, a diagonal of any sign and size depending on
    the BLAS (0 m clipped here, 5.15e3 km on another machine): its variance inflation S_ii·(S⁻¹)_ii says it."""
    from fotogeo.models.precision import UNDETERMINED_INFLATION, determined_sqrt as _root
    variance = np.array([1e-4, 5.15e6 ** 2, -3.0, 2.0, 0.01])
    inflation = np.array([12.0, 2.7e11, 2.7e11, UNDETERMINED_INFLATION, 2.5e8])  # the last: held by a prior only
    out = _root(variance, inflation)
    assert out[0] == pytest.approx(0.01) and np.isnan(out[1]) and np.isnan(out[2]) and out[3] == pytest.approx(2 ** 0.5)
    assert out[4] == pytest.approx(0.1)


def test_the_report_covariance_is_blank_exactly_where_its_sigma_reads_undetermined(sb):
    """The covariance `ortho --uncertainty` propagates (report.json frames[].covariance) holds, in an undetermined
    direction, the same any-sign-any-size inverse as the σ: its rows and columns read NaN (null in the report)
    where the frame's σ reads undetermined, by the one rule, and the σ raster's cells of that frame are NaN
    instead of a number from the BLAS at hand; the determined frames keep their covariance."""
    import json

    from fotogeo.io.report import _finite
    from fotogeo.orientation.ground_sigma import covariances_from_report, frame_covariance_entry
    block = _pair_only(sb, 3, 2)
    r = adjust_block(block, BundleOptions(snooping=False))
    bad = np.isnan(r.eo_sigma)
    assert bad[3, :3].any() and not bad[[0, 1, 2, 4, 5, 6, 7]].any()
    rep = json.loads(json.dumps(_finite({"fotogeo": "triangulate", "frames": [
        {"name": n, **frame_covariance_entry(r, j)} for j, n in enumerate(block.frames)]})))
    covs = covariances_from_report(rep)
    for j, n in enumerate(block.frames):
        c = covs[n].matrix()
        assert np.array_equal(np.isnan(np.diag(c)), bad[j]), (n, np.diag(c), r.eo_sigma[j])
        assert np.isnan(c[bad[j]]).all() and np.isnan(c[:, bad[j]]).all()
        assert np.isfinite(c[np.ix_(~bad[j], ~bad[j])]).all()
        assert np.allclose(np.sqrt(np.diag(c)[~bad[j]]) * np.r_[1, 1, 1, *[180 / np.pi] * 3][~bad[j]],
                           r.eo_sigma[j][~bad[j]])
