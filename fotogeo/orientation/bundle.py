"""Bundle block adjustment of frame images (array layer): aerial triangulation.

The collinearity equations of :mod:`fotogeo.orientation.bundle_jacobian` (the camera
convention of :mod:`fotogeo.geometry.camera`: PATB angles, corner-convention pixels, plus
Brown's radial and tangential distortion) relate every image observation of a ground point
to the exterior orientation of its frame. :func:`adjust_block` estimates, together, the
exterior orientations of all frames (``X0, Y0, Z0, ω, φ, κ``), the ground coordinates of all
tie points and, optionally, the interior orientation (self-calibration: any of ``f, ppx, ppy,
k1, k2, k3, p1, p2`` and Ebner's ``b1 … b12``, shared by the frames) — the bundle block adjustment of Yastıklı's
digital aerial triangulation, solved as in Triggs et al. (2000):

* in a local Cartesian frame (the block's mean projection centre subtracted); the map CRS
  must be projected and metric (a geographic CRS is refused);
* control points are observations of ``X, Y, Z`` with their σ; check points are adjusted as
  tie points and only compared with their known coordinates afterwards;
* Levenberg–Marquardt on the reduced normal equations (points eliminated by the Schur
  complement; :mod:`~fotogeo.orientation.bundle_normals`, :mod:`~fotogeo.orientation.bundle_lm`)
  with analytic Jacobians vectorised over the observations;
* robust in three phases (:mod:`~fotogeo.orientation.bundle_robust`): Huber (1964)
  reweighting from the approximate orientation (weights frozen per round, the first round unweighted),
  observations beyond ``skip_c`` robust σ of the start skipped at every iteration
  (:mod:`~fotogeo.orientation.bundle_lm`; removed before data snooping); then the multiple correlation of every free
  interior parameter with the exterior orientations (:mod:`~fotogeo.orientation.bundle_rules`) — a parameter the
  block cannot determine
  (ϱ > ``max_correlation`` *and* its a-posteriori σ moving the image points by more than half a pixel,
  e.g. a free focal length against the flying heights over flat ground, nadir frames) is held
  fixed and reported; a correlated parameter that many rays determine nevertheless (the principal
  point against the attitudes and the decentering terms) stays free — and its precision companion for Ebner's
  (1976) additional parameters (``self_calibration=("ebner",)``,
  :mod:`~fotogeo.orientation.bundle_ebner`): one not significant (``|b| < significance·σ_b``)
  is held fixed at 0 and reported; then Baarda's (1968) data snooping with
  redundancy numbers in closed form, culling the worst observation of every flagged point and
  solving again until nothing is flagged; when it culled anything and a parameter was held fixed, the rules are
  taken again on the cleaned block (every parameter freed, least-squares weights) and snooping resumes — before it,
  σ̂₀ still carries the blunders the robust phase did not skip, and a parameter's σ with it;
* precision: σ₀ (in px with the default a priori image σ of 1 px; ≈ 1 when the a priori σ are
  right) and the image RMS in px, and the a-posteriori σ of every orientation
  parameter, interior parameter and point, from the inverse blocks of the reduced system.

The datum comes from ≥ 3 control points or from priors on the approximate orientation
(``eo_sigma``, GNSS/INS). A point needs 2 rays (a control point 1).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ModelError
from ..geometry.camera import FrameCamera
from ..options import EBNER_PARAMETERS
from ..progress import as_progress
from . import bundle_jacobian as bj
from .bundle_lm import State, levenberg_marquardt
from .bundle_types import ROLES, BundleResult  # noqa: F401 (part of this module's API)
from .bundle_problem import active_points, build_problem, check_block, initial_points, local_frame
from .bundle_result import frame_eos, make_result, reweighted
from .bundle_variance import images_too_strong
from .bundle_robust import huber_weights, interior_correlations, posterior, skipped_huber
from .bundle_rules import DETERMINED_PX, _to_fix  # noqa: F401 (part of this module's API)
from .bundle_rules import correlation_rule, initial_interior, release, significance_rule
from .bundle_snooping import cull_skipped, snoop_round

#: tie and check points whose rays meet at a smaller angle are dropped: their depth is undetermined and their
#: 3x3 normal block so close to singular that the reduced system loses its positive definiteness (a rendered
#: oblique block: two rays at 1.3° from frames 7 m apart turned every σ into NaN); COLMAP's default is 1.5° too
MIN_RAY_ANGLE_DEG = 1.5
#: tie and check points nearer to one of their cameras than this fraction of the block's median ray length are
#: dropped: the two rays of a wrong match can pull its point onto a projection centre, where the collinearity
#: derivatives grow without bound and the reduced system loses its positive definiteness (every σ undetermined)
NEAR_FRACTION = 0.05


@dataclass(frozen=True)
class Block:
    """Observations of a block: the frames, their approximate orientation and the image points.

    ``obs_frame``, ``obs_point`` ``(n,)`` index ``frames`` and ``point_ids``; ``obs_pixel``
    ``(n, 2)`` (corner convention); ``obs_sigma`` ``(n,)`` a priori σ in px (default 1).
    ``point_xyz`` ``(P, 3)`` known coordinates of control and check points (NaN for tie
    points), ``point_sigma`` ``(P, 3)`` their σ (control), ``role`` ``(P,)`` one of
    :data:`ROLES`. ``distortion`` = initial ``(k1, k2, k3, p1, p2)``.
    """

    camera: FrameCamera
    frames: tuple
    eo: tuple
    obs_frame: np.ndarray
    obs_point: np.ndarray
    obs_pixel: np.ndarray
    point_ids: tuple
    point_xyz: np.ndarray
    point_sigma: np.ndarray
    role: np.ndarray
    obs_sigma: np.ndarray | None = None
    distortion: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    crs: object = None


@dataclass(frozen=True)
class BundleOptions:
    """``self_calibration``: free interior parameters (names of ``INTERIOR_NAMES``, ``"ebner"`` for
    all of Ebner's ``b1 … b12``); ``eo_sigma``: ``(σ position m, σ angles °)`` or an ``(m, 6)`` array of σ
    per frame (``inf``: free; :func:`~fotogeo.orientation.bundle_problem.eo_weights`) priors on the
    approximate orientation or None; ``max_correlation`` and ``significance``: the rules that hold
    interior parameters fixed (module docstring)."""

    self_calibration: tuple = ()
    eo_sigma: tuple | None = None
    robust_rounds: int = 3
    huber_k: float = 2.0
    #: robust phase: observations beyond ``skip_c`` robust σ of the start (at least ``skip_c`` a-priori σ) are skipped
    #: (:mod:`~fotogeo.orientation.bundle_lm`), and removed before data snooping
    skip_c: float = 10.0
    snooping: bool = True
    critical_w: float = 3.29
    max_snooping_rounds: int = 10
    max_correlation: float = 0.999
    significance: float = 3.0
    max_iterations: int = 60
    max_residual_px: float = 10.0
    #: estimate the image points' σ as a variance component when they drive σ₀ (:func:`_image_variance`), and widen
    #: the covariances by each group's σ̂ (:func:`~fotogeo.orientation.bundle_result.widened`); off: the global rule
    estimate_image_sigma: bool = True


#: what a caller is asked to check when the adjustment does not converge (a tool names the inputs it was given)
CHECK_START = "check the approximate exterior orientation, the camera file and the tie points"


def _robust_weights(pb, s, opts):
    v = bj.project(s.R, s.C, s.X, pb.st.frame, pb.st.point, s.interior, pb.scale) - pb.pixel
    return pb.p0 * huber_weights(v, pb.p0, opts.huber_k)


def _solve(pb, s, p, opts, prog, label, huber=None):
    s, info = levenberg_marquardt(pb, s, p, max_iterations=opts.max_iterations, progress=prog, huber=huber)
    v = np.linalg.norm(bj.project(s.R, s.C, s.X, pb.st.frame, pb.st.point, s.interior, pb.scale) - pb.pixel,
                       axis=1)
    med = float(np.median(v))
    if not np.isfinite(med) or med > opts.max_residual_px:
        raise ModelError(f"bundle adjustment did not converge ({label}): median image residual {med:.3g} px "
                         f"after {info.iterations} iterations; {CHECK_START}")
    return s, info.iterations


class _Run:
    """The mutable state of one adjustment across its phases (block-wide arrays)."""

    def __init__(self, block, opts):
        self.block, self.opts = block, opts
        self.origin, self.R, self.C = local_frame(block)
        self.interior = initial_interior(block)
        self.free = [bj.INTERIOR_NAMES.index(n) for n in opts.self_calibration]
        self.active = np.ones(len(block.obs_frame), bool)
        self.X = initial_points(block, self.origin, self.R, self.C, self.interior)
        self.iterations = 0
        self.unusable = 0
        self.drop_unusable()

    def drop_unusable(self, near_only: bool = False) -> int:
        """Drop tie and check points whose rays do not meet in front of their cameras, or meet 10x
        farther than the median point (near-parallel rays of a wrong match drift to infinity) or nearer than
        :data:`NEAR_FRACTION` of it, or meet at less than :data:`MIN_RAY_ANGLE_DEG` (every ray within half of
        it from the rays' mean direction); with ``near_only`` only the points nearer than :data:`NEAR_FRACTION`.
        The number of points dropped."""
        b = self.block
        Xs = np.nan_to_num(self.X)
        dist = np.linalg.norm(Xs[b.obs_point] - self.C[b.obs_frame], axis=1)
        median = np.median(dist[self.active])
        bad_obs = self.active & (dist < NEAR_FRACTION * median)
        if not near_only:
            z = bj.camera_coordinates(self.R, self.C, Xs, b.obs_frame, b.obs_point)[:, 2]
            bad_obs |= self.active & ((z <= 0) | (dist > 10 * median) | ~np.isfinite(self.X[b.obs_point]).all(axis=1))
        bad = np.zeros(len(b.point_ids), bool)
        bad[b.obs_point[bad_obs]] = True
        if not near_only:
            bad |= _narrow_rays(Xs, self.C, b.obs_frame, b.obs_point, self.active, len(b.point_ids))
        bad &= b.role != "control"
        dropped = int(np.count_nonzero(bad & active_points(b, self.active)))
        self.unusable += dropped
        self.active &= ~bad[b.obs_point]
        return dropped

    def problem(self):
        self.drop_unusable()
        pb = build_problem(self.block, self.active, self.free, self.origin, self.opts.eo_sigma)
        return pb, State(self.R, self.C, self.X[pb.point_ids], self.interior)

    def keep(self, pb, s):
        self.R, self.C, self.interior = s.R, s.C, s.interior
        self.X[pb.point_ids] = s.X


def _narrow_rays(X, C, obs_frame, obs_point, active, n_points) -> np.ndarray:
    """``(P,)`` True for points whose active rays all lie within ``MIN_RAY_ANGLE_DEG / 2`` of their mean
    direction (for two rays: they meet at less than ``MIN_RAY_ANGLE_DEG``); points with one ray are not."""
    d = X[obs_point[active]] - C[obs_frame[active]]
    u = d / np.maximum(np.linalg.norm(d, axis=1), 1e-12)[:, None]
    mean = np.zeros((n_points, 3))
    np.add.at(mean, obs_point[active], u)
    rays = np.bincount(obs_point[active], minlength=n_points)
    mean /= np.maximum(np.linalg.norm(mean, axis=1), 1e-12)[:, None]
    spread = np.zeros(n_points)
    np.maximum.at(spread, obs_point[active], np.arccos(np.clip(np.sum(u * mean[obs_point[active]], axis=1), -1, 1)))
    return (rays >= 2) & (spread < np.radians(MIN_RAY_ANGLE_DEG) / 2)


def adjust_block(block: Block, options: BundleOptions | None = None, *, progress=None) -> BundleResult:
    """Bundle block adjustment of ``block`` (module docstring); raises :class:`InputError` for
    a block that cannot be adjusted (datum, unconnected frames) and :class:`ModelError` when
    it does not converge."""
    opts = options or BundleOptions()
    opts = replace(opts, self_calibration=expand_self_calibration(opts.self_calibration))
    prog = as_progress(progress).with_own_timings()
    check_block(block, opts)
    run = _Run(block, opts)
    t0 = time.perf_counter()
    pb, s = run.problem()
    with prog.timed("robust"):
        skip = skipped_huber(pb, s, opts.huber_k, opts.skip_c).skip  # gross against the start, every round
        p = pb.p0
        for k in range(max(1, opts.robust_rounds)):
            h = skipped_huber(pb, s, np.inf, opts.skip_c, skip)  # Huber's weights frozen in p, gross ones skipped
            s, it = _solve(pb, s, p, opts, prog.stage(k / opts.robust_rounds * 0.4,
                                                      (k + 1) / opts.robust_rounds * 0.4, "robust reweighting"),
                           "reweighting", h)
            run.iterations += it
            p = _robust_weights(pb, s, opts)
        run.keep(pb, s)
        blunders = cull_skipped(run, pb, s, skipped_huber(pb, s, opts.huber_k, opts.skip_c, skip))
        pb, s = run.problem()
        p = _robust_weights(pb, s, opts)
    fixed = []
    pb, s, p = _rules(run, pb, s, p, opts, prog, fixed, lambda pb, s: _robust_weights(pb, s, opts))
    with prog.timed("snooping"):
        pb, s, post, rnd = _snooping(run, pb, s, opts, prog, blunders, 0)
    if fixed and any(b["round"] > 0 for b in blunders):  # the rules again, with the σ̂₀ of the cleaned block
        release(run, fixed)
        pb, s, p = _rules(run, *run.problem(), None, opts, prog, fixed, lambda pb, s: pb.p0)
        with prog.timed("snooping"):
            pb, s, post, rnd = _snooping(run, pb, s, opts, prog, blunders, min(rnd + 1, opts.max_snooping_rounds))
    pb, s, post, factor = _image_variance(run, pb, s, post, opts, prog)
    prog.timings["total"] = time.perf_counter() - t0
    corr = interior_correlations(pb, post, block.frames, bj.INTERIOR_NAMES) if run.free else []
    given, factors, given_eo = post, None, frame_eos(run)
    if opts.estimate_image_sigma:  # off: nothing estimated, the global rule
        pb, s, post, factors = reweighted(pb, s, post, lambda pw, sw: _group_solve(run, pw, sw, opts, prog))
        run.keep(pb, s)
    result = make_result(run.block, run, pb, post, fixed, corr, blunders, dict(prog.timings), given, factors,
                         given_eo)
    if factor is not None:
        result.stats["variance_components"]["image"].update(factor)
    result.stats["n_points_unusable"] = run.unusable  # rays not meeting in front of the cameras (or at infinity)
    return result


def _rules(run, pb, s, p, opts, prog, fixed, weights):
    """``(pb, s, p)``: the correlation and the significance rule (:mod:`~fotogeo.orientation.bundle_rules`) taken
    at ``s`` with the weights ``p``, each re-solve weighted by ``weights(pb, s)``; ``p`` None: ``s`` solved with
    them first (after :func:`~fotogeo.orientation.bundle_rules.release`)."""
    def resolve(label):
        return _resolve(run, opts, prog, label, weights)
    if p is None:
        pb, s, p = _solved(run, pb, s, opts, prog.stage(0.4, 0.5, "re-solving"), "the rules again", weights)
    with prog.timed("correlations"):
        pb, s, p = correlation_rule(run, pb, s, p, opts, resolve, fixed)
    with prog.timed("significance"):
        pb, s, p = significance_rule(run, pb, s, p, opts, resolve, fixed)
    return pb, s, p


def _snooping(run, pb, s, opts, prog, blunders, first: int):
    """``(pb, s, post, round)``: data snooping (:func:`~fotogeo.orientation.bundle_snooping.snoop_round`) from round
    ``first`` until nothing is flagged or ``opts.max_snooping_rounds``; the first test of round 0 is made at ``s``
    (the robust solution), every other after a least-squares solve."""
    rnd = first
    for rnd in range(first, opts.max_snooping_rounds + 1):
        pb, s = run.problem()
        if rnd > 0 or not opts.snooping:
            pb, s, _ = _solved(run, pb, s, opts, prog.stage(0.5 + 0.05 * min(rnd, 9), 0.55 + 0.05 * min(rnd, 9),
                                                          "data snooping"), "data snooping", lambda pb, s: pb.p0)
        post = posterior(pb, s, pb.p0)
        if not opts.snooping or rnd == opts.max_snooping_rounds:
            break
        if not snoop_round(run, pb, post, opts, rnd, blunders):
            break
    return pb, s, post, rnd


def _image_variance(run, pb, s, post, opts, prog):
    """``(pb, s, post, estimate)``: when the image points' σ̂ is the largest (:func:`~fotogeo.orientation.
    bundle_variance.images_too_strong`: their a-priori σ too small, e.g. least-squares matching's formal σ), their σ is estimated
    as a variance component (Förstner 1979): every image weight divided by ``σ̂_image²`` and the block solved
    again, at most three times, until ``σ̂_image ≤ 1.05``. A parameter the images determine keeps its σ (its
    cofactor grows by ``σ̂²`` as σ₀ falls by ``σ̂``); one a prior holds (the attitude of a short strip) is no
    longer inflated by the images' σ₀. Only ever widens the image σ; ``estimate`` None when not applied, else
    ``{"sigma0_given", "factor"}`` (the σ₀ of the image group with the given σ, the factor applied to it)."""
    groups = post.groups
    if not opts.estimate_image_sigma or not images_too_strong(groups):
        return pb, s, post, None
    given, factor = groups["image"]["sigma0"], 1.0
    for _ in range(3):
        g = post.groups["image"]["sigma0"]
        if not np.isfinite(g) or g <= 1.05:
            break
        factor *= g
        pb = replace(pb, p0=pb.p0 / g ** 2)
        s, it = _solve(pb, s, pb.p0, opts, prog.stage(0.95, 1.0, "image variance component"), "image variance")
        run.iterations += it
        run.keep(pb, s)
        post = posterior(pb, s, pb.p0)
    return pb, s, post, {"sigma0_given": float(given), "factor": float(factor)}


def _group_solve(run, pb, s, opts, prog):
    """``s`` solved with the groups' re-weighted problem ``pb`` (:func:`~fotogeo.orientation.bundle_result.
    reweighted`), its iterations counted."""
    s, it = _solve(pb, s, pb.p0, opts, prog.stage(0.99, 1.0, "group variance"), "group variance components")
    run.iterations += it
    return s


def expand_self_calibration(names) -> tuple:
    """The free interior parameters in :data:`INTERIOR_NAMES` order, ``"ebner"`` standing for ``b1 … b12``
    (unknown names are kept, for :func:`check_block` to name them)."""
    names = list(dict.fromkeys(names or ()))
    if "ebner" in names:
        names = [n for n in names if n != "ebner"] + list(EBNER_PARAMETERS)
    known = [n for n in bj.INTERIOR_NAMES if n in names]
    return tuple(known + [n for n in dict.fromkeys(names) if n not in known])


def _resolve(run, opts, prog, label, weights):
    """The problem rebuilt after a parameter was held fixed, its weights ``weights(pb, s)`` anew (it may have
    lost points) and its solution."""
    pb, s = run.problem()
    return _solved(run, pb, s, opts, prog.stage(0.4, 0.5, "re-solving"), label, weights)


def _solved(run, pb, s, opts, prog, label, weights):
    """``(pb, s, p)``: ``pb`` solved from ``s`` with the weights ``p = weights(pb, s)`` and kept; when points
    were pulled onto a projection centre at the solution (:meth:`_Run.drop_unusable`, ``near_only``) the problem
    is rebuilt without them and solved again (at most twice), so that no statistic is computed with them."""
    for _ in range(3):
        p = weights(pb, s)
        s, it = _solve(pb, s, p, opts, prog, label)
        run.iterations += it
        run.keep(pb, s)
        if not run.drop_unusable(near_only=True):
            break
        pb, s = run.problem()
    return pb, s, p
