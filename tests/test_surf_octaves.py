"""SURF with Gaussian layers: one keypoint per blob across octaves (fotogeo.features.octaves).

Octave o's image is smoothed to sigma 2^o before its Gaussian layers, so one blob peaks at a larger
scale s the coarser the octave and used to be found twice near the octaves' scale cut (sigma 2.5 px:
s 2.9 in octave 0 and 3.6 in octave 1).
"""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.features import hessian, octaves, surf
from fotogeo.features.surf import FINE_PRESMOOTH, PRESMOOTH_SIGMA


def _blob(b, n=160, cx=80.3, cy=79.6, amp=200.0):
    """A Gaussian blob of sigma ``b`` px centred at (cx, cy) in the GDAL corner convention."""
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    return (amp * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * b * b))).astype(np.float32)


# blobs near every cut: fine octave / octave 0 (1.0, 1.25), octaves 0 / 1 (2.25-2.75, 3.0),
# 1 / 2 (3.5, 5.5, 5.75), and inside octaves
@pytest.mark.parametrize("b", [1.0, 1.25, 1.6, 2.25, 2.5, 2.75, 3.0, 3.5, 4.5, 5.5, 5.75, 7.0])
@pytest.mark.parametrize("amp", [200.0, -120.0])
def test_an_isolated_blob_gives_one_keypoint_across_octaves(b, amp):
    """Bright and dark blobs of sigma 1-7 px: exactly one keypoint at the centre (within 0.15 px)
    at any detection threshold low enough to see it, with its sign."""
    img = _blob(b, amp=amp) + 30
    for thr in (1.0, 10.0):
        r = surf(img, hessian_threshold=thr, upright=True, gaussian=True)
        assert len(r) == 1, (b, thr, r.xy.tolist(), r.scale.tolist())
        assert np.abs(r.xy[0] - [80.3, 79.6]).max() < 0.15, r.xy
        assert r.laplacian[0] == (-1 if amp > 0 else 1)
        assert 0.8 * b < r.scale[0] < 1.6 * b + 0.5, (b, r.scale)


def test_a_small_blob_beside_a_large_one_stays():
    """The de-duplication joins copies of one blob only: a small blob beside a large one (sigma 1.2
    and 5 px, 14 px apart) gives a keypoint at each centre."""
    img = _blob(5.0, cx=70.0) + _blob(1.2, cx=84.0, amp=150.0)
    r = surf(img, hessian_threshold=1.0, upright=True, gaussian=True)
    assert np.sum(np.abs(r.xy[:, 0] - 70.0) < 1) == 1 and np.sum(np.abs(r.xy[:, 0] - 84.0) < 1) == 1, r.xy


def test_drop_duplicates_keeps_the_stronger_copy():
    """Two copies of a blob in octaves 0 and 1 (0.3 px apart, blob scales within 1.3x): the
    stronger stays; a copy of the other sign, or 2.5 px away, or at twice the blob scale stays too."""
    kp = {"x": np.array([10.0, 10.3, 10.2, 12.5, 10.1]), "y": np.array([5.0, 5.0, 5.1, 5.0, 5.0]),
          "response": np.array([800.0, 500.0, 400.0, 450.0, 420.0]),
          "laplacian": np.array([-1, -1, 1, -1, -1], np.int8), "octave": np.array([0, 1, 1, 1, 1], np.int8)}
    s = np.array([2.9, 3.6, 3.6, 3.6, 6.5])
    blur = octaves.octave_blur(kp["octave"], PRESMOOTH_SIGMA, hessian.OCTAVE_BLUR, FINE_PRESMOOTH)
    assert blur.tolist() == [PRESMOOTH_SIGMA, 2.0, 2.0, 2.0, 2.0]
    keep = octaves.drop_duplicates(kp, s, blur)
    assert keep.tolist() == [True, False, True, True, True]
    kp["response"] = np.array([400.0, 500.0, 400.0, 450.0, 420.0])
    assert octaves.drop_duplicates(kp, s, blur).tolist() == [False, True, True, True, True]


def test_fine_weight_puts_the_fine_copy_level_with_octave_0():
    """A blob both the fine octave and octave 0 see with Gaussian layers (sigma 1.25 px): the fine
    octave's det(H) times fine_weight is 0.85-1.05x octave 0's (measured 0.96x; unweighted 2.1x),
    and the default keeps one keypoint, octave 0's."""
    import cv2

    from fotogeo.features.surf import fine_weight
    img = _blob(1.25, n=96, cx=48.3, cy=47.6)
    plain = surf(img, upright=True, upscale=False, hessian_threshold=1.0, gaussian=True)
    doubled = cv2.resize(img, (192, 192), interpolation=cv2.INTER_LINEAR)
    fine = surf(doubled, upright=True, upscale=False, hessian_threshold=1.0, n_octaves=1, gaussian=True)
    assert len(plain) == 1 and len(fine) == 1
    ratio = fine.response[0] * fine_weight(fine.scale[0] / 2) / plain.response[0]
    assert 0.85 <= ratio <= 1.05, ratio
    both = surf(img, upright=True, hessian_threshold=1.0, gaussian=True)
    assert len(both) == 1 and both.response[0] == pytest.approx(plain.response[0])
