"""Each frame resampled once onto the block's ground plane and detected there (the tool layer of ``fotogeo
triangulate``; the pairs are matched in :mod:`fotogeo.tools.triangulate.guided`).

* **Footprint** (:func:`footprint`): a grid of the frame's pixels projected onto the plane ``Z = h0`` (the
  block's terrain height) through its approximate orientation, rays reaching farther than :data:`REACH` × the
  camera's height above the plane left out (grazing rays towards the horizon); the convex hull of what is left.
* **One grid for the block** (:func:`block_grid`): north-up, on the plane ``Z = h0``, its corner the top-left of the
  frames' footprints; one cell for every frame, the median over the frames of ``sqrt(footprint area /
  max_pixels)``, never finer than the finest frame's nadir ground sample ``(Z0 − h0) / f``. Every frame's tile
  (:func:`tile`) is a window of whole cells of that grid, so that a keypoint's grid position is the same ground
  point in every tile: two frames' keypoints are compared with no transformation between them.
* **Resampled once** (:func:`resampled`): a cell centre ``(X, Y, h0)`` goes through the camera (distortion
  included, :func:`fotogeo.orientation.bundle_jacobian.project_camera`) to its pixel, the frame is sampled there
  (bilinear; ``cv2.remap``; a frame finer than the grid by ``s`` frame pixels per cell is low-passed first, Gaussian
  σ = ``0.5·sqrt(s² − 1)``); cells whose ray misses the frame are invalid. Over flat ground two frames' tiles
  differ by a translation of the orientation error and the relief parallax only.
* **Detected once** (:func:`ground_features`): the tile stretched (1st–99th percentiles) and detected with the
  options' detector (:func:`fotogeo.features.detect.detect`); the keypoints kept in grid coordinates.
* **Back to the frame** (:func:`grid_to_pixels`): a grid position goes back through the same projection (exact,
  not an inverse homography: the distortion is in it).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...geometry.camera import OrientedFrame

#: rays meeting the plane farther than this many camera heights from the nadir point are left out
REACH = 4.0
#: samples across a frame (cols, rows) for its footprint
_SAMPLES = (33, 23)


def _ground_points(camera, eo, height: float) -> np.ndarray:
    """``(n, 2)`` ground XY of a grid of the frame's pixels on the plane ``Z = height`` (module docstring)."""
    w, h = camera.image_size
    cols, rows = np.meshgrid(np.linspace(0, w, _SAMPLES[0]), np.linspace(0, h, _SAMPLES[1]))
    P = OrientedFrame(camera, eo).pixel_to_world_at(np.column_stack([cols.ravel(), rows.ravel()]), height)
    P = P[np.isfinite(P).all(axis=1)]
    above = max(eo.Z - height, 1e-6)
    near = np.hypot(P[:, 0] - eo.X, P[:, 1] - eo.Y) <= REACH * above
    return P[near, :2]


def footprint(camera, eo, height: float):
    """The frame's footprint on the plane ``Z = height`` (a shapely polygon; module docstring), or None when
    fewer than three of its rays reach the plane within :data:`REACH`."""
    from shapely.geometry import MultiPoint
    pts = _ground_points(camera, eo, height)
    if len(pts) < 3:
        return None
    hull = MultiPoint([tuple(p) for p in pts]).convex_hull
    return hull if hull.area > 0 else None


def block_grid(camera, eos, footprints, height: float, max_pixels: int):
    """``(x0, y0, cell)``: the top-left corner and the cell (m) of the block's ground grid over the frames whose
    ``footprints`` are given (not None) (module docstring); None when none is."""
    have = [(eo, fp) for eo, fp in zip(eos, footprints) if fp is not None]
    if not have:
        return None
    nadir = min(max(eo.Z - height, 1e-6) for eo, _ in have) / max(camera.fx, camera.fy)
    cell = max(float(np.median([math.sqrt(fp.area / max_pixels) for _, fp in have])), nadir)
    x0 = min(fp.bounds[0] for _, fp in have)
    y0 = max(fp.bounds[3] for _, fp in have)
    return x0, y0, cell


def tile(grid, fp):
    """``(window, offset)`` of the footprint ``fp`` on the block's grid: ``window`` ``(x0, y0, cell, cols,
    rows)`` of its own top-left cell, ``offset`` ``(col, row)`` of that cell in the block grid."""
    x0, y0, cell = grid
    minx, miny, maxx, maxy = fp.bounds
    c0, r0 = int(math.floor((minx - x0) / cell)), int(math.floor((y0 - maxy) / cell))
    c1, r1 = int(math.ceil((maxx - x0) / cell)), int(math.ceil((y0 - miny) / cell))
    return (x0 + c0 * cell, y0 - r0 * cell, cell, max(c1 - c0, 1), max(r1 - r0, 1)), (c0, r0)


