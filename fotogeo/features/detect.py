"""Tie points between two images: keypoints and descriptors, then matching (array layer).

Detectors: ``"surf"`` (fotogeo's own SURF, :func:`fotogeo.features.surf`, default) and
``"sift"`` (OpenCV's SIFT, the strong baseline). Both return keypoint positions in the
GDAL corner convention of :mod:`fotogeo.pixels`.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..options import DETECTORS
from ..pixels import from_centre

SIFT_OFFSET = 0.25

#: ``surf(upscale=...)`` in the registration pipeline: the fine octave (issue 19) is off here.
#: Measured with register() on the NGI pairs (one run each, load ~10 on 2 cores, CPU seconds):
#: frame 0182 -> orthophoto 3.25 -> 4.43 s (1.37x; keypoints 5181 -> 7921, the 8000 budget then
#: nearly full, so matching costs more too), 0184 3.15 -> 4.01 s (1.27x), Sentinel-2 -> orthophoto
#: 3.83 -> 4.44 s (1.16x; check RMSE 6.16 -> 5.89 m), 0182 terrain-aware 2.64 -> 3.98 s (1.51x;
#: dense error 2.43 -> 2.29 m): small gains for up to 1.5x the time.
PIPELINE_FINE_OCTAVE = False

#: ``surf(gaussian=...)`` in the registration pipeline: box filters, although ``surf()`` defaults to
#: the Gaussian layers. Measured through the pipeline both ways (docs/benchmarks/registration.md,
#: "The pipeline's SURF with Gaussian-derivative layers"): the Gaussian layers give more and more
#: accurate tie points and a smaller check error, but a larger dense-grid error of the terrain-aware
#: registration to the orthophoto -- the error against the true geometry, on which the pipeline's
#: accuracy goal is set; the default model choice on one frame then exceeds that goal.
PIPELINE_GAUSSIAN = False


def ignore_specks(mask: np.ndarray | None, max_area: int = 64) -> np.ndarray | None:
    """``mask`` with invalid specks of at most ``max_area`` pixels marked valid again.

    SURF drops a keypoint whose descriptor window touches an invalid pixel, so a few
    scattered nodata pixels inside an image (dropouts, saturated pixels flagged as nodata,
    interpolation specks) would veto most keypoints. Only large nodata areas (collars,
    clouds masked out, image edges) should; the specks keep their fill value.
    """
    if mask is None or mask.all():
        return mask
    inv = (~np.asarray(mask, bool)).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(inv, connectivity=8)
    small = np.zeros(n, bool)
    small[1:] = stats[1:, cv2.CC_STAT_AREA] <= max_area
    return np.asarray(mask, bool) | small[labels]


@dataclass(frozen=True)
class Keypoints:
    xy: np.ndarray  # (N, 2) corner convention
    descriptors: np.ndarray  # (N, D) float32
    laplacian: np.ndarray | None  # (N,) ±1 for SURF, None otherwise

    def __len__(self) -> int:
        return len(self.xy)


def detect(image: np.ndarray, mask: np.ndarray | None, detector: str = "surf", *,
           max_keypoints: int | None = 8000, hessian_threshold: float | None = None,
           upright: bool = False) -> Keypoints:
    """Keypoints and descriptors of a fused 0..255 float image with a validity ``mask``.

    Invalid specks smaller than 64 pixels do not veto keypoints (:func:`ignore_specks`).
    """
    mask = ignore_specks(mask)
    if detector == "surf":
        from . import surf
        kw = {} if hessian_threshold is None else {"hessian_threshold": hessian_threshold}
        r = surf(image, mask, max_keypoints=max_keypoints, upright=upright, upscale=PIPELINE_FINE_OCTAVE,
                 gaussian=PIPELINE_GAUSSIAN, **kw)
        return Keypoints(np.asarray(r.xy, float), np.asarray(r.descriptors, np.float32),
                         np.asarray(r.laplacian))
    if detector == "sift":
        img8 = np.clip(np.nan_to_num(image), 0, 255).astype(np.uint8)
        m8 = None if mask is None else np.asarray(mask, np.uint8) * 255
        sift = cv2.SIFT_create(nfeatures=int(max_keypoints or 0))
        kps, desc = sift.detectAndCompute(img8, m8)
        if not kps:
            return Keypoints(np.zeros((0, 2)), np.zeros((0, 128), np.float32), None)
        # OpenCV's SIFT reports positions SIFT_OFFSET px too far right and down (measured on
        # self-matches of 180°-rotated copies: x1 + x2 = W − 0.5 instead of W)
        xy = from_centre(np.array([k.pt for k in kps], np.float64)) - SIFT_OFFSET
        return Keypoints(xy, desc.astype(np.float32), None)
    raise InputError(f"unknown detector {detector!r}; choose one of: {', '.join(DETECTORS)}")
