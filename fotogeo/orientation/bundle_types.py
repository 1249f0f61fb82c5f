"""The types both sides of the bundle adjustment share: the point roles and the result object
(:mod:`fotogeo.orientation.bundle` makes it, :mod:`fotogeo.orientation.bundle_result` fills it)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry.camera import FrameCamera

ROLES = ("tie", "control", "check")  # a control point that fails the test becomes "rejected"


@dataclass(frozen=True)
class BundleResult:
    frames: tuple
    roles: np.ndarray  # (P,) final roles: the block's, with "rejected" for control points that failed the test
    eo: tuple  # adjusted ExteriorOrientation per frame, map CRS
    eo_sigma: np.ndarray  # (m, 6): X0, Y0, Z0 (m), rotations about the camera axes (°)
    camera: FrameCamera  # adjusted f and principal point
    distortion: dict  # k1, k2, k3, p1, p2 (and Ebner's b1 … b12 in px when estimated)
    interior_sigma: dict  # σ of the free interior parameters
    point_xyz: np.ndarray  # (P, 3) adjusted, NaN for points dropped
    point_sigma: np.ndarray  # (P, 3)
    point_rays: np.ndarray  # (P,) observations used
    residuals: np.ndarray  # (n, 2) projected − measured, px (NaN where the point was dropped)
    status: np.ndarray  # (n,) "used", "blunder" or "dropped"
    redundancy: np.ndarray  # (n, 2) redundancy numbers (NaN unless used)
    w_test: np.ndarray  # (n,) largest standardised residual (NaN unless used)
    sigma0: float
    stats: dict
    fixed: tuple  # interior parameters held fixed: {parameter, multiple_correlation, partner, ...}
    correlations: tuple  # of the free interior parameters at the end
    blunders: tuple  # {observation, frame, point, w, residual_px, round}; round 0: skipped by the robust phase
    iterations: int
    timings: dict = field(default_factory=dict)
    #: σ₀²·(S⁻¹) blocks (:mod:`fotogeo.orientation.bundle_result`): per frame ``(m, 6, 6)`` in the order
    #: X0, Y0, Z0 (m), δθ about the OpenCV camera axes (rad); the free interior parameters ``(k, k)``
    #: (:attr:`interior_free`, units of :data:`~fotogeo.orientation.bundle_jacobian.INTERIOR_NAMES`) and their
    #: cross-covariance with each frame ``(m, 6, k)``
    eo_covariance: np.ndarray | None = None
    interior_covariance: np.ndarray | None = None
    eo_interior_covariance: np.ndarray | None = None
    interior_free: tuple = ()
    #: (m, 6) σ of each orientation given every other frame and the interior (σ₀ √diag((S_jj)⁻¹), as eo_sigma):
    #: what its own rays (and priors) hold within the block, the block's datum aside (bundle_result)
    eo_sigma_in_block: np.ndarray | None = None
    #: (m, 6) √diag(S⁻¹) with the a-priori weights, unscaled (as eo_sigma's units): what the observations would give
    #: if every a-priori σ were right (the priors' residual test, bundle_quality)
    eo_sigma_a_priori: np.ndarray | None = None
    #: the orientations of the given weights when the groups were re-weighted (``stats["group_factors"]``), else None
    eo_given_weights: tuple | None = None