def grid_to_pixels(camera, distortion, eo, height: float, window, xy) -> np.ndarray:
    """Frame pixels ``(n, 2)`` (corner convention, distortion included) of grid positions ``xy`` ``(n, 2)``
    (corner convention) of ``window`` (its ``(x0, y0, cell)`` first); NaN behind the camera."""
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


#: the exact projection of :func:`resampled` on every this-many cells, bilinear between
_LATTICE = 4


def _pixel_map(camera, distortion, eo, height: float, window) -> np.ndarray:
    """``(rows * cols, 2)`` frame pixels of the cell centres of ``window``: :func:`grid_to_pixels` on every
    :data:`_LATTICE`-th cell (and the last), interpolated bilinearly between (the projection is smooth over a
    few cells; NaN spreads to the cells next to a ray behind the camera)."""
    import cv2
    cols, rows = window[3], window[4]
    cx = np.append(np.arange(0, cols, _LATTICE), cols - 1).astype(float)
    cy = np.append(np.arange(0, rows, _LATTICE), rows - 1).astype(float)
    gx, gy = np.meshgrid(cx + 0.5, cy + 0.5)
    coarse = grid_to_pixels(camera, distortion, eo, height, window, np.column_stack([gx.ravel(), gy.ravel()]))
    coarse = coarse.reshape(len(cy), len(cx), 2).astype(np.float32)
    # the fractional lattice index of every cell (the last lattice step may be shorter)
    fx = np.interp(np.arange(cols), cx, np.arange(len(cx))).astype(np.float32)
    fy = np.interp(np.arange(rows), cy, np.arange(len(cy))).astype(np.float32)
    mx, my = np.meshgrid(fx, fy)
    out = [cv2.remap(np.ascontiguousarray(coarse[..., k]), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
           for k in range(2)]
    return np.column_stack([out[0].ravel(), out[1].ravel()]).astype(np.float64)


def resampled(image, camera, distortion, eo, height: float, window):
    """``(image float32, valid bool)``: the frame ``image`` (full resolution, NaN = nodata) on the grid of
    ``window`` (module docstring)."""
    import cv2
    cols, rows = window[3], window[4]
    px = _pixel_map(camera, distortion, eo, height, window)
    h, w = image.shape
    inside = np.isfinite(px).all(axis=1) & (px[:, 0] >= 0) & (px[:, 0] <= w) & (px[:, 1] >= 0) & (px[:, 1] <= h)
    m = np.where(inside[:, None], px - 0.5, -10.0).astype(np.float32)  # cv2: pixel centres at integers
    src = np.nan_to_num(image, nan=0.0).astype(np.float32)
    step = np.hypot(*np.diff(px.reshape(rows, cols, 2), axis=1).reshape(-1, 2).T)  # frame pixels per cell
    step = float(np.nanmedian(step)) if np.isfinite(step).any() else 1.0
    if step > 1.2:  # a frame finer than the grid: low-passed first (no aliasing)
        src = cv2.GaussianBlur(src, (0, 0), 0.5 * math.sqrt(step * step - 1.0))
    mx, my = m[:, 0].reshape(rows, cols), m[:, 1].reshape(rows, cols)
    out = cv2.remap(src, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    valid = inside.reshape(rows, cols)
    if np.isnan(image).any():
        nod = cv2.remap(np.isnan(image).astype(np.float32), mx, my, cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=1)
        valid &= nod < 0.5
    return out, valid


def _stretched(image, valid):
    """0..255 with the 1st–99th percentiles of the valid cells stretched (the fused images' linear stretch)."""
    v = image[valid]
    lo, hi = (np.percentile(v, [1, 99]) if v.size else (0.0, 1.0))
    return np.clip((image - lo) * (255.0 / max(hi - lo, 1e-6)), 0, 255).astype(np.float32)


@dataclasses.dataclass
class GroundFeatures:
    """One frame's keypoints on the block's ground grid: ``xy`` ``(n, 2)`` grid positions (corner convention of
    the block grid), ``descriptors``, ``laplacian`` (SURF's sign, or None)."""

    xy: np.ndarray
    descriptors: np.ndarray
    laplacian: np.ndarray | None


def ground_features(image, camera, distortion, eo, height: float, grid, fp, opts):
    """The :class:`GroundFeatures` of one frame (``image``: full resolution, NaN = nodata) resampled onto its tile
    of the block ``grid`` (module docstring), or None when less than 2 % of the tile is valid."""
    from ...features.detect import detect
    from ...image.contrast import apply_contrast
    window, (c0, r0) = tile(grid, fp)
    img, valid = resampled(image, camera, distortion, eo, height, window)
    if valid.mean() < 0.02:
        return None
    img = apply_contrast(_stretched(img, valid), valid, opts.contrast)
    kp = detect(img, valid, opts.detector, max_keypoints=opts.max_keypoints, hessian_threshold=opts.hessian_threshold)
    lap = getattr(kp, "laplacian", None)
    return GroundFeatures(np.asarray(kp.xy, np.float64) + [c0, r0], kp.descriptors, lap)
