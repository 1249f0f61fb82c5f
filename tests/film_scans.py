"""Synthetic scans of film frames with known truth (tests and benchmarks): a film border, fiducial marks
of a camera layout rendered by area sampling where the scan's affine distortion puts them, a photo in
the image area (an NGI frame when given, else smooth texture), a scan rotation (k·90° + a few degrees),
scanner noise. Truth: the photo → pixel affine and every mark's scan position (corner convention)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: layouts after two common aerial cameras (8 marks: corners and mid-sides; 4 mid-side marks), mm
RC_LIKE = {"1": (-106.0, 106.0), "2": (106.0, 106.0), "3": (106.0, -106.0), "4": (-106.0, -106.0),
           "5": (0.0, 112.0), "6": (112.0, 0.0), "7": (0.0, -112.0), "8": (-112.0, 0.0)}
RMK_LIKE = {"1": (-113.0, 0.0), "2": (0.0, 113.0), "3": (113.0, 0.0), "4": (0.0, -113.0)}
#: corner marks only make sense in the corners: the corners of RC_LIKE
CORNERS = {k: RC_LIKE[k] for k in "1234"}


@dataclass
class Scan:
    image: np.ndarray  # (rows, cols) uint8
    A: np.ndarray  # (2, 3) photo mm -> scan pixel (corner convention)
    marks: dict  # id -> (col, row) truth


def photo_to_pixel(pixel_mm, size, k90=0, theta=0.0, scale=(1.0, 1.0), skew=0.0, offset=(0.0, 0.0)):
    """(2, 3) photo mm -> pixel: R(k·90° + θ) · [[sx, skew], [0, sy]] · diag(1, −1) / p, centred in ``size``."""
    t = np.deg2rad(90 * k90 + theta)
    R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    L = R @ np.array([[scale[0], skew], [0.0, scale[1]]]) @ np.diag([1.0, -1.0]) / pixel_mm
    return np.column_stack([L, np.array(size, float) / 2 + np.asarray(offset, float)])


def _mark_inside(u, v, kind, size, width, centre_sign):
    if kind == "dot":
        return u * u + v * v <= (size / 2) ** 2
    r2 = u * u + v * v <= (size / 2) ** 2
    if kind == "corner":  # the quadrant opening towards the frame centre (photo axes, y up)
        return r2 & (u * -centre_sign[0] >= 0) & (v * -centre_sign[1] >= 0)
    base = 45.0 if kind == "x" else 0.0
    hit = np.zeros(u.shape, bool)
    for a in np.deg2rad([base, base + 90]):
        hit |= np.abs(-np.sin(a) * u + np.cos(a) * v) <= width / 2
    return hit & r2


def render_scan(layout: dict, *, pixel_mm=0.15, film_mm=240.0, image_mm=200.0, kind="x", size_mm=6.0,
                width_mm=0.6, k90=0, theta=1.5, scale=(1.002, 0.998), skew=0.001, offset=(7.3, -4.6), noise=2.0,
                content=None, missing=(), seed=0) -> Scan:
    """Render a scan (module docstring); marks in ``missing`` are left out (cut off or damaged).
    ``image_mm``: the image area's side, or its ``(width, height)`` (a rectangular frame)."""
    rng = np.random.default_rng(seed)
    image_mm = np.broadcast_to(np.asarray(image_mm, float), (2,))
    n = int(np.ceil(film_mm / pixel_mm))
    A = photo_to_pixel(pixel_mm, (n, n), k90, theta, scale, skew, offset)
    Ai = np.linalg.inv(np.vstack([A, [0, 0, 1]]))[:2]
    rows, cols = np.mgrid[0:n, 0:n] + 0.5
    x = Ai[0, 0] * cols + Ai[0, 1] * rows + Ai[0, 2]
    y = Ai[1, 0] * cols + Ai[1, 1] * rows + Ai[1, 2]
    img = np.full((n, n), 35.0)
    inside = (np.abs(x) < image_mm[0] / 2) & (np.abs(y) < image_mm[1] / 2)
    img[inside] = _content(x[inside], y[inside], image_mm, content, rng)
    marks = {}
    for fid, (fx, fy) in layout.items():
        c, r = A @ [fx, fy, 1.0]
        marks[fid] = (float(c), float(r))
        if fid in missing:
            continue
        h = int(np.ceil(size_mm / 2 / pixel_mm * max(scale) * (1 + abs(skew)))) + 3
        r0, c0 = int(r) - h, int(c) - h
        sub = (np.arange(8) + 0.5) / 8
        cc = (np.arange(c0, c0 + 2 * h)[:, None] + sub).reshape(-1)
        rr = (np.arange(r0, r0 + 2 * h)[:, None] + sub).reshape(-1)
        C, Rr = np.meshgrid(cc, rr)
        u = Ai[0, 0] * C + Ai[0, 1] * Rr + Ai[0, 2] - fx
        v = Ai[1, 0] * C + Ai[1, 1] * Rr + Ai[1, 2] - fy
        cover = _mark_inside(u, v, kind, size_mm, width_mm, (np.sign(fx), np.sign(fy)))
        cover = cover.reshape(2 * h, 8, 2 * h, 8).mean(axis=(1, 3))
        patch = img[r0:r0 + 2 * h, c0:c0 + 2 * h]
        img[r0:r0 + 2 * h, c0:c0 + 2 * h] = patch * (1 - cover) + 225.0 * cover
    img = np.clip(img + rng.normal(0, noise, img.shape), 0, 255).astype(np.uint8)
    return Scan(img, A, marks)


def _content(x, y, image_mm, content, rng):
    """Grey values of the image area at photo (x, y) mm: ``content`` (2-D array) stretched over it, or texture."""
    if content is None:
        return 120 + 40 * np.sin(x / 7.0) * np.cos(y / 5.0) + 20 * np.sin((x + y) / 2.3)
    from scipy.ndimage import map_coordinates
    h, w = content.shape
    mx = (x / image_mm[0] + 0.5) * w - 0.5
    my = (0.5 - y / image_mm[1]) * h - 0.5
    return map_coordinates(content.astype(np.float64), [my, mx], order=1, mode="nearest")


def report_yaml(layout: dict, *, focal=153.0, pp=(0.01, -0.02), kind="x", size_mm=6.0, width_mm=0.6,
                polarity="bright", frame_mm=None) -> str:
    """The calibration report YAML of a layout."""
    lines = ["camera: synthetic", f"focal_mm: {focal}", f"principal_point_mm: [{pp[0]}, {pp[1]}]", "fiducials_mm:"]
    lines += [f"  {k}: [{x}, {y}]" for k, (x, y) in layout.items()]
    lines += [f"mark: {kind}", f"mark_size_mm: {size_mm}", f"mark_width_mm: {width_mm}", f"polarity: {polarity}"]
    if frame_mm:
        lines.append(f"frame_mm: [{frame_mm[0]}, {frame_mm[1]}]")
    return "\n".join(lines) + "\n"
