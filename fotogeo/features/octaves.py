"""One keypoint per blob across SURF's octaves (Gaussian-derivative layers).

Octave o of :mod:`fotogeo.features.hessian` filters a copy of the image already smoothed to
sigma ``b_o`` (:func:`octave_blur`), and a Gaussian layer of scale s there measures the image at
the total scale sqrt(s^2 + b_o^2) while normalising by s^4 (Lindeberg 1998): a Gaussian blob of
sigma b then peaks near s^2 = b^2 + b_o^2, at a larger s the coarser the octave. The scale cut
between octaves (sizes, not blurs) thus lets one blob be a maximum in two adjacent octaves, and
the ratio test would reject both copies. :func:`drop_duplicates` removes the copy: a keypoint of
octave o + 1 and one of octave o are the same blob when they lie within one sample of octave
o + 1 (2^(o+1) px; 1 px for octave 0 against the fine octave -1), have the same Laplacian sign
and their scales agree once mapped to the blob's own scale,

    b^2 = s^2 - b_o^2,       | ln(b_coarse / b_fine) | < ln(:data:`SCALE_RATIO`),

and the one with the smaller det(H) response is dropped (the finer on ties).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: Largest ratio of the two copies' blob scales b (above) still taken as one blob.
SCALE_RATIO = 1.3


def octave_blur(octave, presmooth: float, octave_blur: float, fine_presmooth: float):
    """Sigma (image pixels) of the smoothing already in octave ``octave``'s image: the larger of
    ``presmooth`` and ``octave_blur * 2^o`` for o >= 0 (:func:`hessian.octave_integrals`), and
    ``fine_presmooth`` for the fine octave -1 (the doubled image, :mod:`fotogeo.features.fine`)."""
    o = np.asarray(octave, np.int64)
    usual = np.maximum(presmooth, octave_blur * np.exp2(np.maximum(o, 0)))
    return np.where(o < 0, fine_presmooth, usual)


def drop_duplicates(kp: dict, scale: np.ndarray, blur: np.ndarray) -> np.ndarray:
    """Boolean mask over the detections ``kp`` (dict of ``x``, ``y``, ``response``, ``laplacian``,
    ``octave`` arrays) keeping one of every cross-octave pair of copies of a blob (module doc).
    ``scale``: each detection's SURF scale s; ``blur``: its octave's :func:`octave_blur`."""
    n = len(kp["x"])
    keep = np.ones(n, bool)
    if n < 2:
        return keep
    xy = np.column_stack([kp["x"], kp["y"]])
    octave = np.asarray(kp["octave"], np.int64)
    b = np.sqrt(np.maximum(scale ** 2 - blur ** 2, 1e-6))
    resp = np.asarray(kp["response"], float)
    for o in np.unique(octave)[1:]:
        fi, ci = np.nonzero((octave == o - 1) & keep)[0], np.nonzero(octave == o)[0]
        if not len(fi) or not len(ci):
            continue
        radius = float(2 ** max(o, 0))                  # one sample of the coarser octave
        pairs = cKDTree(xy[fi]).sparse_distance_matrix(cKDTree(xy[ci]), radius, output_type="ndarray")
        f, c = fi[pairs["i"]], ci[pairs["j"]]
        same = (kp["laplacian"][f] == kp["laplacian"][c]) & (np.abs(np.log(b[c] / b[f])) < np.log(SCALE_RATIO))
        f, c = f[same], c[same]
        coarse_wins = resp[c] > resp[f]
        keep[f[coarse_wins]] = False
        keep[c[~coarse_wins]] = False
    return keep
