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


#: control points each correction needs
MIN_GCPS = {"shift": 1, "affine": 3}


def estimate_bias(rpc: Rpc, lonlath, pixels, method: str = "shift") -> RpcBias:
    """Fit the image-space correction of ``rpc`` from GCPs (lon, lat, h) ↔ pixels (corner convention)."""
    if method not in ("shift", "affine"):
        raise InputError(f"method must be 'shift' or 'affine'; got {method!r}")
    g = np.asarray(lonlath, float).reshape(-1, 3)
    m = np.asarray(pixels, float).reshape(-1, 2)
    need = MIN_GCPS[method]
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


def corrected_rpc(rpc: Rpc, bias: RpcBias, *, grid: int = 11, levels: int = 5) -> tuple[Rpc, float]:
    """The vendor ``rpc`` with the image-space ``bias`` correction built in, as RPC00B, and the
    largest deviation (px) of the returned RPC from ``correction(rpc)`` over its ground volume.

    A shift is exact: ``sample = SAMP_OFF + SAMP_SCALE·N/D``, so ``t`` adds to ``SAMP_OFF`` and
    ``LINE_OFF`` (deviation 0). An affinity mixes sample and line, whose denominators differ in
    general, so the corrected mapping is refitted: a ``grid`` x ``grid`` x ``levels`` lattice
    over the RPC's normalised ground volume (offset ± scale in lon, lat, h) is projected through
    ``rpc`` and the correction, and a ground → image RFM is fitted to it
    (:func:`~fotogeo.orientation.rpc.fit_rpc`); the deviation is measured on a second, staggered
    lattice.
    """
    from dataclasses import replace

    if bias.method == "shift":
        return replace(rpc, samp_off=rpc.samp_off + bias.shift[0], line_off=rpc.line_off + bias.shift[1]), 0.0
    from .rpc import fit_rpc

    def lattice(n, k, stagger=0.0):
        u = (np.arange(n) + stagger) / (n - 1) * 2 - 1
        v = np.linspace(-1, 1, k)
        L, P, H = (a.ravel() for a in np.meshgrid(u, u, v, indexing="ij"))
        return np.column_stack([rpc.long_off + rpc.long_scale * L, rpc.lat_off + rpc.lat_scale * P,
                                rpc.height_off + rpc.height_scale * H])

    def target(g):
        return bias.correct(from_centre(rpc.project(g[:, 0], g[:, 1], g[:, 2])))

    g = lattice(grid, levels)
    new, _ = fit_rpc(g, target(g), "EPSG:4326")
    t = lattice(grid - 1, levels, stagger=0.5)
    t = t[np.all(np.abs(t[:, :2] - [rpc.long_off, rpc.lat_off]) <= [rpc.long_scale, rpc.lat_scale], axis=1)]
    dev = np.hypot(*(from_centre(new.project(t[:, 0], t[:, 1], t[:, 2])) - target(t)).T)
    return new, float(dev.max())
