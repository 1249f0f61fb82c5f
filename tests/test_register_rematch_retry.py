"""The band re-match of a weak first match tries RANSAC's next hypotheses when the correlation gate refuses the
first one (fotogeo.tools.register.bands, module docstring): the same RANSAC drawing on from the same seeded
generator, each hypothesis through the same gate."""
import warnings
from types import SimpleNamespace

import numpy as np
import rasterio

from fotogeo.image.fusion import pca_fuse
from fotogeo.models import Projective, ransac
from fotogeo.tools.register import bands as bands_mod
from fotogeo.tools.register.tool import register
from known_warps import known_warp_bands


def test_a_nir_only_target_whose_first_hypothesis_is_wrong_is_matched_from_a_later_one(data_dir, tmp_path):
    """RGB reference, NIR-only target (s2, r30_s0.85_p): SURF keeps 6 homography inliers of 48 matches, a
    consensus of true and wrong matches whose homography is tens of pixels off; the combination through it does
    not correlate, so it was refused. A later hypothesis of the same RANSAC fits one that does."""
    ref, tgt, grid, truth = known_warp_bands(data_dir, "s2", "r30_s0.85_p", "ref3_tgtN", tmp_path)
    with rasterio.open(ref) as ds:
        px = abs(ds.transform.a)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = register(ref, tgt, tmp_path / "out.tif", seed=0)
    again = r.report["bands_rematched"]
    tries = again["hypotheses"]
    assert again["kept"] and len(tries) >= 2 and tries[-1]["kept"], again
    assert all("correlate" in t["refused"] for t in tries[:-1])
    assert tries[0]["inliers"] == again["inliers_before"]
    assert tries[-1]["correlation_combined"] >= bands_mod.REMATCH_MIN_CORRELATION > tries[0]["correlation_combined"]
    assert np.sqrt(np.mean(np.hypot(*(r.model.forward(grid) - truth).T) ** 2)) / px <= 0.05


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


class _Shift:
    def __init__(self, d):
        self.d = np.asarray(d, float)

    def forward(self, xy):
        return np.asarray(xy, float) + self.d

    def inverse(self, xy):
        return np.asarray(xy, float) - self.d


def _scene(seed):
    r = np.random.default_rng(seed)
    return r.uniform(0, 255, (3, 60, 60)).astype(np.float32)


def _setup(monkeypatch, hyps, accept, n1=60, off_px=0.5):
    """rematch with the first match's hypotheses ``hyps`` ((H, n, at) each), the correlation gate accepting the
    homographies in ``accept``, and a re-match of ``n1`` inliers ``off_px`` from the accepted hypothesis;
    ``(fusions, rematch's result, [(H, len(at)) the re-match was checked against])``."""
    fused = tuple(pca_fuse(_scene(s)) for s in (1, 2))
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
    assert "so did the 2 next RANSAC hypotheses of the first match (6 inliers: 0.2, 5 inliers: 0.2)" in report["refused"]
    assert [t["inliers"] for t in report["hypotheses"]] == [6, 6, 5]
