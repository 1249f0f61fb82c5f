"""One image's bands combined to look like another image's fused band (precise matching across band sets).

PCA fusion (:mod:`fotogeo.image.fusion`) gives each image its own first component: an RGB target's
is about the brightness, an 8-band reference's may be dominated by a near-infrared band, so the two
fused images differ by more than the gain and offset least-squares matching models, and LSM is less
precise. Once the images are approximately aligned (``q = h(p)``, reference pixel ``p`` -> target
pixel ``q``), the bands ``b_k`` of one image are combined to predict the other's fused grey values
``f`` by least squares over a grid of valid pixels,

    f(h(p)) ≈ c + Σ_k w_k · b_k(p),

(bands standardised, nearly collinear directions left out: a minimum-norm solution),
with one refit after dropping the pixels whose residual exceeds 3 robust σ (clouds, changes). The
combination is then the image that side is matched on: its bands correspond to the other image's
fusion as well as any linear combination can. It is used only when its correlation with ``f`` beats
the PCA fusion's by :data:`MIN_GAIN`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from .fusion import Fusion

#: at most this many pixels enter the fit (a regular grid)
MAX_SAMPLES = 40_000
#: the combination replaces the PCA fusion when its correlation with the other image is higher by this
MIN_GAIN = 0.005
#: singular values of the standardised bands below this fraction of the largest are left out (bands
#: that are linear combinations of others get a minimum-norm share of the weight)
RCOND = 1e-3


@dataclass(frozen=True)
class Combination:
    """``weights`` (B,) per band (0 for bands left out), ``offset`` c, correlations of the PCA fusion
    and of the combination with the other image's fused values, ``n`` pixels fitted."""

    weights: np.ndarray
    offset: float
    correlation_pca: float
    correlation: float
    n: int

    @property
    def better(self) -> bool:
        return bool(self.correlation >= self.correlation_pca + MIN_GAIN)


def _samples(valid: np.ndarray, to_other, other: Fusion):
    """Grid pixels of this image (centres, corner convention) valid here and, through ``to_other``,
    inside the other image's valid area; their positions and the other image's bilinear values there."""
    h, w = valid.shape
    step = max(1, int(np.sqrt(h * w / MAX_SAMPLES)))
    r, c = np.mgrid[step // 2:h:step, step // 2:w:step]
    r, c = r.ravel(), c.ravel()
    keep = valid[r, c]
    r, c = r[keep], c[keep]
    q = to_other(np.column_stack([c + 0.5, r + 0.5])) - 0.5  # pixel-centre coordinates of the other image
    img = np.where(other.mask, other.image, np.nan).astype(np.float32)
    n = len(q)
    rows = -(-n // 256)  # OpenCV's maps: fewer than 32767 columns
    m = np.full((2, rows * 256), -1e6, np.float32)
    m[:, :n] = q.T
    f = cv2.remap(img, m[0].reshape(rows, 256), m[1].reshape(rows, 256), cv2.INTER_LINEAR,
                  borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan).ravel()[:n]
    ok = np.isfinite(f)
    return r[ok], c[ok], f[ok].astype(np.float64)


def fit_combination(bands: np.ndarray, valid: np.ndarray, own: Fusion, to_other, other: Fusion) -> Combination | None:
    """The least-squares combination of ``bands`` (B, rows, cols; valid where ``valid``) predicting
    ``other``'s fused image at ``to_other(p)`` (module docstring); ``own`` is these bands' PCA fusion
    (its bands left out stay out). None when fewer than 100 pixels overlap."""
    r, c, f = _samples(valid, to_other, other)
    if len(f) < 100:
        return None
    use = np.zeros(len(bands), bool)
    use[np.flatnonzero(own.component != 0)] = True
    X = bands[:, r, c][use].astype(np.float64).T
    mu, sd = X.mean(axis=0), X.std(axis=0) + 1e-12
    A = np.column_stack([(X - mu) / sd, np.ones(len(f))])  # standardised: collinear bands share the weight
    keep = np.ones(len(f), bool)
    for _ in range(2):
        coef, *_ = np.linalg.lstsq(A[keep], f[keep], rcond=RCOND)
        res = f - A @ coef
        s = 1.4826 * np.median(np.abs(res[keep] - np.median(res[keep]))) + 1e-9
        keep = np.abs(res) <= 3 * s
    pred = A[keep] @ coef
    coef = np.append(coef[:-1] / sd, coef[-1] - float((coef[:-1] / sd) @ mu))  # back to the bands' own units
    w = np.zeros(len(bands))
    w[use] = coef[:-1]
    own_v = own.image[r, c][keep].astype(np.float64)
    return Combination(w, float(coef[-1]), _corr(own_v, f[keep]), _corr(pred, f[keep]), int(keep.sum()))


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    if a.std() == 0 or b.std() == 0:
        return 0.0
    return float(np.corrcoef(a, b)[0, 1])


def combined_fusion(bands: np.ndarray, valid: np.ndarray, own: Fusion, comb: Combination) -> Fusion:
    """``own`` with its image replaced by ``clip(c + Σ w_k b_k, 0, 255)`` and its component, mean and
    stretch set so that ``(v·(b − μ) − lo)·255/(hi − lo)`` (how full-resolution windows are fused)
    gives the same values: ``v = w/|w|``, ``hi − lo = 255/|w|``, ``lo = −(c + w·μ)/|w|``."""
    w = comb.weights
    norm = float(np.linalg.norm(w))
    mean = own.mean if own.mean is not None else np.zeros(len(w))
    img = np.tensordot(w, bands.astype(np.float64), axes=1) + comb.offset
    img = np.where(valid, np.clip(img, 0, 255), 0).astype(np.float32)
    lo = -(comb.offset + float(w @ mean)) / norm
    return replace(own, image=img, component=w / norm, stretch=(lo, lo + 255.0 / norm))
