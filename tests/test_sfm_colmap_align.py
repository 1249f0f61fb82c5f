"""A COLMAP model in its own frame aligned to the images' GPS (fotogeo.io.colmap_align, fotogeo.geometry.similarity3d):
the similarity, its precision, one blunder left out, and the refusals of an ill-determined or contradicted alignment.
The full block: tests/test_sfm_projects.py."""
from __future__ import annotations

import re

import numpy as np
import pytest
from pyproj import Transformer
from scipy.spatial.transform import Rotation

from fotogeo.crs import parse_crs
from fotogeo.errors import InputError
from fotogeo.geometry.similarity3d import fit_similarity, robust_similarity, similarity_precision
from fotogeo.io.colmap_align import align_to_gps
from fotogeo.io.sfm_frame import GpsFix

CRS = "EPSG:32633"
Q = Rotation.from_euler("zyx", [37.0, 10.0, -5.0], degrees=True).as_matrix()


def _block(centres, sigma, rng, blunder=None, warp=0.0):
    """Images ``[(name, cid, C_model, R)]`` of a model ``0.05·Q·(C − C0)`` and their GPS (σ ``sigma``)."""
    C0 = np.array([500000.0, 6650000.0, 300.0])
    to_ll = Transformer.from_crs(CRS, 4326, always_xy=True)
    images, gps = [], {}
    for k, c in enumerate(centres):
        name = f"IMG_{k:02d}"
        cm = 0.05 * Q @ (c - C0) + warp * np.array([0.0, 0.0, ((c - C0)[0] / 50.0) ** 2])
        images.append((name + ".JPG", "1", cm, np.eye(3) @ Q.T))
        noisy = c + rng.normal(0, 1, 3) * [sigma, sigma, 1.5 * sigma]
        if blunder is not None and k == blunder[0]:
            noisy = noisy + blunder[1]
        lon, lat = to_ll.transform(noisy[0], noisy[1])
        gps[name] = GpsFix(lon, lat, noisy[2], sigma, True, 1.5 * sigma)
    return images, gps


def _grid(n=3, m=3, step=30.0):
    return np.array([[500000.0 + i * step, 6650000.0 + j * step, 380.0] for i in range(n) for j in range(m)])


def test_umeyama_recovers_an_exact_similarity():
    rng = np.random.default_rng(1)
    x = rng.normal(0, 10, (6, 3))
    y = 3.5 * x @ Q.T + [1.0, 2.0, 3.0]
    sim = fit_similarity(x, y)
    assert sim.scale == pytest.approx(3.5) and np.allclose(sim.rotation, Q) and np.allclose(sim.apply(x), y)


def test_alignment_of_rtk_gps_lands_within_centimetres():
    truth = _grid()
    images, gps = _block(truth, 0.02, np.random.default_rng(2))
    out, said, _ = align_to_gps(images, gps, parse_crs(CRS), "model")
    err = np.array([o[2] for o in out]) - truth
    assert np.abs(err).max() < 0.08 and "9 images" in said and "expected error" in said
    assert all(np.allclose(o[3], np.eye(3), atol=3e-3) for o in out)  # R·Qᵀ undoes the model's rotation


def test_consumer_gps_aligns_with_a_warning_of_the_expected_error():
    """σ 2 m over a 120 m block: aligned, but warned with the expected error (not an accurate georeference)."""
    from fotogeo.errors import FotogeoWarning
    truth = _grid(4, 4, step=40.0)
    images, gps = _block(truth, 2.0, np.random.default_rng(8))
    with pytest.warns(FotogeoWarning, match=r"aligned to the images' GPS only: expected error ≈ [0-9.]+ m"):
        out, said, _ = align_to_gps(images, gps, parse_crs(CRS), "model")
    err = np.linalg.norm((np.array([o[2] for o in out]) - truth)[:, :2], axis=1)
    assert 0.05 < np.median(err) < 4.0 and "expected error of the cameras ±" in said


def test_one_bad_fix_is_left_out_and_named():
    truth = _grid()
    images, gps = _block(truth, 0.02, np.random.default_rng(3), blunder=(4, np.array([25.0, 0.0, 0.0])))
    out, said, _ = align_to_gps(images, gps, parse_crs(CRS), "model")
    assert "IMG_04's GPS left out" in said
    assert np.abs(np.array([o[2] for o in out]) - truth).max() < 0.08


def test_centres_on_a_line_are_refused():
    line = np.array([[500000.0 + 20 * k, 6650000.0 + 10 * k, 380.0] for k in range(6)])
    images, gps = _block(line, 0.02, np.random.default_rng(4))
    with pytest.raises(InputError, match="lie on a line .condition number.*model_aligner.*--crs"):
        align_to_gps(images, gps, parse_crs(CRS), "model")


def test_residuals_far_beyond_the_gps_sigma_are_refused():
    """A model bent (not rigid) by metres against an RTK σ of 2 cm: no similarity fits; refused, not aligned."""
    images, gps = _block(_grid(4, 3), 0.02, np.random.default_rng(5), warp=0.1)
    with pytest.raises(InputError, match="more than 3 x their σ.*model_aligner"):
        align_to_gps(images, gps, parse_crs(CRS), "model")


