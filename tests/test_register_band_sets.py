"""Sub-pixel registration across band sets: LSM on one image's bands combined to match the other's fusion
(fotogeo.image.band_match, fotogeo.tools.register.bands), measured on known warps of real images with other
band counts (tests/known_warps.py BAND_SETS); the re-match of a weak first match, and its later RANSAC hypotheses
when the correlation gate refuses the first."""
import warnings
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
import rasterio

from fotogeo.errors import MatchingError
from fotogeo.image.band_match import combined_fusion, fit_combination
from fotogeo.image.fusion import pca_fuse
from fotogeo.models import Projective, ransac
from fotogeo.tools.register import bands as bands_mod
from fotogeo.tools.register.tool import register
from known_warps import known_warp_bands


class _Shift:
    """A pure translation as the homography (reference px -> other px)."""

    def __init__(self, d):
        self.d = np.asarray(d, float)

    def forward(self, xy):
        return np.asarray(xy, float) + self.d

    def inverse(self, xy):
        return np.asarray(xy, float) - self.d


def test_the_combination_of_bands_that_predicts_the_other_image_is_found(rng):
    base = rng.normal(100, 30, (3, 120, 130))
    bands = np.concatenate([base, [255 - base[1]], [0.5 * base[0] + 0.5 * base[2]]])  # collinear extras
    other_img = np.clip(0.6 * base[0] + 0.3 * base[1] + 0.1 * base[2] + 10, 0, 255)
    other = pca_fuse(other_img[None])
    other = other.__class__(**{**other.__dict__, "image": np.roll(other_img, (3, 2), axis=(0, 1)).astype(np.float32)})
    own = pca_fuse(bands)
    comb = fit_combination(bands, own.mask, own, _Shift((2, 3)).forward, other)
    assert comb.correlation > 0.999 and comb.better
    fu = combined_fusion(bands, own.mask, own, comb)
    inner = np.s_[5:-5, 5:-5]
    assert np.allclose(fu.image[inner], np.clip(other_img, 0, 255)[inner], atol=0.05)
    # full-resolution windows are fused as (v·(b − μ) − lo)·255/(hi − lo): the same image
    lo, hi = fu.stretch
    pc = np.tensordot(fu.component, bands - fu.mean[:, None, None], axes=1)
    assert np.allclose(np.clip((pc - lo) * 255 / (hi - lo), 0, 255)[inner], fu.image[inner], atol=1e-3)


@pytest.mark.parametrize("image, band_set", [("landsat", "ref8_tgt3"), ("s2", "ref4_tgt1")])
def test_default_is_sub_pixel_and_beats_sift_across_band_sets(data_dir, tmp_path, image, band_set):
    ref, tgt, grid, truth = known_warp_bands(data_dir, image, "r30_s0.85_p", band_set, tmp_path)
    with rasterio.open(ref) as ds:
        px = abs(ds.transform.a)
    err = {}
    for method, opts in (("default", {}), ("sift", dict(detector="sift", refine="none"))):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = register(ref, tgt, tmp_path / f"{method}.tif", overwrite=True, seed=0, **opts)
        err[method] = float(np.sqrt(np.mean(np.hypot(*(r.model.forward(grid) - truth).T) ** 2))) / px
        if method == "default":
            bands = r.report["lsm"]["bands"]
    assert err["default"] <= 0.05 and err["default"] <= err["sift"], err
    if band_set == "ref8_tgt3":
        assert bands["combined"] == "reference" and bands["correlation_combined"] > bands["correlation_pca"]


def _nir_only(data_dir, tmp_path, warp):
    """``(result, dense RMSE in reference px)`` of registering the s2 NIR-only target of ``warp`` to RGB."""
    ref, tgt, grid, truth = known_warp_bands(data_dir, "s2", warp, "ref3_tgtN", tmp_path)
    with rasterio.open(ref) as ds:
        px = abs(ds.transform.a)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = register(ref, tgt, tmp_path / "out.tif", seed=0)
    return r, float(np.sqrt(np.mean(np.hypot(*(r.model.forward(grid) - truth).T) ** 2))) / px


