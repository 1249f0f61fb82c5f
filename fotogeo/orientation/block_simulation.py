"""A synthetic block of aerial frames with known truth, for the bundle adjustment (array layer).

:func:`simulate_block` flies ``strips`` strips of ``frames_per_strip`` frames over a smooth
terrain (a sum of Gaussian hills of amplitude ``relief``·N(0, 1) m on a base height: the hills overlap, so
over a large block the surface spans several times ``relief`` — seed 3, 10 × 10 frames of 600 × 400 px:
40 to 267 m for ``relief`` 40), with the forward and side overlaps given (60 % / 30 % by default) at the
ground under the flight. The camera flies ``flying_height`` above the datum (the overlaps hold at height 0
only: over ground 230 m up, 1000 m above the datum, 60/30 % become 46/7 %, no point is in three frames of a
strip) or, with ``above_terrain``, each strip ``flying_height`` above the mean terrain under its frames, as a
flight plan sets each strip's height from the terrain for the overlaps to hold (Wolf & Dewitt 2000, flight
planning). Alternate strips flown in opposite directions
(κ = 0° / 180°), each frame with a random attitude of ``attitude_sd`` degrees and, with
``convergent`` degrees, a fore/aft tilt alternating from frame to frame. Ground points on a
jittered grid (``point_spacing`` m, an equivalent of Gruber's positions) are projected into
every frame that sees them (:func:`fotogeo.orientation.bundle_jacobian.project`, with the true
camera and distortion); points seen in ≥ 2 frames are kept. Image noise is Gaussian with σ
``noise`` px per axis, which is also the observations' a priori σ (so σ₀ ≈ 1). Blunders (``blunder_fraction`` of the observations, 8–25 px in a random
direction, at most one per point) are planted on points with ≥ 3 rays: in a 2-ray point the
part of a blunder along the epipolar line cannot be seen by any test (zero redundancy; Baarda
1968, internal reliability). Control points are the points nearest to the block's corners,
edge midpoints and centre (``n_control``), their coordinates with Gaussian noise of
``control_sigma``; check points are drawn at random among the remaining ≥ 3-ray points. The
approximate orientation given to the adjustment is the truth plus Gaussian noise
``eo_noise = (m, °)``, and the nominal camera may differ from the true one
(``true_focal_length``, ``true_distortion``, and Ebner's (1976) additional parameters
``true_additional`` ``b1 … b12`` in px, :mod:`fotogeo.orientation.bundle_ebner`), for self-calibration.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.camera import ExteriorOrientation, FrameCamera
from . import bundle_jacobian as bj
from .bundle import Block


@dataclass(frozen=True)
class SyntheticBlock:
    block: Block  # what the adjustment gets (noisy observations, approximate orientation)
    true_eo: tuple
    true_camera: FrameCamera
    true_distortion: tuple
    true_xyz: np.ndarray  # (P, 3)
    blunders: np.ndarray  # observation indices with a planted blunder
    gsd: float  # ground sample distance at the mean terrain height (m)
    surface: object  # XY (N, 2) -> Z (N,)
    true_additional: tuple = ()  # Ebner's b1 … b12 (px)


def terrain(rng, centre, extent, base: float, relief: float, n_hills: int = 14):
    """A smooth random surface ``XY -> Z``: ``base`` plus Gaussian hills of ±``relief`` m."""
    cx = centre[0] + (rng.random(n_hills) - 0.5) * extent[0]
    cy = centre[1] + (rng.random(n_hills) - 0.5) * extent[1]
    width = (0.12 + 0.25 * rng.random(n_hills)) * max(extent)
    amp = relief * rng.normal(size=n_hills)

    def surface(XY):
        XY = np.asarray(XY, float).reshape(-1, 2)
        d2 = (XY[:, 0, None] - cx) ** 2 + (XY[:, 1, None] - cy) ** 2
        return base + np.sum(amp * np.exp(-d2 / (2 * width ** 2)), axis=1)
    return surface


def _flight(camera, strips, per_strip, fwd, side, height, rng, attitude_sd, convergent, eo_noise):
    fx, fy = camera.fx, camera.fy
    w, h = camera.image_size
    foot_x, foot_y = w / fx * height, h / fy * height  # x across track, y along track (κ = 0)
    base, spacing = (1 - fwd) * foot_y, (1 - side) * foot_x
    true, approx = [], []
    for s in range(strips):
        for k in range(per_strip):
            kappa = 0.0 if s % 2 == 0 else 180.0
            y = k * base if s % 2 == 0 else (per_strip - 1 - k) * base
            tilt = convergent * (1 if k % 2 == 0 else -1)
            om, ph, ka = rng.normal(0, attitude_sd, 3) + [tilt, 0.0, kappa]
            e = ExteriorOrientation(s * spacing + rng.normal(0, 2.0), y + rng.normal(0, 2.0),
                                    height + rng.normal(0, 5.0), om, ph, ka)
            true.append(e)
            dp, da = rng.normal(0, eo_noise[0], 3), rng.normal(0, eo_noise[1], 3)
            approx.append(ExteriorOrientation(e.X + dp[0], e.Y + dp[1], e.Z + dp[2], e.omega + da[0],
                                              e.phi + da[1], e.kappa + da[2]))
    return true, approx, (strips - 1) * spacing + foot_x, (per_strip - 1) * base + foot_y


def _strip_terrain(eos, surface, per_strip) -> np.ndarray:
    """``(n,)``: per frame, the mean terrain height under its strip's frames (their centres' nadir points)."""
    xy = np.array([[e.X, e.Y] for e in eos])
    return surface(xy).reshape(-1, per_strip).mean(axis=1).repeat(per_strip)


def _raised(eos, rise) -> list:
    """``eos`` with each Z raised by ``rise`` (m)."""
    return [ExteriorOrientation(e.X, e.Y, e.Z + dz, e.omega, e.phi, e.kappa) for e, dz in zip(eos, rise)]


def _observe(true_eo, camera, interior, XYZ, margin):
    """Observations of the points every frame sees (one frame at a time: only the points within
    the frame's ground radius are projected, so memory stays proportional to the observations)."""
    scale = bj.pixel_scale(camera)
    w, h = camera.image_size
    frames, points, pixels = [], [], []
    for j, e in enumerate(true_eo):
        reach = 1.5 * np.hypot(w / camera.fx, h / camera.fy) * (e.Z - XYZ[:, 2].min())
        near = np.flatnonzero(np.hypot(XYZ[:, 0] - e.X, XYZ[:, 1] - e.Y) < reach)
        zero = np.zeros(len(near), dtype=np.intp)
        c = bj.camera_coordinates(e.rotation_cv[None], e.centre[None], XYZ[near], zero, np.arange(len(near)))
        px = bj.project(e.rotation_cv[None], e.centre[None], XYZ[near], zero, np.arange(len(near)), interior, scale)
        seen = ((c[:, 2] > 0) & (px[:, 0] > margin) & (px[:, 0] < w - margin) & (px[:, 1] > margin)
                & (px[:, 1] < h - margin))
        frames.append(np.full(int(seen.sum()), j, dtype=np.intp))
        points.append(near[seen])
        pixels.append(px[seen])
    return np.concatenate(frames), np.concatenate(points), np.concatenate(pixels)


def _pick_control(xyz, rays, n_control, lo, hi):
    mid = (lo + hi) / 2
    targets = [(lo[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1]), (hi[0], lo[1]), (mid[0], lo[1]), (mid[0], hi[1]),
               (lo[0], mid[1]), (hi[0], mid[1]), (mid[0], mid[1])]
    chosen = []
    for t in targets[:n_control]:
        d = np.hypot(xyz[:, 0] - t[0], xyz[:, 1] - t[1]) + np.where(rays >= 2, 0.0, 1e9)
        d[chosen] = np.inf
        chosen.append(int(np.argmin(d)))
    return np.array(chosen, dtype=int)


def simulate_block(*, strips: int = 3, frames_per_strip: int = 8, forward_overlap: float = 0.6,
                   side_overlap: float = 0.3, camera: FrameCamera | None = None, flying_height: float = 1000.0,
                   relief: float = 40.0, point_spacing: float = 40.0, noise: float = 0.3,
                   blunder_fraction: float = 0.015, n_control: int = 8, n_check: int = 20,
                   control_sigma: tuple = (0.02, 0.03), eo_noise: tuple = (5.0, 0.5), attitude_sd: float = 1.0,
                   convergent: float = 0.0, true_focal_length: float | None = None,
                   true_distortion: tuple = (0.0, 0.0, 0.0, 0.0, 0.0), true_additional: tuple = (),
                   origin=(500000.0, 4420000.0), above_terrain: bool = False,
                   margin: float = 20.0, seed=0) -> SyntheticBlock:
    """A seeded synthetic block (module docstring); the block's map coordinates start at ``origin``."""
    rng = np.random.default_rng(seed)
    camera = camera or FrameCamera(30.0, (20.0, 30.0), (2000, 3000))
    true_cam = camera if true_focal_length is None else FrameCamera(
        true_focal_length, camera.sensor_size, camera.image_size, camera.principal_point)
    true_eo, approx, ext_x, ext_y = _flight(camera, strips, frames_per_strip, forward_overlap, side_overlap,
                                           flying_height, rng, attitude_sd, convergent, eo_noise)
    half = np.array([camera.image_size[0] / camera.fx, camera.image_size[1] / camera.fy]) * flying_height / 2
    lo, hi = -half, np.array([ext_x, ext_y]) - half
    surface = terrain(rng, (lo + hi) / 2, hi - lo, 0.0, relief)
    if above_terrain:
        rise = _strip_terrain(true_eo, surface, frames_per_strip)
        true_eo, approx = _raised(true_eo, rise), _raised(approx, rise)
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], point_spacing), np.arange(lo[1], hi[1], point_spacing))
    XY = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-0.4, 0.4, (gx.size, 2)) * point_spacing
    XYZ = np.column_stack([XY, surface(XY)])
    interior = true_interior(true_cam, true_distortion, true_additional)
    frame, point, px = _observe(true_eo, true_cam, interior, XYZ, margin)
    rays = np.bincount(point, minlength=len(XYZ))
    keep = rays >= 2
    remap = np.cumsum(keep) - 1
    sel = keep[point]
    frame, point, px, XYZ, rays = frame[sel], remap[point[sel]], px[sel], XYZ[keep], rays[keep]
    px = px + rng.normal(0, noise, px.shape)
    role = np.full(len(XYZ), "tie", dtype=object)
    ctrl = _pick_control(XYZ, rays, n_control, lo, hi)
    role[ctrl] = "control"
    free = np.flatnonzero((role == "tie") & (rays >= 3))
    role[rng.choice(free, min(n_check, len(free)), replace=False)] = "check"
    blunders = _plant_blunders(rng, point, rays, role, blunder_fraction, px)
    known = np.full((len(XYZ), 3), np.nan)
    known[role != "tie"] = XYZ[role != "tie"]
    sig = np.full((len(XYZ), 3), np.nan)
    sig[ctrl] = [control_sigma[0], control_sigma[0], control_sigma[1]]
    known[ctrl] += rng.normal(0, 1, (len(ctrl), 3)) * sig[ctrl]
    shift = np.array([origin[0], origin[1], 0.0])
    names = tuple(f"s{s + 1}_{k + 1:02d}" for s in range(strips) for k in range(frames_per_strip))
    block = Block(camera, names, tuple(_shifted(e, shift) for e in approx), frame, point, px,
                  tuple(f"p{i}" for i in range(len(XYZ))), known + shift, sig, role.astype(str),
                  np.full(len(px), max(noise, 1e-3)), (0.0, 0.0, 0.0, 0.0, 0.0), None)
    gsd = flying_height / camera.fx
    return SyntheticBlock(block, tuple(_shifted(e, shift) for e in true_eo), true_cam, tuple(true_distortion),
                          XYZ + shift, blunders, gsd, lambda XY: surface(np.asarray(XY, float) - shift[:2]),
                          tuple(true_additional))


