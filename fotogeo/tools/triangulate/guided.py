"""Tie points between frames seen from very different directions, matched on the ground plane (the tool layer of
``fotogeo triangulate``).

Converging obliques — a camera 30–45° off nadir looking east, south, west and north at one place — see the
same ground turned by up to 180°, scaled by up to 2–3× and sheared: a detector's rotation and scale invariance
covers the first two only in part, and the descriptors of one patch seen from two sides differ too much for the
ratio test. Guided matching removes the viewpoint with the approximate orientation before matching, as
orthorectification does (each frame resampled onto one ground plane):

* the **window**: each frame's pixels (a grid of samples) projected onto the plane ``Z = h0`` (the block's
  terrain height) through its approximate orientation, rays reaching farther than :data:`REACH` × the
  camera's height above the plane left out (grazing rays towards the horizon); the two frames' ground boxes
  intersected; a cell of ``sqrt(area / max_pixels)`` metres, never finer than the finer frame's nadir ground
  sample ``(Z0 − h0) / f``;
* each frame **resampled onto that grid**: a cell centre ``(X, Y, h0)`` goes through the camera (distortion
  included, :func:`fotogeo.orientation.bundle_jacobian.project_camera`) to its pixel, the frame is sampled
  there (bilinear; ``cv2.remap``; a frame finer than the grid by ``s`` frame pixels per cell is low-passed first,
  Gaussian σ = ``0.5·sqrt(s² − 1)``); cells whose ray misses the frame are invalid. Over flat ground the two
  resampled images differ by a translation of the orientation error and the relief parallax only;
* **detection and matching** as for every pair (the options' detector, ratio test and mutual check:
  :func:`fotogeo.features.detect.detect`, :func:`fotogeo.features.match.match_descriptors`);
* each match's grid position goes back to the frame through the same projection (exact, not an inverse
  homography: the distortion is in it), and the pair's **one RANSAC**, the epipolar test of the plain pairs
  (:func:`fotogeo.tools.triangulate.pairs.epipolar_kept`), keeps those that fit the two-view geometry on the
  frames' own pixels — a wrong approximate orientation makes fewer matches, never wrong ones.

:func:`guided_results` runs it for the pairs whose plain matching kept fewer than :data:`GUIDED_BELOW`
inliers, or whose optical axes differ by more than :data:`CONVERGING_DEG` (converging views: the plain matches
there are fewer and more of them wrong), and keeps, per pair, whichever kept more inliers. The caller's
``max_pixels`` bounds the grid (``fotogeo triangulate``: the larger of the pyramid level's budget and a frame's
pixels up to 1 Mpx).

**The plane's height.** With a DEM or control the caller gives it; otherwise the first pairs start on the
provisional height of the pair selection (:func:`fotogeo.tools.triangulate.start.provisional_height`, often tens of
metres off for a drone) and each pair's inliers measure it: the median height of the midpoints of their rays'
shortest segments (:func:`ray_heights`) through the approximate orientations; a pair whose inliers put the plane
more than a tenth of the camera height away is matched once more on the measured plane, and the next pairs start
on the median of the heights measured so far (:func:`measured_pair`).
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import FotogeoError
from ...geometry.camera import OrientedFrame
from ...progress import as_progress
from .pairs import epipolar_kept, grey

#: pairs whose plain matching kept fewer epipolar inliers than this are matched on the ground plane too
GUIDED_BELOW = 12
#: pairs whose optical axes differ by more than this (degrees) are matched on the ground plane whatever the plain
#: matching found
CONVERGING_DEG = 20.0
#: each frame takes part in at most this many ground-plane pairs (those with the fewest plain inliers first):
#: a frame tied to three partners on the ground plane is placed, and the cost stays linear in the frames
GUIDED_PER_FRAME = 3
#: rays meeting the plane farther than this many camera heights from the nadir point are left out
REACH = 4.0
#: samples across a frame (cols, rows) for its ground box
_SAMPLES = (33, 23)


def _ground_points(camera, eo, height: float) -> np.ndarray:
    """``(n, 2)`` ground XY of a grid of the frame's pixels on the plane ``Z = height`` (module docstring)."""
    w, h = camera.image_size
    cols, rows = np.meshgrid(np.linspace(0, w, _SAMPLES[0]), np.linspace(0, h, _SAMPLES[1]))
    P = OrientedFrame(camera, eo).pixel_to_world_at(np.column_stack([cols.ravel(), rows.ravel()]), height)
    ok = np.isfinite(P).all(axis=1)
    P = P[ok]
    above = max(eo.Z - height, 1e-6)
    near = np.hypot(P[:, 0] - eo.X, P[:, 1] - eo.Y) <= REACH * above
    return P[near, :2]


