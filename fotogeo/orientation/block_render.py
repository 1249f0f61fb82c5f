"""Rendered frames of a synthetic block (array layer): images to match, with known truth.

:func:`render_block` gives every frame of a :class:`~fotogeo.orientation.block_simulation.SyntheticBlock`
an image: a ground texture (an orthophoto-like grid over the block: fractal noise of several
octaves, as the demo scene's, plus random bright and dark patches — fields, roofs — for
corners and blobs) is draped on the terrain, and each frame pixel's ray, through the true
camera *with its distortion* (Brown's and Ebner's;
:func:`~fotogeo.orientation.bundle_jacobian.undistort_rays`), is intersected with the terrain
(:meth:`fotogeo.geometry.camera.OrientedFrame.pixel_to_world` on a DEM sampled from the block's
surface) and the texture sampled there (bilinear). Gaussian grey noise of ``noise`` levels is
added. Pixel centres follow the corner convention (:func:`fotogeo.pixels.pixel_centres`), the
texture is sampled through :func:`fotogeo.pixels.to_centre`.
"""
from __future__ import annotations

import cv2
import numpy as np
from affine import Affine

from ..geometry.camera import FrameCamera, OrientedFrame
from ..geometry.dem import Dem
from ..pixels import pixel_centres, to_centre
from . import bundle_jacobian as bj
from .block_simulation import true_interior


def _fractal(rng, shape, octaves=8, persistence=0.8):
    out = np.zeros(shape, np.float32)
    amp = 1.0
    for o in range(octaves):
        n = 2 ** (o + 2)
        out += amp * cv2.resize(rng.normal(size=(n, n)).astype(np.float32), shape[::-1], interpolation=cv2.INTER_CUBIC)
        amp *= persistence
    return (out - out.mean()) / out.std()


def texture(rng, shape) -> np.ndarray:
    """A float32 ground texture 0..255 of ``shape`` (rows, cols): fractal noise and patches (one per 2000 cells)."""
    img = 128 + 40 * _fractal(rng, shape)
    rows, cols = shape
    n_patches = rows * cols // 2000
    for _ in range(n_patches):
        r, c = rng.integers(0, rows), rng.integers(0, cols)
        h, w = rng.integers(4, max(5, rows // 60)), rng.integers(4, max(5, cols // 60))
        img[r:r + h, c:c + w] += rng.choice([-60.0, 60.0])
    return np.clip(img, 0, 255).astype(np.float32)


def _extent(sb):
    """``(x0, y0, x1, y1)``: west, north, east, south edges of the rendered ground (the block's points and a
    margin of 0.3 frame diagonals)."""
    xyz = sb.true_xyz
    margin = 0.3 * np.hypot(*sb.true_camera.image_size) * sb.gsd
    return xyz[:, 0].min() - margin, xyz[:, 1].max() + margin, xyz[:, 0].max() + margin, xyz[:, 1].min() - margin


def _texture(sb, rng, texture_pixel):
    x0, y0, x1, y1 = _extent(sb)
    tp = texture_pixel or sb.gsd / 2
    return texture(rng, (int((y0 - y1) / tp) + 1, int((x1 - x0) / tp) + 1)), Affine(tp, 0, x0, 0, -tp, y0)


def ground_texture(sb, *, texture_pixel: float | None = None, seed=0):
    """``(texture, transform)``: the ground texture :func:`render_block` with the same ``texture_pixel`` and
    ``seed`` drapes on the terrain — the true orthophoto of the rendered frames (grey values before noise)."""
    return _texture(sb, np.random.default_rng(seed), texture_pixel)


def render_block(sb, *, texture_pixel: float | None = None, noise: float = 2.0, seed=0):
    """``(images, dem)``: one uint8 ``(rows, cols)`` image per frame of ``sb`` and the DEM used
    (module docstring). ``texture_pixel`` (m) defaults to half the ground sample distance."""
    rng = np.random.default_rng(seed)
    cam = sb.true_camera
    x0, y0, x1, y1 = _extent(sb)
    cell = 4 * sb.gsd
    gx, gy = pixel_centres(int((x1 - x0) / cell) + 1, int((y0 - y1) / cell) + 1)
    dem_t = Affine(cell, 0, x0, 0, -cell, y0)
    XY = np.column_stack([dem_t.c + gx.ravel() * cell, dem_t.f - gy.ravel() * cell])
    dem = Dem(sb.surface(XY).reshape(gx.shape), dem_t)
    tex, tex_t = _texture(sb, rng, texture_pixel)
    tp = tex_t.a
    interior = true_interior(cam, sb.true_distortion, sb.true_additional)
    scale = bj.pixel_scale(cam)
    ideal_cam = FrameCamera(cam.focal_length, cam.sensor_size, cam.image_size, cam.principal_point)
    w, h = cam.image_size
    cx, cy = pixel_centres(w, h)
    pix = np.column_stack([cx.ravel(), cy.ravel()])
    rays = bj.undistort_rays(pix, interior, scale)  # distortion removed: the ideal pinhole pixel
    ideal = np.column_stack([cam.principal_point[0] + cam.fx * rays[:, 0], cam.principal_point[1] + cam.fy * rays[:, 1]])
    images = []
    for eo in sb.true_eo:
        ground = OrientedFrame(ideal_cam, eo).pixel_to_world(ideal, dem)
        col = (ground[:, 0] - tex_t.c) / tp
        row = (tex_t.f - ground[:, 1]) / tp
        m = to_centre(np.column_stack([col, row])).astype(np.float32)
        m[~np.isfinite(m)] = -1.0
        img = cv2.remap(tex, m[:, 0].reshape(h, w), m[:, 1].reshape(h, w), cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        img = img + rng.normal(0, noise, img.shape).astype(np.float32)
        images.append(np.clip(np.round(img), 1, 255).astype(np.uint8))
    return images, dem
