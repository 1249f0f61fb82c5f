"""The band re-match (fotogeo.tools.register.bands.rematch) on keypoints from the feature cache, as
``triangulate``'s tie pairs match them: the same re-match as without the cache (issue 32)."""
import warnings

import numpy as np

from fotogeo.io.raster import open_raster
from fotogeo.options import RegisterOptions
from fotogeo.tools.register import bands as bands_mod
from fotogeo.tools.register.match import FeatureCache, find_tie_points
from known_warps import known_warp_bands


def test_cached_keypoints_of_an_rgb_and_a_nir_only_image_are_matched_again_as_without_the_cache(data_dir, tmp_path):
    """RGB reference, NIR-only target (s2, r45_s1.2_p): without the cache the first match keeps 11 homography
    inliers and the re-match hundreds; with it (the keypoints only, no images) the match stayed at the first one."""
    ref, tgt, _, _ = known_warp_bands(data_dir, "s2", "r45_s1.2_p", "ref3_tgtN", tmp_path)
    infos, opts = (open_raster(ref, "reference"), open_raster(tgt, "target")), RegisterOptions(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0, r0, plain = find_tie_points(*infos, opts)
        cache = FeatureCache()
        t1, r1, cached = find_tie_points(*infos, opts, cache=cache)
    again = cached.get("bands_rematched")
    assert again is not None and again["kept"], cached
    assert again == plain["bands_rematched"] and cached["matches"] == plain["matches"]
    np.testing.assert_array_equal(t1, t0)
    np.testing.assert_array_equal(r1, r0)
    assert len(cache) == 2  # the cache keeps the first detections; the re-match's keypoints are the pair's own


class _Fusion:
    def __init__(self, n):
        self.bands = tuple(range(1, n + 1))


def test_the_images_are_read_for_a_rematch_only_when_the_cached_match_is_weak(monkeypatch):
    """The fusions are a callable on the cached path: not called when the first match has enough inliers (or
    both sides have one band, or as many bands: one camera's frames), called when it is weak."""
    calls = []

    def fused():
        calls.append(1)
        return _Fusion(3), _Fusion(1)

    class Info:
        def __init__(self, count):
            self.count = count

    opts = RegisterOptions()
    monkeypatch.setattr(bands_mod, "combined_for_matching", lambda *a: None)
    for n0, counts, read in ((bands_mod.REMATCH_BELOW, (3, 1), False), (5, (1, 1), False), (5, (3, 3), False),
                             (5, (3, 1), True), (5, (3, 4), True)):
        monkeypatch.setattr(bands_mod, "_hypotheses", lambda *a, n0=n0: iter([("H", n0, None)]))
        calls.clear()
        out = bands_mod.rematch((Info(counts[0]), Info(counts[1])), opts, fused, ("kp_ref", "kp_tgt"), "m")
        assert bool(calls) is read and out[2:] == ("kp_ref", "kp_tgt", "m", None)
        assert (out[0] is None) is not read
