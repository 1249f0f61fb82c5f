"""One pair of oriented frames → 3-D points (the per-pair steps of ``fotogeo dsm``).

:func:`frame_view` gives a frame's :class:`~fotogeo.stereo.rectify.FrameView` from its ground → image model
(triangulate's :class:`~fotogeo.tools.triangulate.ortho.AdjustedFrame`: collinearity with Brown's distortion).
:func:`sparse_check` matches SIFT features on the rectified pair (Lowe 2004, ratio 0.8): their row differences are
the pair's epipolar residuals (the orientation's relative error, in rectified pixels), their rays' miss distances
its error in metres, their disparities the search range when no DEM bounds it. :func:`dense_points` then matches
the rectified pair strip by strip (:func:`fotogeo.stereo.dense.disparity`, strips of ``STRIP`` rows overlapping by
``MARGIN``: memory bounded by the strip, not the image) and triangulates every matched pixel
(:func:`fotogeo.stereo.rays.closest_points`), yielding ``(points, colours)`` per strip.
"""
from __future__ import annotations

import cv2
import numpy as np

from ...orientation import bundle_jacobian as bj
from ...pixels import HALF
from ...stereo.dense import disparity, to_uint8
from ...stereo.rays import closest_points
from ...stereo.rectify import FrameView, RectifiedPair

STRIP = 384
MARGIN = 48


def frame_view(im) -> FrameView:
    """The :class:`FrameView` of an :class:`~fotogeo.tools.ortho.inputs.OrthoImage` of a frame."""
    m = im.model
    M = m.frame.eo.rotation_cv
    cam = m.frame.camera

    def rays(px):
        return bj.undistort_rays(np.asarray(px, float), m.interior, m.scale) @ M.T

    return FrameView(im.name, m.frame.eo.centre, M, 0.5 * (cam.fx + cam.fy), (im.width, im.height), m.forward, rays)


def _remap(img, mx, my, interpolation=cv2.INTER_LINEAR):
    return cv2.remap(img, mx, my, interpolation, borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def rectified(rp: RectifiedPair, view, i: int, grey, r0: int, r1: int) -> tuple:
    """``(grey float32, valid bool, maps)`` of rows ``r0:r1`` of rectified image ``i``."""
    mx, my = rp.maps(view, i, r0, r1)
    h, w = grey.shape
    valid = (mx >= 0) & (my >= 0) & (mx <= w - 1) & (my <= h - 1)
    return _remap(grey, mx, my, cv2.INTER_CUBIC), valid, (mx, my)


def sparse_check(rp: RectifiedPair, views, greys, max_features: int = 4000) -> dict:
    """Sparse matches of the whole rectified pair (module docstring): ``{"n", "dy" (px), "d" (px), "points",
    "miss" (m)}``; ``n`` 0 when nothing matched."""
    h = rp.size[1]
    imgs = []
    for i in (0, 1):
        g, valid, _ = rectified(rp, views[i], i, greys[i], 0, h)
        imgs.append((to_uint8(g, valid), valid))
    sift = cv2.SIFT_create(nfeatures=max_features)
    k1, d1 = sift.detectAndCompute(imgs[0][0], imgs[0][1].astype(np.uint8))
    k2, d2 = sift.detectAndCompute(imgs[1][0], imgs[1][1].astype(np.uint8))
    empty = {"n": 0, "dy": np.zeros(0), "d": np.zeros(0), "points": np.zeros((0, 3)), "miss": np.zeros(0),
             "dy_median": 0.0, "dy_spread": 0.0}
    if d1 is None or d2 is None or len(k1) < 8 or len(k2) < 8:
        return empty
    pairs = cv2.BFMatcher(cv2.NORM_L2).knnMatch(d1, d2, k=2)
    good = [m[0] for m in pairs if len(m) == 2 and m[0].distance < 0.8 * m[1].distance]
    if len(good) < 8:
        return empty
    p1 = np.array([k1[m.queryIdx].pt for m in good]) + HALF
    p2 = np.array([k2[m.trainIdx].pt for m in good]) + HALF
    dy = p1[:, 1] - p2[:, 1]
    med = float(np.median(dy))
    spread = float(1.4826 * np.median(np.abs(dy - med)))
    keep = np.abs(dy - med) <= max(2.0, 3.0 * spread)
    p1, p2, dy = p1[keep], p2[keep], dy[keep]
    P, miss = closest_points(rp.centres[0], rp.rays(p1[:, 0], p1[:, 1], 0), rp.centres[1],
                             rp.rays(p2[:, 0], p2[:, 1], 1))
    ok = np.isfinite(miss)
    return {"n": int(ok.sum()), "dy": dy[ok], "d": (p1[:, 0] - p2[:, 0])[ok], "points": P[ok], "miss": miss[ok],
            "dy_median": med, "dy_spread": spread}


def sparse_problem(sp, max_px: float) -> str:
    """Why the sparse matches of a pair cannot be trusted ("" when they can): they disagree among themselves (the
    images do not show the same ground, or the orientation is wrong), or agree on rows ``max_px`` apart (the
    orientation does not fit the images)."""
    if sp["n"] < 8:
        return ""
    if sp["dy_spread"] > 3.0:
        return (f"its sparse matches disagree (their row differences spread {sp['dy_spread']:.0f} px): the images "
                f"may not show the same ground, or their orientation is wrong")
    if abs(sp["dy_median"]) > max_px:
        return (f"the orientation does not fit the images: sparse matches lie {abs(sp['dy_median']):.1f} px off "
                f"their epipolar lines (rays miss by {np.median(sp['miss']):.2f} m); refine the orientation "
                f"(fotogeo triangulate)")
    return ""


def dense_points(rp: RectifiedPair, views, greys, colours, lo: float, hi: float, zlim: tuple, stats: dict):
    """Yield ``(points (N, 3), colours (N, 3) uint8)`` strip by strip (module docstring); ``[lo, hi]`` the
    disparity range, ``zlim`` the heights kept; ``stats`` gets the matched and matchable pixel counts."""
    w, h = rp.size
    stats.update(matched=0, matchable=0)
    for r0 in range(0, h, STRIP):
        a, b = max(0, r0 - MARGIN), min(h, r0 + STRIP + MARGIN)
        g1, v1, maps1 = rectified(rp, views[0], 0, greys[0], a, b)
        g2, v2, _ = rectified(rp, views[1], 1, greys[1], a, b)
        d = disparity(g1, g2, v1, v2, lo, hi)
        core = slice(r0 - a, min(h, r0 + STRIP) - a)
        shift = int(round(0.5 * (lo + hi)))  # matchable: the partner at the middle disparity lies in the image
        partner = np.zeros_like(v2)
        if abs(shift) < w:
            partner[:, max(0, shift):w + min(0, shift)] = v2[:, max(0, -shift):w - max(0, shift)]
        d, v1 = d[core], (v1 & partner)[core]
        mx, my = maps1[0][core], maps1[1][core]
        rows, cols = np.nonzero(np.isfinite(d))
        stats["matchable"] += int(v1.sum())
        stats["matched"] += len(rows)
        if not len(rows):
            continue
        u = cols + HALF
        v = rows + r0 + HALF
        P, _ = closest_points(rp.centres[0], rp.rays(u, v, 0), rp.centres[1], rp.rays(u - d[rows, cols], v, 1))
        ok = np.isfinite(P).all(axis=1) & (P[:, 2] >= zlim[0]) & (P[:, 2] <= zlim[1])
        rgb = np.stack([_remap(c, mx, my)[rows, cols] for c in colours], axis=1)
        yield P[ok], rgb[ok]
