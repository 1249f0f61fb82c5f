"""RPC bias compensation from GCPs: an image-space shift or affine correction of a vendor RPC.

Vendor RPCs of push-broom images are typically off by a few pixels, mostly a constant shift
(attitude and ephemeris bias). With GCPs (ground lon, lat, h and their measured pixels
``m``), the RPC's projections ``p = RPC(lon, lat, h)`` are corrected in image space:

* ``shift``  (≥ 1 GCP):  ``m ≈ p + t``;
* ``affine`` (≥ 3 GCPs): ``m ≈ A p + t``

(Grodecki & Dial 2003). Residuals ``m − p`` are reported before and after; with few GCPs the
"after" residuals at the GCPs themselves flatter the correction, so leave-one-out residuals
(each GCP predicted by the correction fitted without it) are reported too.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..models import Affine
from ..models.stats import rmse
from ..pixels import from_centre
from .rpc import Rpc


@dataclass(frozen=True)
class RpcBias:
    method: str
    shift: np.ndarray  # (2,) col, row: the translation part
    matrix: np.ndarray  # (2, 3) [A | t] mapping projected -> corrected pixels
    before: np.ndarray  # (N, 2) measured − RPC projection
    after: np.ndarray  # (N, 2) measured − corrected projection (fitted on all GCPs)
    leave_one_out: np.ndarray  # (N, 2) measured − correction fitted without the point

    def correct(self, projected) -> np.ndarray:
        p = np.asarray(projected, float)
        return p @ self.matrix[:, :2].T + self.matrix[:, 2]

    def summary(self) -> dict:
        return {"method": self.method, "shift_px": self.shift.tolist(), "matrix": self.matrix.tolist(),
                "rms_before_px": rmse(self.before), "mean_before_px": self.before.mean(axis=0).tolist(),
                "rms_after_px": rmse(self.after),
                "rms_leave_one_out_px": rmse(self.leave_one_out) if np.isfinite(self.leave_one_out).all() else None}


def _fit(method, p, m):
    if method == "shift":
        t = (m - p).mean(axis=0)
        return np.array([[1.0, 0.0, t[0]], [0.0, 1.0, t[1]]])
    return Affine.estimate(p, m).world_matrix()[:2]


def estimate_bias(rpc: Rpc, lonlath, pixels, method: str = "shift") -> RpcBias:
    """Fit the image-space correction of ``rpc`` from GCPs (lon, lat, h) ↔ pixels (corner convention)."""
    if method not in ("shift", "affine"):
        raise InputError(f"method must be 'shift' or 'affine'; got {method!r}")
    g = np.asarray(lonlath, float).reshape(-1, 3)
    m = np.asarray(pixels, float).reshape(-1, 2)
    need = 1 if method == "shift" else 3
    if len(g) < need or len(g) != len(m) or not (np.isfinite(g).all() and np.isfinite(m).all()):
        raise InputError(f"{method} bias compensation needs at least {need} GCPs with finite ground and pixel "
                         f"coordinates; got {len(g)}")
    p = from_centre(rpc.project(g[:, 0], g[:, 1], g[:, 2]))  # RPC00B pixels are centre-based
    M = _fit(method, p, m)
    after = m - (p @ M[:, :2].T + M[:, 2])
    loo = np.full_like(m, np.nan)
    if len(g) > need:
        for i in range(len(g)):
            keep = np.arange(len(g)) != i
            Mi = _fit(method, p[keep], m[keep])
            loo[i] = m[i] - (p[i] @ Mi[:, :2].T + Mi[:, 2])
    return RpcBias(method, M[:, 2].copy(), M, m - p, after, loo)