def ground_window(camera, eo_i, eo_j, height: float, max_pixels: int):
    """``(x0, y0, cell, cols, rows)`` of the north-up ground grid both frames see (module docstring), or None
    when their boxes on the plane do not meet."""
    a, b = _ground_points(camera, eo_i, height), _ground_points(camera, eo_j, height)
    if len(a) < 3 or len(b) < 3:
        return None
    x0, y0 = max(a[:, 0].min(), b[:, 0].min()), max(a[:, 1].min(), b[:, 1].min())
    x1, y1 = min(a[:, 0].max(), b[:, 0].max()), min(a[:, 1].max(), b[:, 1].max())
    if x1 <= x0 or y1 <= y0:
        return None
    nadir = min(max(e.Z - height, 1e-6) for e in (eo_i, eo_j)) / max(camera.fx, camera.fy)
    cell = max(math.sqrt((x1 - x0) * (y1 - y0) / max_pixels), nadir)
    cols, rows = int(math.ceil((x1 - x0) / cell)), int(math.ceil((y1 - y0) / cell))
    if cols < 16 or rows < 16:
        return None
    return x0, y1, cell, cols, rows


def grid_to_pixels(camera, distortion, eo, height: float, window, xy) -> np.ndarray:
    """Frame pixels ``(n, 2)`` (corner convention, distortion included) of grid positions ``xy`` ``(n, 2)``
    (corner convention) of ``window``; NaN behind the camera."""
    from ...orientation import bundle_jacobian as bj
    x0, y0, cell = window[:3]
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    P = np.column_stack([x0 + xy[:, 0] * cell, y0 - xy[:, 1] * cell, np.full(len(xy), height)])
    c = OrientedFrame(camera, eo).world_to_camera(P)
    terms = [float(t) for t in (distortion or ())] + [0.0] * 5
    interior = np.array([camera.focal_length, *camera.principal_point, *terms[:5]])
    px = bj.project_camera(c, interior, bj.pixel_scale(camera))
    px[c[:, 2] <= 0] = np.nan
    return px