def test_a_tilt_the_gps_cannot_determine_is_refused():
    """Consumer GPS (σ 5 m, 7.5 m vertically) on a 20 m block: the tilt is known to tens of degrees; refused."""
    images, gps = _block(_grid(step=10.0), 5.0, np.random.default_rng(7))
    with pytest.raises(InputError, match="determines its tilt only to ±[0-9.]+°.*--crs"):
        align_to_gps(images, gps, parse_crs(CRS), "model")


def test_fewer_than_three_gps_images_do_not_align():
    images, gps = _block(_grid(), 0.02, np.random.default_rng(6))
    assert align_to_gps(images, dict(list(gps.items())[:2]), parse_crs(CRS), "model") is None


def test_precision_shrinks_with_the_gps_sigma_and_is_infinite_on_a_line():
    x = _grid()
    sim = fit_similarity(x, x)
    p1 = similarity_precision(sim, x, np.full((9, 3), 2.0))
    p2 = similarity_precision(sim, x, np.full((9, 3), 0.02))
    assert p1.horizontal == pytest.approx(100 * p2.horizontal) and p1.tilt_deg > 0 and p1.condition < 1e3
    line = similarity_precision(sim, x[::4], np.full((3, 3), 0.02))
    assert line.tilt_deg == np.inf and line.condition > 1e12
    fit = robust_similarity(x, x + 0.01, np.full((9, 3), 0.02))
    assert fit.left_out is None and fit.chi2_dof < 1


def _corridor():
    """Two strips 40 m apart, 1.5 km long, 120 images: a thin block (shape ratio 0.046), not a line."""
    return np.array([[500000.0 + x, 6650000.0 + y, 380.0] for y in (0.0, 40.0) for x in np.arange(0, 1500, 25.0)])


def test_the_tilt_sigma_does_not_depend_on_where_the_points_are():
    """The precision linearised about the model frame's origin lost the tilt to rounding with map coordinates
    (~1e5 m): on main 0.00024° at 1e5 m against 0.00524° about the centroid (20 x too optimistic)."""
    c = _corridor() - _corridor().mean(axis=0)
    tilt = [similarity_precision(fit_similarity(c + o, c + o), c + o, np.full((120, 3), 0.02)).tilt_deg
            for o in (0.0, 1e3, 1e5, 6e6)]
    assert tilt[0] == pytest.approx(0.005236, rel=1e-3) and np.allclose(tilt, tilt[0], rtol=1e-6)


def test_a_corridor_of_two_rtk_strips_is_aligned_not_refused_as_a_line():
    """main refused it by the shape ratio alone (0.046 < 0.05) although its RTK GPS (σ 2 cm, 3 cm vertically) fixes
    the tilt to ±0.013°."""
    truth = _corridor()
    images, gps = _block(truth, 0.02, np.random.default_rng(2))
    out, said, _ = align_to_gps(images, gps, parse_crs(CRS), "model")
    assert np.abs(np.array([o[2] for o in out]) - truth).max() < 0.02 and re.search(r"tilt ±0\.01\d°", said)


def test_images_without_gps_altitude_are_refused_not_put_at_height_0():
    """lat/lon without GPSAltitude: main took the altitude as 0 and landed the cameras at Z ≈ 0 (truth 380 m) with
    only a warning of ≈ 1 m; refused naming the images (heights and tilt are not invented)."""
    from dataclasses import replace
    images, gps = _block(_grid(4, 4, step=40.0), 2.0, np.random.default_rng(8))
    gps = {k: replace(g, alt=None, tagged=False, sigma_v=None) for k, g in gps.items()}
    with pytest.raises(InputError, match=r"16 of its 16 images with GPS carry latitude and longitude but no GPS "
                                         r"altitude \(IMG_00, IMG_01, IMG_02, ...\).*model_aligner"):
        align_to_gps(images, gps, parse_crs(CRS), "model")


def test_images_without_gps_altitude_among_others_are_left_out_and_named():
    from dataclasses import replace
    truth = _grid(4, 4)
    images, gps = _block(truth, 0.02, np.random.default_rng(9))
    gps["IMG_05"] = replace(gps["IMG_05"], alt=None, sigma_v=None)
    out, said, _ = align_to_gps(images, gps, parse_crs(CRS), "model")
    assert "15 images" in said and "1 image(s) without GPS altitude left out (IMG_05)" in said
    assert np.abs(np.array([o[2] for o in out]) - truth).max() < 0.08


def test_the_heights_reference_is_the_gps_fixes_common_one():
    from dataclasses import replace
    images, gps = _block(_grid(), 0.02, np.random.default_rng(2))
    ell = {k: replace(g, height_reference="ellipsoid") for k, g in gps.items()}
    out, said, ref = align_to_gps(images, ell, parse_crs(CRS), "model")
    assert ref == "ellipsoid" and "heights are the GPS altitudes' (above the ellipsoid" in said
    mixed = dict(ell, IMG_00=gps["IMG_00"])
    assert align_to_gps(images, mixed, parse_crs(CRS), "model")[2] is None
