"""σ0 per observation group: the group whose a-priori σ is wrong is named, never hidden in a global σ0.

The global σ0 mixes the image points (thousands of redundant observations) with the GPS positions (a few): GPS
positions 3 m off given a σ of 0.5 m leave σ0 ≈ 1 — a confident, wrong block. Per group
(``statistics.variance_components``, :mod:`fotogeo.orientation.bundle_variance`) their σ0 is several times 1 and
the console names them and the flag to fix. The opposite case — tie points weighted with a σ three times too
small (least-squares matching's formal σ) — drives σ0 to ≈ 3 while the GPS and the attitude priors fit theirs:
the console says it is the image points and what σ they measure. Simulated blocks with known truth (seconds).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.orientation.bundle_variance import dominant_group
from fotogeo.tools.triangulate.outputs import variance_lines
from test_triangulate import CAMERA as SMALL_CAMERA
from test_triangulate import write_block

CAMERA = FrameCamera(5.0, (4.0, 6.0), (400, 600))


@pytest.fixture(scope="module")
def sb():
    return simulate_block(seed=11, strips=2, frames_per_strip=5, camera=CAMERA, point_spacing=40.0, margin=3.0,
                          blunder_fraction=0.0, n_check=5)


def _gps(sb, noise: float, seed: int, *, image_sigma=None, free_control=True):
    """``sb``'s block started from GPS positions with ``noise`` m of error per axis (true attitude), no control
    unless ``free_control`` is False, the image points given ``image_sigma`` px when set."""
    rng = np.random.default_rng(seed)
    eo = tuple(dataclasses.replace(e, X=e.X + rng.normal(0, noise), Y=e.Y + rng.normal(0, noise),
                                   Z=e.Z + rng.normal(0, noise)) for e in sb.true_eo)
    b = sb.block
    role = np.where(b.role == "control", "check", b.role) if free_control else b.role
    sigma = b.obs_sigma if image_sigma is None else np.full(len(b.obs_frame), image_sigma)
    return dataclasses.replace(b, eo=eo, role=role, obs_sigma=sigma)


def _adjust(block, position_sigma, angle_sigma=np.inf):
    sigma = np.tile([position_sigma] * 3 + [angle_sigma] * 3, (len(block.frames), 1))
    return adjust_block(block, BundleOptions(snooping=False, eo_sigma=sigma))


def test_the_groups_share_the_redundancy_and_fit_when_their_sigma_is_right(sb):
    result = _adjust(_gps(sb, 0.5, 1), 0.5, 5.0)
    groups = result.stats["variance_components"]
    assert set(groups) == {"image", "position_prior", "attitude_prior"}
    assert sum(g["redundancy"] for g in groups.values()) == pytest.approx(result.stats["redundancy"], rel=1e-3)
    assert 0.85 < groups["image"]["sigma0"] < 1.15  # the simulation's 0.3 px noise, given as 0.3 px
    assert groups["position_prior"]["sigma0"] < 1.8 and groups["position_prior"]["redundancy"] > 5
    assert dominant_group(groups) is None
    assert not any("driven by" in line for line in variance_lines({"statistics": result.stats, "sigma0": 1.0}))


@pytest.mark.parametrize("seed", [2, 3])
def test_gps_far_off_its_sigma_is_named_though_the_global_sigma0_looks_right(sb, seed):
    block = _gps(sb, 3.0, seed)
    result = _adjust(block, 0.5)
    st = result.stats
    err = np.array([[a.X - t.X, a.Y - t.Y, a.Z - t.Z] for a, t in zip(result.eo, sb.true_eo)])
    assert np.sqrt(np.mean(err ** 2)) > 1.0  # the wrong answer: metres off, each frame σ < 0.5 m
    assert st["sigma0"] < 1.3  # the global σ0 does not show it
    assert st["variance_components"]["position_prior"]["sigma0"] > 3.0  # its own group does
    assert dominant_group(st["variance_components"]) == "position_prior"
    lines = variance_lines({"statistics": st, "sigma0": st["sigma0"]})
    assert "sigma0 is driven by the GPS positions" in lines[1] and "--eo-sigma-position" in lines[1]


def test_image_points_weighted_too_strongly_get_their_sigma_estimated(sb):
    """Tie points given 0.1 px for 0.3 px of noise: their σ is estimated (variance component) and the block
    adjusted with it — the σ of what the images hold and of what a prior holds as with the right σ given, where
    the global σ0 of 3 scaled the prior-held ones three times too wide."""
    right = _adjust(_gps(sb, 0.5, 4), 0.5, 5.0)
    result = _adjust(_gps(sb, 0.5, 4, image_sigma=0.1), 0.5, 5.0)
    image = result.stats["variance_components"]["image"]
    assert 2.5 < image["sigma0_given"] < 3.5 and image["factor"] == pytest.approx(image["sigma0_given"], rel=0.05)
    assert image["sigma0"] == pytest.approx(1.0, abs=0.05) and 0.25 < image["a_priori_px"] < 0.35
    assert result.stats["sigma0"] == pytest.approx(1.0, abs=0.1)
    assert np.allclose(result.eo_sigma, right.eo_sigma, rtol=0.15)  # positions, and the angles the images hold
    assert "not checked" not in right.stats["variance_components"]  # sanity: the reference fits its σ
    assert "factor" not in right.stats["variance_components"]["image"]  # nothing estimated where σ was right
    lines = variance_lines({"statistics": result.stats, "sigma0": result.stats["sigma0"]})
    assert "image points' sigma estimated from their residuals: 0.1 px given" in lines[1], lines
    assert f"weighted as {image['a_priori_px']:.3g} px instead" in lines[1]


def test_a_strip_held_by_its_attitude_prior_is_not_inflated_by_the_images_sigma0():
    """A single 3-frame strip (the eBee case): its roll rests on a 5° attitude prior. Tie points given a σ three
    times too small once inflated that angle σ threefold; estimated, it matches the one with the right σ."""
    strip = simulate_block(seed=13, strips=1, frames_per_strip=3, camera=CAMERA, point_spacing=40.0, margin=3.0,
                           blunder_fraction=0.0, n_check=0, n_control=0)
    right = _adjust(_gps(strip, 2.0, 7), 2.0, 5.0)
    small = _adjust(_gps(strip, 2.0, 7, image_sigma=0.1), 2.0, 5.0)
    held = np.nanmax(right.eo_sigma[:, 3:])
    assert held > 0.5  # the prior holds it (the strip does not)
    assert np.nanmax(small.eo_sigma[:, 3:]) == pytest.approx(held, rel=0.15)


def test_a_group_the_images_cannot_check_says_so(sb):
    """GPS σ of centimetres on a block without control: the images cannot tell the positions' error from the
    attitudes' (its redundancy is below 1) — 'not checked', never a σ0 read off nothing."""
    st = _adjust(_gps(sb, 3.0, 5), 0.02).stats
    assert st["variance_components"]["position_prior"]["redundancy"] < 1.0
    line = variance_lines({"statistics": st, "sigma0": st["sigma0"]})[0]
    assert "GPS positions not checked by the other observations" in line