def resampled(image, camera, distortion, eo, height: float, window):
    """``(image float32, valid bool)``: the frame ``image`` (full resolution, NaN = nodata) on the grid of
    ``window`` (module docstring)."""
    import cv2
    cols, rows = window[3], window[4]
    gx, gy = np.meshgrid(np.arange(cols) + 0.5, np.arange(rows) + 0.5)
    px = grid_to_pixels(camera, distortion, eo, height, window, np.column_stack([gx.ravel(), gy.ravel()]))
    h, w = image.shape
    inside = np.isfinite(px).all(axis=1) & (px[:, 0] >= 0) & (px[:, 0] <= w) & (px[:, 1] >= 0) & (px[:, 1] <= h)
    m = np.where(inside[:, None], px - 0.5, -10.0).astype(np.float32)  # cv2: pixel centres at integers
    src = np.nan_to_num(image, nan=0.0).astype(np.float32)
    step = np.hypot(*np.diff(px.reshape(rows, cols, 2), axis=1).reshape(-1, 2).T)  # frame pixels per cell
    step = float(np.nanmedian(step)) if np.isfinite(step).any() else 1.0
    if step > 1.2:  # a frame finer than the grid: low-passed first (no aliasing)
        src = cv2.GaussianBlur(src, (0, 0), 0.5 * math.sqrt(step * step - 1.0))
    out = cv2.remap(src, m[:, 0].reshape(rows, cols), m[:, 1].reshape(rows, cols), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    valid = inside.reshape(rows, cols)
    if np.isnan(image).any():
        nod = cv2.remap(np.isnan(image).astype(np.float32), m[:, 0].reshape(rows, cols), m[:, 1].reshape(rows, cols),
                        cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=1)
        valid &= nod < 0.5
    return out, valid


def _stretched(image, valid):
    """0..255 with the 1st–99th percentiles of the valid cells stretched (the fused images' linear stretch)."""
    v = image[valid]
    lo, hi = (np.percentile(v, [1, 99]) if v.size else (0.0, 1.0))
    return np.clip((image - lo) * (255.0 / max(hi - lo, 1e-6)), 0, 255).astype(np.float32)


def guided_pair(images, camera, distortion, eos, height: float, opts, threshold: float, ideal, max_pixels: int):
    """``(matches, xy_i, xy_j)`` of one pair matched on the ground plane (module docstring; ``images`` and
    ``eos``: the two frames'), the epipolar inliers in frame pixels; None when the frames share no ground."""
    from ...features.detect import detect
    from ...features.match import match_descriptors
    from ...image.contrast import apply_contrast
    window = ground_window(camera, eos[0], eos[1], height, max_pixels)
    if window is None:
        return None
    kps = []
    for image, eo in zip(images, eos):
        img, valid = resampled(image, camera, distortion, eo, height, window)
        if valid.mean() < 0.02:
            return None
        img = apply_contrast(_stretched(img, valid), valid, opts.contrast)
        kps.append(detect(img, valid, opts.detector, max_keypoints=opts.max_keypoints,
                          hessian_threshold=opts.hessian_threshold))
    if min(len(k) for k in kps) < 2:
        return 0, np.zeros((0, 2)), np.zeros((0, 2))
    m = match_descriptors(kps[0].descriptors, kps[1].descriptors, ratio=opts.ratio, mutual=opts.mutual,
                          laplacian1=kps[0].laplacian, laplacian2=kps[1].laplacian)
    xy_i = grid_to_pixels(camera, distortion, eos[0], height, window, kps[0].xy[m.pairs[:, 0]])
    xy_j = grid_to_pixels(camera, distortion, eos[1], height, window, kps[1].xy[m.pairs[:, 1]])
    ok = np.isfinite(xy_i).all(axis=1) & np.isfinite(xy_j).all(axis=1)
    return epipolar_kept(xy_i[ok], xy_j[ok], ideal, threshold)


def ray_heights(camera, eos, xy_i, xy_j) -> np.ndarray:
    """Heights of the midpoints of the shortest segments between the rays of ``xy_i`` in frame i and ``xy_j``
    in frame j (approximate orientations ``eos``); NaN where the rays are parallel or meet behind a camera."""
    a, b = OrientedFrame(camera, eos[0]), OrientedFrame(camera, eos[1])
    ca, da = a._rays(xy_i)
    cb, db = b._rays(xy_j)
    w = ca - cb
    aa, bb, cc = np.sum(da * da, 1), np.sum(da * db, 1), np.sum(db * db, 1)
    dd, ee = np.sum(da * w, 1), np.sum(db * w, 1)
    den = aa * cc - bb * bb
    with np.errstate(divide="ignore", invalid="ignore"):
        s, t = (bb * ee - cc * dd) / den, (aa * ee - bb * dd) / den
    z = 0.5 * ((ca[2] + s * da[:, 2]) + (cb[2] + t * db[:, 2]))
    z[~((s > 0) & (t > 0) & (np.abs(den) > 1e-12 * aa * cc))] = np.nan
    return z


def _median_height(camera, eos, result):
    """The median ray height of a pair's inliers; None with fewer than ``MIN_PAIR_INLIERS`` of them."""
    from .pairs import MIN_PAIR_INLIERS
    if result is None or len(result[1]) < MIN_PAIR_INLIERS:
        return None
    z = float(np.nanmedian(ray_heights(camera, eos, result[1], result[2])))
    return z if np.isfinite(z) else None


def measured_pair(images, camera, distortion, eos, height: float, *args):
    """``(result, height)``: :func:`guided_pair` on the plane ``height``, and once more on the plane of its
    inliers' median ray height (:func:`ray_heights`) when that is more than a tenth of the cameras' height
    above ``height`` away (a terrain height nobody gave: the provisional one of the pair selection); the run
    with more inliers and the height measured on it (None with too few inliers)."""
    first = guided_pair(images, camera, distortion, eos, height, *args)
    z = _median_height(camera, eos, first)
    if z is None or abs(z - height) <= 0.1 * max(min(e.Z for e in eos) - height, 1e-6):
        return first, z
    again = guided_pair(images, camera, distortion, eos, z, *args)
    if again is not None and len(again[1]) > len(first[1]):
        return again, _median_height(camera, eos, again) or z
    return first, z


def guided_results(infos, pairs, found, camera, distortion, eos, height: float, opts, threshold: float, ideal,
                   max_pixels: int, progress=None):
    """``(found, guided, height)``: ``found`` (the plain pairs' ``(matches, xy_i, xy_j)`` or None, in pair
    order) with the result of the ground-plane matching in place of a pair's where it kept more inliers;
    ``guided`` one dict per pair tried (``{"pair", "matches", "inliers", "used", "height_m"}``); ``height``
    the median of the pairs' measured heights (None when none measured one). Pairs tried: fewer than
    :data:`GUIDED_BELOW` plain inliers or optical axes more than :data:`CONVERGING_DEG` apart, each frame in at
    most :data:`GUIDED_PER_FRAME` (:func:`_pairs_to_guide`); first on the plane
    of the median height the pairs before measured (``height`` until one did) (:func:`measured_pair`), then those
    still short of it once more on the plane of the measured height."""
    prog = as_progress(progress)
    found, rows = list(found), {}
    todo = _pairs_to_guide(found, pairs, eos)
    frames = _Frames(infos)
    dist = _distortion_terms(distortion)
    heights = []
    for n, k in enumerate(todo):
        i, j = pairs[k]
        prog(n / max(len(todo), 1) / 2, f"matching pair {k + 1} on the ground plane")
        plane = float(np.median(heights)) if heights else height  # the height measured so far
        got, z = _safe(measured_pair, frames.pair(i, j), camera, dist, (eos[i], eos[j]), plane, opts, threshold,
                       ideal, max_pixels)
        rows[k] = _take(found, k, got, pairs[k], z)
        heights += [] if z is None else [z]
    measured = float(np.median(heights)) if heights else None
    if measured is not None and abs(measured - height) > 1e-3:
        again = [k for k in todo if rows[k]["height_m"] is None]
        for n, k in enumerate(again):
            i, j = pairs[k]
            prog(0.5 + n / len(again) / 2, f"matching pair {k + 1} on the ground plane")
            got = _safe(guided_pair, frames.pair(i, j), camera, dist, (eos[i], eos[j]), measured, opts, threshold,
                        ideal, max_pixels)
            if got is not None and len(got[1]) > rows[k]["inliers"]:
                rows[k] = _take(found, k, got, pairs[k], measured)
    return found, [rows[k] for k in todo], measured


def _pairs_to_guide(found, pairs, eos) -> list:
    """Indices of the pairs to match on the ground plane: fewer than :data:`GUIDED_BELOW` plain inliers or axes
    more than :data:`CONVERGING_DEG` apart, the fewest plain inliers first, each frame in at most
    :data:`GUIDED_PER_FRAME` of them; returned in pair order."""
    def plain(k):
        return 0 if found[k] is None else len(found[k][1])
    wanted = [k for k in range(len(found)) if plain(k) < GUIDED_BELOW
              or axes_angle(eos[pairs[k][0]], eos[pairs[k][1]]) > CONVERGING_DEG]
    used, todo = {}, []
    for k in sorted(wanted, key=plain):
        i, j = pairs[k]
        if used.get(i, 0) < GUIDED_PER_FRAME and used.get(j, 0) < GUIDED_PER_FRAME:
            todo.append(k)
            used[i], used[j] = used.get(i, 0) + 1, used.get(j, 0) + 1
    return sorted(todo)


def axes_angle(eo_i, eo_j) -> float:
    """The angle (degrees) between two frames' optical axes."""
    a, b = eo_i.rotation[:, 2], eo_j.rotation[:, 2]
    return math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b)))))