def true_interior(camera, distortion, additional=()) -> np.ndarray:
    """The interior vector (:data:`~fotogeo.orientation.bundle_jacobian.INTERIOR_NAMES`) of a camera, its
    Brown distortion and Ebner's additional parameters (missing ones 0)."""
    b = np.zeros(len(bj.INTERIOR_NAMES) - bj.N_PHYSICAL)
    b[:len(additional)] = additional
    return np.array([camera.focal_length, *camera.principal_point, *distortion, *b], dtype=np.float64)


def _shifted(e, shift):
    return ExteriorOrientation(e.X + shift[0], e.Y + shift[1], e.Z + shift[2], e.omega, e.phi, e.kappa)


def _plant_blunders(rng, point, rays, role, fraction, px):
    n_bad = int(round(fraction * len(point)))
    candidates = np.flatnonzero(rays[point] >= 3)
    order = rng.permutation(candidates)
    _, first = np.unique(point[order], return_index=True)  # at most one per point
    chosen = np.sort(order[first][rng.permutation(len(first))[:n_bad]])
    ang = rng.uniform(0, 2 * np.pi, len(chosen))
    mag = rng.uniform(8.0, 25.0, len(chosen))
    px[chosen] += np.column_stack([mag * np.cos(ang), mag * np.sin(ang)])
    return chosen
