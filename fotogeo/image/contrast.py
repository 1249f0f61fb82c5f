"""Contrast of a fused 0..255 image for matching: linear, equalised, adaptive (CLAHE).

* ``"linear"`` — the paper's robust stretch between the 1st and 99th percentiles (done by
  :func:`fotogeo.image.fusion.pca_fuse`), kept as is;
* ``"equalize"`` — through the empirical distribution function of the valid pixels
  (``255 · F(pc1)``): monotonic like the linear stretch, but bright clouds, snow or a fill
  value cannot squeeze the land into a few grey levels;
* ``"adaptive"`` (default) — ``equalize`` followed by CLAHE (contrast-limited adaptive
  histogram equalisation, 8x8 tiles, clip limit 2; Zuiderveld 1994), which evens out contrast
  between bright and dark parts of the scene.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..errors import InputError
from ..options import CONTRASTS


def apply_contrast(image: np.ndarray, valid: np.ndarray, contrast: str) -> np.ndarray:
    """Re-map a linearly stretched 0..255 image with ``contrast`` (see the module docstring)."""
    if contrast not in CONTRASTS:
        raise InputError(f"contrast {contrast!r} unknown; choose one of {', '.join(CONTRASTS)}")
    if contrast == "linear":
        return image
    out = _equalize(image, valid)
    if contrast == "adaptive":
        clahe = cv2.createCLAHE(clipLimit=2.0, tileGridSize=(8, 8))
        out = clahe.apply(np.round(out).astype(np.uint8)).astype(np.float32)
        out[~valid] = 0
    return out


def _equalize(img: np.ndarray, valid: np.ndarray, bins: int = 4096) -> np.ndarray:
    """``255 · F(img)`` with ``F`` the empirical distribution of the valid pixels."""
    hist, edges = np.histogram(img[valid], bins=bins, range=(0.0, 255.0))
    cdf = np.cumsum(hist) / max(1, hist.sum())
    out = np.interp(img, edges[1:], 255.0 * cdf).astype(np.float32)
    out[~valid] = 0
    return out