class _Frames:
    """The grey frames of the pair at hand, the frames no longer needed dropped (two or three in memory)."""

    def __init__(self, infos):
        self.infos, self.cache = infos, {}

    def pair(self, i, j):
        self.cache = {f: v for f, v in self.cache.items() if f in (i, j)}
        for f in (i, j):
            if f not in self.cache:
                self.cache[f] = grey(self.infos[f])
        return self.cache[i], self.cache[j]


def _safe(fn, *args):
    """``fn(*args)``, None (or ``(None, None)`` for :func:`measured_pair`) where it raises a FotogeoError."""
    try:
        return fn(*args)
    except FotogeoError:
        return (None, None) if fn is measured_pair else None


def _take(found, k, got, pair, z) -> dict:
    """The report row of pair ``k``'s ground-plane result ``got``, put in ``found[k]`` when it kept more inliers."""
    if got is None:
        return {"pair": list(pair), "matches": 0, "inliers": 0, "used": False, "height_m": None}
    plain = 0 if found[k] is None else len(found[k][1])
    used = len(got[1]) > plain
    if used:
        found[k] = got
    return {"pair": list(pair), "matches": int(got[0]), "inliers": int(len(got[1])), "used": bool(used),
            "height_m": None if z is None else round(float(z), 2)}


def _distortion_terms(distortion) -> tuple:
    """``(k1, k2, k3, p1, p2)`` of a Block's tuple or a camera file's dict (zeros when absent)."""
    if isinstance(distortion, dict):
        return tuple(float(distortion.get(k, 0.0)) for k in ("k1", "k2", "k3", "p1", "p2"))
    return tuple(float(t) for t in (distortion or ())[:5])
