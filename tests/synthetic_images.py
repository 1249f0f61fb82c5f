"""Exact synthetic images for sub-pixel tests and benchmarks (shared by tests/ and benchmarks/)."""
import numpy as np

from fotogeo.matching import synthetic_x_target
from fotogeo.pixels import pixel_centres, to_centre


def warp(image, A, a=4):
    """search(y) = image(A⁻¹ y) on the same grid, Lanczos-``a`` interpolation (float64).

    Not cv2.warpAffine: it quantises positions to 1/32 px and its cubic kernel (a = −0.75)
    biases a 0.25–0.3 px shift by about 0.05 px on these images, which would spoil the truth.
    """
    H, W = image.shape
    X, Y = pixel_centres(W, H)
    B = np.linalg.inv(np.vstack([A, [0, 0, 1]]))[:2]
    src = to_centre(np.stack([X, Y], axis=-1) @ B[:, :2].T + B[:, 2])
    sx, sy = src[..., 0], src[..., 1]
    x0, y0 = np.floor(sx).astype(int), np.floor(sy).astype(int)
    pad = np.pad(image, a + 1, mode="reflect")
    taps = range(-a + 1, a + 1)
    wx = [np.sinc(sx - (x0 + i)) * np.sinc((sx - (x0 + i)) / a) for i in taps]
    wy = [np.sinc(sy - (y0 + j)) * np.sinc((sy - (y0 + j)) / a) for j in taps]
    out, wsum = np.zeros((H, W)), np.zeros((H, W))
    for j, wj in zip(taps, wy):
        rows = np.clip(y0 + j + a + 1, 0, pad.shape[0] - 1)
        for i, wi in zip(taps, wx):
            out += wi * wj * pad[rows, np.clip(x0 + i + a + 1, 0, pad.shape[1] - 1)]
            wsum += wi * wj
    return out / wsum


def x_target_scene(centres, shape=(200, 300), background=40.0, target=210.0, arm_width=3.0):
    """A flat image with X-shaped targets (radius 18 px) centred at ``centres`` (corner convention)."""
    img = np.full(shape, background)
    for c in np.asarray(centres, float):
        patch = synthetic_x_target((41, 41), c - np.floor(c) + 20, arm_width, target=target,
                                   background=background, radius=18)
        r0, c0 = int(np.floor(c[1])) - 20, int(np.floor(c[0])) - 20
        img[r0:r0 + 41, c0:c0 + 41] = np.maximum(img[r0:r0 + 41, c0:c0 + 41], patch)
    return img
