"""Coarse pre-alignment of unreferenced targets: the Fourier–Mellin similarity (fotogeo.coreg.similarity) on
arrays, and ``register`` of rotated, scaled two-date chips without georeference (tests/rotated_pairs.py)."""
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
import rasterio

from fotogeo.coreg.similarity import estimate_similarity, similarity_matrix
from fotogeo.errors import MatchingError
from fotogeo.pixels import pixel_to_map
from fotogeo.tools.register.local import MAX_CORNER_SE_PX, corner_standard_error
from fotogeo.tools.register.tool import register
from rotated_pairs import apply, make_case


def _grey(path):
    with rasterio.open(path) as ds:
        a = ds.read().astype(np.float32)
        nodata = ds.nodata
    g = a.mean(axis=0)
    if nodata is not None:
        g[(a == nodata).all(axis=0)] = np.nan
    return g


@pytest.fixture(scope="module")
def cases(data_dir, tmp_path_factory):
    folder = tmp_path_factory.mktemp("rotated")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {name: make_case(data_dir, name, folder) for name in
                ("landsat_r25_s1.1", "s2_r200_s0.85", "landsat_r40_s1.2_inverted", "s2pair_r-140_s0.9",
                 "s2pair_r-100_s0.8")}


def test_similarity_matrix_is_rotation_then_scale():
    M = similarity_matrix(2.0, 90.0, (5.0, 1.0))
    assert np.allclose(M[:2] @ [1.0, 0.0, 1.0], [5.0, 3.0])


@pytest.mark.parametrize("name, angle", [("landsat_r25_s1.1", 25.0), ("s2_r200_s0.85", -160.0)])
def test_fourier_mellin_finds_rotation_scale_and_offset_of_a_chip(cases, name, angle):
    """A chip of another radiometry, any rotation (200° needs the 180° ambiguity resolved), anywhere in the scene."""
    ref, tgt, H, check = cases[name]
    s = estimate_similarity(_grey(ref), _grey(tgt))
    assert abs(((s.angle - angle + 180) % 360) - 180) < 0.3
    assert s.scale == pytest.approx(np.sqrt(abs(np.linalg.det(H[:2, :2]))), rel=0.01)
    err = np.hypot(*(s.apply(check) - apply(H, check)).T)
    assert np.sqrt(np.mean(err ** 2)) < 1.0 and s.confidence > 10


def test_fourier_mellin_refuses_unrelated_images(cases):
    ref, _, _, _ = cases["landsat_r25_s1.1"]
    _, tgt, _, _ = cases["s2_r200_s0.85"]
    with pytest.raises(MatchingError, match=r"no rotation/scale/offset of the target matches the reference "
                                            r"\(Fourier–Mellin: best peak ratio 1\.\d+ < 3"):
        estimate_similarity(_grey(ref), _grey(tgt))


def _register(ref, tgt, out, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return register(ref, tgt, out, overwrite=True, seed=0, **options)


def _check_rmse(r, ref, H, check) -> float:
    with rasterio.open(ref) as ds:
        t = ds.transform
    err = np.hypot(*(r.model.forward(check) - pixel_to_map(t, apply(H, check))).T) / abs(t.a)
    return float(np.sqrt(np.mean(err ** 2)))


def test_an_inverted_unreferenced_chip_is_pre_aligned_and_registered_by_windows(cases, tmp_path):
    """Contrast inverted, rotated 40°, scaled 1.2, no georeference: SURF fails, Fourier–Mellin + windows register it."""
    ref, tgt, H, check = cases["landsat_r40_s1.2_inverted"]
    r = _register(ref, tgt, tmp_path / "out.tif")
    pre = r.report["area_based"]["pre_alignment"]
    assert pre["confidence_peak_ratio"] > 10 and abs(pre["rotation_deg"] - 40) < 0.5
    assert _check_rmse(r, ref, H, check) < 0.3


def test_a_weak_feature_fit_gives_way_to_the_windows(cases, tmp_path):
    """Real two dates (s2_pair), -140°, clouds: SURF keeps only a handful of (wrong) inliers; the windows win."""
    ref, tgt, H, check = cases["s2pair_r-140_s0.9"]
    r = _register(ref, tgt, tmp_path / "out.tif")
    assert "feature matching kept only" in r.report["area_based"]["why"]
    assert _check_rmse(r, ref, H, check) < 0.5


def test_an_imprecise_feature_fit_of_many_inliers_is_checked_and_beaten_by_the_windows(cases, tmp_path):
    """Two dates (s2_pair), -100°, finer than the reference (0.8), a case no sweep ran: SURF keeps 26 inliers (more
    than 12) whose fit was written 2.57 px RMSE (max 8.7 px) off; its standard error at the chip's corners says
    it is imprecise, the windows seeded from it are run, and their fit is kept, closer to their check points."""
    ref, tgt, H, check = cases["s2pair_r-100_s0.8"]
    r = _register(ref, tgt, tmp_path / "out.tif")
    a = r.report["area_based"]
    assert "is imprecise: standard error" in a["why"] and a["pre_alignment"]["method"].startswith("the feature fit")
    c = a["compared"]
    assert c["kept"] == "windows" and c["windows_fit_rmse_px"] < c["feature_fit_rmse_px"]
    assert c["feature_fit_corner_se_px"] > MAX_CORNER_SE_PX
    assert _check_rmse(r, ref, H, check) < 0.5


def test_the_corner_standard_error_grows_with_clustered_points_and_scatter():
    """σ0·sqrt(1/n + (c − x̄)ᵀS⁻¹(c − x̄)) at the worst corner: points spread over the image vs the same
    points squeezed into its centre, and twice the residuals."""
    rng = np.random.default_rng(0)
    src = rng.uniform(0, 400, (30, 2))
    res = rng.normal(0, 0.5, (30, 2))

    def se(xy, r):
        gf = SimpleNamespace(role=np.array(["control"] * 30), residual_m=r, z=None)
        return corner_standard_error(gf, SimpleNamespace(src=xy), 1.0, 400, 400)
    spread = se(src, res)
    assert se(200 + (src - 200) / 4, res) > 3 * spread and se(src, 2 * res) == pytest.approx(2 * spread)
    s0 = np.sqrt(np.sum(res ** 2) / 54)
    assert s0 * np.sqrt(1 / 30) < spread < s0


def test_unrelated_unreferenced_images_are_refused_not_registered(cases, tmp_path):
    ref, _, _, _ = cases["s2_r200_s0.85"]
    _, tgt, _, _ = cases["landsat_r25_s1.1"]
    with pytest.raises(MatchingError, match="the target has no georeference and no rotation/scale/offset"):
        _register(ref, tgt, tmp_path / "out.tif", hessian_threshold=1e9)
    assert not (tmp_path / "out.tif").exists()