def test_the_console_names_the_group(tmp_path):
    sb = simulate_block(seed=12, strips=2, frames_per_strip=5, camera=SMALL_CAMERA, point_spacing=50.0, margin=3.0,
                        blunder_fraction=0.0, n_check=8)
    frames, _ = write_block(tmp_path, dataclasses.replace(sb, block=_gps(sb, 3.0, 6)))
    res = CliRunner().invoke(main, ["triangulate", *map(str, frames), "--camera", str(tmp_path / "camera.yaml"),
                                    "--eo", str(tmp_path / "eo.txt"), "--observations", str(tmp_path / "tie.csv"),
                                    "--image-sigma", "0.3", "--eo-sigma-position", "0.5", "--crs", "EPSG:32635", "-o",
                                    str(tmp_path / "out"), "-q"], terminal_width=200)
    assert res.exit_code == 0, res.output + res.stderr
    said = [line for line in res.stdout.splitlines() if line.startswith("sigma0 ")]
    assert said[0].startswith("sigma0 by observation group: image points ")
    assert "sigma0 is driven by the GPS positions" in said[1] and "--eo-sigma-position" in said[1], res.stdout


def test_the_estimate_can_be_turned_off_and_then_the_global_rule_scales_every_sigma(sb):
    """``estimate_image_sigma=False``: σ0 ≈ 3 scales every σ by 3 (the global rule of
    :func:`fotogeo.orientation.bundle_result.covariance_scale`), nothing estimated."""
    block = _gps(sb, 0.5, 4, image_sigma=0.1)
    sigma = np.tile([0.5] * 3 + [5.0] * 3, (len(block.frames), 1))
    off = adjust_block(block, BundleOptions(snooping=False, eo_sigma=sigma, estimate_image_sigma=False))
    assert 2.5 < off.sigma0 < 3.5 and off.stats["covariance_scale"] == off.sigma0
    assert "factor" not in off.stats["variance_components"]["image"]
    assert "driven by the image points" in variance_lines({"statistics": off.stats, "sigma0": off.sigma0})[1]


@pytest.mark.parametrize("given, warned", [((0.02, 0.03), True), ((0.5, 0.5), False)])
def test_control_whose_sigma_the_block_cannot_check_is_warned_about(given, warned):
    """GCPs 0.5 m off under a 1.7 m GSD: given 3 cm, their redundancy is near 0 — no residual can show the σ too
    small and every frame's σ rests on it (e/σ 1.67, ``benchmarks/triangulate_sigma_bench.py``): warned, in
    report.json's ``sigma_warnings`` and on the console, naming the options. Given the 0.5 m they are off, the
    images check them: no warning. Main: no such warning."""
    from fotogeo.tools.triangulate.outputs import unchecked_lines
    sb = simulate_block(seed=9, strips=2, frames_per_strip=4, camera=FrameCamera(6.0, (4.0, 6.0), (400, 600)),
                        point_spacing=80.0, margin=5.0, blunder_fraction=0.0, n_control=8, control_sigma=(0.5, 0.5))
    b = sb.block
    sig = np.where((b.role == "control")[:, None], np.array(given)[[0, 0, 1]], b.point_sigma)
    result = adjust_block(dataclasses.replace(b, point_sigma=sig))
    lines = unchecked_lines(result.stats["variance_components"])
    said = [line for line in lines if "control coordinates' given sigma" in line]
    assert bool(said) == warned, lines
    if warned:
        assert "(0.02 m)" in said[0] and "--control-sigma-xy" in said[0]
        assert said[0] in variance_lines({"statistics": result.stats, "sigma0": result.sigma0})
