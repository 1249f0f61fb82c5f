"""Where a block starts when nobody wrote its orientation down: from the images themselves.

A drone user has images with GPS positions, perhaps gimbal or autopilot angles, perhaps nothing
about the attitude at all. Before least-squares matching and the bundle adjustment need it,
two things the GPS does not give are measured on the images (after the pairs are matched on a
pyramid level, :mod:`fotogeo.tools.triangulate.match`):

* **κ (the heading of the image)**. For each matched pair ``(i, j)`` a similarity
  ``x_j ≈ S(x_i)`` is fitted to the epipolar inliers (``cv2.estimateAffinePartial2D``, RANSAC).
  The nadir point of frame ``j`` (its image centre ``c``) lies at ``m = S⁻¹(c) − c`` in frame
  ``i``: the direction, in frame ``i``'s pixels, in which its camera moved to ``j``. The GPS says
  that the camera moved by ``D = C_j − C_i`` on the map. For a level camera with PATB rotation
  ``Rz(κ)``, the camera axes are ``x`` = right (+col), ``y`` = up (−row), so a map vector
  ``D`` appears in the image as ``(col, −row) = Rz(κ)ᵀ D``; written with complex numbers
  ``m̄ = D·e^{−iκ}`` (``m̄ = m_col + i·(−m_row)`` is the complex conjugate of ``m_col + i·m_row``),
  hence ``κ = arg(D) − arg(m̄)``. Every frame whose attitude is unknown takes the circular mean of its
  pairs' estimates weighted by the baseline in pixels; a frame with a known attitude (gimbal, INS, its
  registration to a reference) keeps its κ — the level camera's κ is not a tilted camera's: on a rendered
  oblique block (30° off nadir) where one frame of twelve was level, overwriting the others' registered κ
  with it turned them by up to 113° and two of them were dropped by the bundle.
* **the terrain height**, when neither a DEM nor control gives it: the same similarity gives the
  image scale — the camera moved ``|D|`` metres and ``|m|`` pixels, so the ground sample
  distance is ``|D| / |m|`` and the camera was ``f·|D| / |m|`` above the ground
  (``f`` in pixels); the block's terrain height is the median of ``Z_i − f·|D|/|m|``.

Both assume frames looking roughly down (tilts up to a few tens of degrees leave κ's sign and
size right); the bundle adjustment refines them, and :mod:`fotogeo.orientation.bundle_quality`
refuses a frame they could not start.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

MIN_PAIR_INLIERS = 12


def pair_motion(xy_i: np.ndarray, xy_j: np.ndarray, camera) -> np.ndarray | None:
    """``m`` (module docstring): where frame ``j``'s image centre lies in frame ``i``, minus the centre
    (pixels); None when the pair has too few matches for a similarity."""
    import cv2
    if len(xy_i) < MIN_PAIR_INLIERS:
        return None
    S, inl = cv2.estimateAffinePartial2D(xy_i.astype(np.float64), xy_j.astype(np.float64), method=cv2.RANSAC,
                                         ransacReprojThreshold=3.0)
    if S is None or inl is None or int(inl.sum()) < MIN_PAIR_INLIERS:
        return None
    c = np.array(camera.principal_point, dtype=np.float64)
    A, t = S[:, :2], S[:, 2]
    try:
        back = np.linalg.solve(A, c - t)
    except np.linalg.LinAlgError:
        return None
    return back - c


def kappa_from_motion(m: np.ndarray, D: np.ndarray) -> float:
    """κ (degrees) of a level frame that saw its camera move by ``m`` pixels while the map says ``D``."""
    m_bar = complex(m[0], -m[1])
    return math.degrees(math.atan2(D[1], D[0]) - math.atan2(m_bar.imag, m_bar.real))


def start_from_pairs(eos, camera, pair_points, *, estimate_kappa, estimate_height: bool):
    """``(eos, height or None, report)``: κ and the terrain height measured on the matched pairs.

    ``pair_points`` is ``[(i, j, xy_i, xy_j), ...]`` (full-resolution pixels, epipolar inliers);
    ``estimate_kappa``: one bool per frame (True: its attitude is unknown, κ is measured), or one for all.
    """
    m_frames = len(eos)
    votes = [[] for _ in range(m_frames)]
    heights = []
    f_px = float(camera.fx)
    for i, j, xy_i, xy_j in pair_points:
        m = pair_motion(xy_i, xy_j, camera)
        D = eos[j].centre - eos[i].centre
        if m is None or np.hypot(*D[:2]) < 1e-6 or np.hypot(*m) < 1.0:
            continue
        k = kappa_from_motion(m, D[:2])
        w = float(np.hypot(*m))
        votes[i].append((k, w))
        votes[j].append((kappa_from_motion(_motion_in_j(xy_i, xy_j, camera, m), -D[:2]), w))
        heights.append(0.5 * (eos[i].Z + eos[j].Z) - f_px * float(np.hypot(*D[:2])) / w)
    report = {}
    out = list(eos)
    unknown = np.broadcast_to(np.asarray(estimate_kappa, dtype=bool), (m_frames,))
    if unknown.any():
        kappas = []
        for j, v in enumerate(votes):
            if v and unknown[j]:
                ang = np.radians([a for a, _ in v])
                w = np.array([b for _, b in v])
                k = math.degrees(math.atan2(np.sum(w * np.sin(ang)), np.sum(w * np.cos(ang))))
                out[j] = replace(out[j], kappa=k)
                kappas.append(round(k, 2))
            else:
                kappas.append(None)
        report["kappa_from_images_deg"] = kappas
    height = None
    if estimate_height and heights:
        height = float(np.median(heights))
        report["terrain_height_from_images_m"] = round(height, 2)
    return tuple(out), height, report


def _motion_in_j(xy_i, xy_j, camera, m_i):
    """Where frame ``i``'s centre lies in frame ``j`` minus the centre: the pair seen from ``j``."""
    m = pair_motion(xy_j, xy_i, camera)
    return m if m is not None else -np.asarray(m_i)


def flight_kappa(centres: np.ndarray) -> np.ndarray:
    """κ (degrees) of level frames whose image top points along the flight direction, from the
    projection centres in capture order (central differences; one frame: 0)."""
    c = np.asarray(centres, dtype=np.float64)[:, :2]
    if len(c) < 2:
        return np.zeros(len(c))
    d = np.gradient(c, axis=0)
    return np.degrees(np.arctan2(-d[:, 0], d[:, 1]))


def provisional_height(eos, camera, reach: float = 2.5) -> float:
    """A terrain height for choosing the pairs to match when nothing gives one: the height at which a
    level frame's round footprint reaches ``reach`` times the median distance between neighbouring
    projection centres (60–80 % forward overlap puts the next 2–4 frames inside it); the real height is
    measured on the matched pairs (:func:`start_from_pairs`)."""
    c = np.array([e.centre for e in eos])
    if len(c) < 2:
        return float(c[0, 2]) - 100.0
    d = np.hypot(*(c[:, None, :2] - c[None, :, :2]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    spacing = float(np.median(d.min(axis=1)))
    w, h = camera.image_size
    half_diagonal = 0.5 * float(np.hypot(w, h))
    return float(np.median(c[:, 2])) - reach * spacing * float(camera.fx) / half_diagonal
