"""Windows for least-squares matching chosen by their texture, independent of the feature detector.

When the matched keypoints are fewer than the LSM budget (:func:`fotogeo.tools.register.points.lsm_budget`),
the reference's corners of strongest texture (Shi & Tomasi 1994: the smaller eigenvalue of the gradient
structure tensor, the conditioning of the LSM shift estimate, Förstner 1986) top them up, spread by a
minimum distance, away from the image border and from the keypoints already refined. Their target positions
are the approximate homography's prediction; LSM refines them like the keypoints.
"""
from __future__ import annotations

import numpy as np

#: Shi-Tomasi quality level: corners weaker than this share of the strongest are not taken
QUALITY = 0.01


def texture_points(image: np.ndarray, taken: np.ndarray, count: int, half_window: int) -> np.ndarray:
    """At most ``count`` reference positions (k, 2; pixel-corner convention, centres of pixels) of strong
    texture in ``image`` (NaN invalid), each window of half size ``half_window`` wholly valid, at least a
    window's width from one another and from the ``taken`` (m, 2) positions.

    >>> img = np.zeros((60, 60), np.float32); img[20:40, 20:40] = 1.0
    >>> texture_points(img, np.empty((0, 2)), 10, 3).shape
    (4, 2)
    """
    import cv2
    if count <= 0:
        return np.empty((0, 2))
    valid = np.isfinite(image)
    size = 2 * half_window + 3
    inner = cv2.erode(valid.astype(np.uint8), np.ones((size, size), np.uint8), borderValue=0)
    img = np.where(valid, image, 0.0).astype(np.float32)
    dist = 2 * half_window + 1
    for xy in np.asarray(taken, float).reshape(-1, 2):
        cv2.circle(inner, (int(xy[0]), int(xy[1])), dist, 0, -1)
    if not inner.any():
        return np.empty((0, 2))
    found = cv2.goodFeaturesToTrack(img, maxCorners=int(count), qualityLevel=QUALITY, minDistance=dist,
                                    mask=inner, blockSize=2 * half_window + 1)
    if found is None:
        return np.empty((0, 2))
    return found.reshape(-1, 2).astype(float) + 0.5