def test_a_nir_only_target_is_matched_again_on_the_reference_bands_combined(data_dir, tmp_path):
    """RGB reference, NIR-only target (s2, r45_s1.2_p; not a case of benchmarks/register_bands_bench.py): on
    the PCA fusions SURF keeps 11 inliers and the windows on R against NIR 8 reliable of 64, so it was refused;
    the 11 inliers' rough homography fits the RGB combination that looks like the NIR (smoothed), SURF on it
    keeps hundreds and LSM makes it sub-pixel."""
    r, dense_px = _nir_only(data_dir, tmp_path, "r45_s1.2_p")
    again = r.report["bands_rematched"]
    assert again["kept"] and again["combined"] == "reference" and again["inliers_after"] > 10 * again["inliers_before"]
    assert again["correlation_combined"] > 0.9 > again["correlation_pca"]
    assert dense_px <= 0.05


def test_a_weak_feature_fit_the_windows_cannot_confirm_is_refused(data_dir, tmp_path):
    """RGB reference limited to R (``reference_bands``), NIR-only target (s2, r30_s0.85_p): nothing to combine;
    SIFT keeps 12 inliers whose fit's standard error at the corners is 3.1 px and the windows on R against NIR
    find 7 reliable of 64: refused, none written (such a fit of 9 SURF inliers was written 5.0 px off)."""
    ref, tgt, _, _ = known_warp_bands(data_dir, "s2", "r30_s0.85_p", "ref3_tgtN", tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(MatchingError,
                           match="the feature fit of 12 inliers .* is not confirmed, so none is written") as e:
            register(ref, tgt, tmp_path / "out.tif", seed=0, reference_bands="1", detector="sift", refine="none")
    message = str(e.value)
    assert message.endswith("--no-area-fallback") and "--window" not in message
    assert "reference band 1, target band 1: try other bands first in --reference-bands/--target-bands" in message
    assert not (tmp_path / "out.tif").exists()


def _unrelated_scene(seed, shape=(400, 400)):
    """Three smooth random bands of one scene (the reviewer's /tmp/s21-review/r4_bands_gate.py)."""
    r = np.random.default_rng(seed)
    base = cv2.GaussianBlur(r.random(shape).astype(np.float32), (0, 0), 4)
    return np.stack([np.clip(128 + 600 * (base - base.mean()) * r.uniform(0.5, 1.5) + r.normal(0, 5, shape), 0, 255)
                     for _ in range(3)]).astype(np.float32)


class _Rigid:
    """A rotation + shift as the (wrong) rough homography, reference -> target pixels."""

    def __init__(self, a, dx, dy):
        self.M = np.array([[np.cos(a), -np.sin(a), dx], [np.sin(a), np.cos(a), dy]])

    def forward(self, xy):
        return np.asarray(xy, float) @ self.M[:, :2].T + self.M[:, 2]

    def inverse(self, xy):
        return (np.asarray(xy, float) - self.M[:, 2]) @ np.linalg.inv(self.M[:, :2]).T


def test_unrelated_scenes_under_a_wrong_rough_homography_are_not_combined_for_a_rematch(monkeypatch):
    """An RGB reference and a one-band target of unrelated scenes, 20 random wrong rough homographies: the
    combination "correlated better" than PCA 17 times of 20 at correlations <= 0.09 and was re-matched on; it must
    clear REMATCH_MIN_CORRELATION, so none is (each refusal named in the report)."""
    ref, tgt = _unrelated_scene(1), _unrelated_scene(2)[:1]
    fu_ref, fu_tgt = pca_fuse(ref), pca_fuse(tgt)
    monkeypatch.setattr(bands_mod, "_bands", lambda info, role, opts: info)
    rng = np.random.default_rng(0)
    for _ in range(20):
        H = _Rigid(rng.uniform(-0.3, 0.3), *rng.uniform(-50, 50, 2))
        side, new, report = bands_mod.combined_for_matching((ref, tgt), None, fu_ref, fu_tgt, H)
        assert new is None and "correlate" in report["refused"], report
        assert report["correlation_combined"] < bands_mod.REMATCH_MIN_CORRELATION


@pytest.mark.parametrize("n1, off_px, refused", [(7, 0.5, "7 inliers after the re-match, 20 needed"),
                                                    (30, 0.5, None), (30, 40.0, "differs from the first match's")])
def test_a_rematch_is_kept_only_with_enough_inliers_and_the_rough_alignment(monkeypatch, n1, off_px, refused):
    """The first match keeps 6 inliers; a re-match of 7 was kept (one more than 6); now it needs max(2·6, 20)
    inliers and a homography within REMATCH_AGREE_PX of the rough one at the first match's inliers."""
    fused = tuple(pca_fuse(_unrelated_scene(s)) for s in (1, 2))
    rough, other = _Shift((3, 4)), _Shift((3 + off_px, 4))
    first = (rough, 6, np.array([[10.0, 20.0], [300.0, 50.0]]))
    monkeypatch.setattr(bands_mod, "_hypotheses", lambda *a: iter([first]))
    monkeypatch.setattr(bands_mod, "_inliers", lambda *a: (other, n1, None))
    monkeypatch.setattr(bands_mod, "combined_for_matching",
                        lambda infos, opts, fu_ref, fu_tgt, H: ("reference", fu_ref, {"combined": "reference"}))
    monkeypatch.setattr(bands_mod, "detect", lambda *a, **k: "new keypoints")
    monkeypatch.setattr(bands_mod, "match_keypoints", lambda *a: np.zeros((40, 2)))
    opts = SimpleNamespace(contrast="linear", detector="surf", max_keypoints=None, hessian_threshold=None)
    out = bands_mod.rematch(None, opts, fused, ("kp_ref", "kp_tgt"), "first matches")
    report = out[-1]
    assert report["inliers_before"] == 6 and report["inliers_after"] == n1
    if refused:
        assert out[:-1] == (*fused, "kp_ref", "kp_tgt", "first matches")
        assert report["kept"] is False and refused in report["refused"]
    else:
        assert out[2] == "new keypoints" and report["kept"] is True and report["disagreement_px"] == 0.5


def test_a_nir_only_target_whose_first_hypothesis_is_wrong_is_matched_from_a_later_one(data_dir, tmp_path):
    """RGB reference, NIR-only target (s2, r30_s0.85_p): SURF keeps 6 homography inliers of 48 matches, a
    consensus of true and wrong matches whose homography is tens of pixels off; the combination through it does
    not correlate, so it was refused. A later hypothesis of the same RANSAC fits one that does."""
    r, dense_px = _nir_only(data_dir, tmp_path, "r30_s0.85_p")
    again = r.report["bands_rematched"]
    tries = again["hypotheses"]
    assert again["kept"] and len(tries) >= 2 and tries[-1]["kept"], again
    assert all("correlate" in t["refused"] for t in tries[:-1])
    assert tries[0]["inliers"] == again["inliers_before"]
    assert tries[-1]["correlation_combined"] >= bands_mod.REMATCH_MIN_CORRELATION > tries[0]["correlation_combined"]
    assert dense_px <= 0.05


def test_later_hypotheses_are_the_same_ransac_drawing_on(rng):
    """The first hypothesis is RANSAC's on the seed, as before; the later ones are other consensus sets."""
    src = rng.uniform(0, 500, (60, 2))
    dst = src + rng.normal(0, 40, src.shape)  # mostly wrong matches: weak consensus sets
    dst[:6] = src[:6] + (3.0, -2.0)
    kp_ref, kp_tgt = SimpleNamespace(xy=src), SimpleNamespace(xy=dst)
    m = SimpleNamespace(pairs=np.stack([np.arange(60), np.arange(60)], axis=1))
    opts = SimpleNamespace(ransac_threshold=3.0, seed=7)
    hyps = list(bands_mod._hypotheses(kp_ref, kp_tgt, m, opts))
    first = ransac(Projective, src, dst, 3.0, rng=7)
    assert np.allclose(hyps[0][0].forward(src), first.model.forward(src)) and hyps[0][1] == first.inliers.sum()
    assert 2 <= len(hyps) <= bands_mod.REMATCH_TRIES
    sets = [tuple(map(tuple, at)) for _, _, at in hyps]
    assert len(set(sets)) == len(sets)


def _setup(monkeypatch, hyps, accept, n1=60, off_px=0.5):
    """rematch with the first match's hypotheses ``hyps`` ((H, n, at) each), the correlation gate accepting the
    homographies in ``accept``, and a re-match of ``n1`` inliers ``off_px`` from the accepted hypothesis;
    ``(fusions, rematch's result, [(H, len(at)) the re-match was checked against])``."""
    fused = tuple(pca_fuse(_unrelated_scene(s, (60, 60))) for s in (1, 2))
    gated, seen = [], []

    def gate(infos, opts, fu_ref, fu_tgt, H):
        gated.append(H)
        c = 0.9 if H in accept else 0.2
        report = {"combined": "reference", "correlation_combined": c}
        if H in accept:
            return "reference", fu_ref, report
        return None, None, {**report, "refused": f"the combined bands correlate {c:.2f} with the other image"}

    def disagreement(H0, H1, xy):
        seen.append((H0, len(xy)))
        return float(np.median(np.hypot(*(H1.forward(xy) - H0.forward(xy)).T)))

    monkeypatch.setattr(bands_mod, "_hypotheses", lambda *a: iter(hyps))
    monkeypatch.setattr(bands_mod, "combined_for_matching", gate)
    monkeypatch.setattr(bands_mod, "detect", lambda *a, **k: "new keypoints")
    monkeypatch.setattr(bands_mod, "match_keypoints", lambda *a: np.zeros((80, 2)))
    monkeypatch.setattr(bands_mod, "_inliers", lambda *a: (_Shift(gated[-1].d + (off_px, 0)), n1, None))
    monkeypatch.setattr(bands_mod, "_disagreement", disagreement)
    opts = SimpleNamespace(contrast="linear", detector="surf", max_keypoints=None, hessian_threshold=None)
    return fused, bands_mod.rematch(None, opts, fused, ("kp_ref", "kp_tgt"), "first matches"), seen


def test_the_rematch_is_checked_against_the_hypothesis_the_gate_accepted(monkeypatch):
    wrong, right = _Shift((40, -30)), _Shift((3, 4))
    at_wrong, at_right = np.array([[10.0, 20.0]] * 6), np.array([[100.0, 50.0], [300.0, 200.0]] * 4)
    fused, out, seen = _setup(monkeypatch, [(wrong, 6, at_wrong), (right, 8, at_right)], [right])
    report = out[-1]
    assert report["kept"] is True and out[2] == "new keypoints"
    assert [t["inliers"] for t in report["hypotheses"]] == [6, 8] and "refused" in report["hypotheses"][0]
    assert seen == [(right, 8)] and report["inliers_before"] == 6


def test_a_later_hypothesis_needs_twice_its_own_inliers(monkeypatch):
    """The inlier gate is never looser than for the first hypothesis: twice the larger consensus."""
    wrong, right = _Shift((40, -30)), _Shift((3, 4))
    at = np.array([[100.0, 50.0]] * 14)
    fused, out, _ = _setup(monkeypatch, [(wrong, 6, at[:6]), (right, 14, at)], [right], n1=25)
    assert out[-1]["kept"] is False and "25 inliers after the re-match, 28 needed" in out[-1]["refused"]
    assert out[:-1] == (*fused, "kp_ref", "kp_tgt", "first matches")


def test_every_hypothesis_refused_is_named_in_the_refusal(monkeypatch):
    hyps = [(_Shift((40 * k, 0)), n, np.zeros((n, 2))) for k, n in ((1, 6), (2, 6), (3, 5))]
    fused, out, seen = _setup(monkeypatch, hyps, [])
    report = out[-1]
    assert report["kept"] is False and not seen and out[:-1] == (*fused, "kp_ref", "kp_tgt", "first matches")
    assert report["refused"].startswith("the combined bands correlate 0.20")
    assert ("so did the 2 next RANSAC hypotheses of the first match (6 inliers: 0.2, 5 inliers: 0.2)"
            in report["refused"])
    assert [t["inliers"] for t in report["hypotheses"]] == [6, 6, 5]
