"""Scene pairs for the batch tests and benchmark: Landsat RGB as the reference, each target a crop
of it under a known similarity-plus-perspective warp (rotation, scale and position vary with the
scene number), re-banded and noisy, without georeference; and a scene that cannot match."""
from __future__ import annotations

import json

import cv2
import numpy as np
import rasterio

from fotogeo.models import model_from_dict
from fotogeo.pixels import pixel_centres, pixel_to_map, to_centre
from synthetic_pair import apply_h


def scene_warp(k: int, ref_size, size: int) -> np.ndarray:
    """Target pixel -> reference pixel homography of scene ``k`` (deterministic)."""
    rng = np.random.default_rng(1000 + k)
    angle, scale = np.radians(rng.uniform(-180, 180)), rng.uniform(0.85, 1.15)
    c, s = np.cos(angle) * scale, np.sin(angle) * scale
    H = np.array([[c, -s, 0], [s, c, 0], [rng.uniform(-2e-5, 2e-5), rng.uniform(-2e-5, 2e-5), 1.0]])
    centre = apply_h(H, [[size / 2, size / 2]])[0]
    rw, rh = ref_size
    target_centre = [rw / 2 + rng.uniform(-0.15, 0.15) * rw, rh / 2 + rng.uniform(-0.15, 0.15) * rh]
    return np.array([[1, 0, target_centre[0] - centre[0]], [0, 1, target_centre[1] - centre[1]], [0, 0, 1]]) @ H


def make_scene(ref, folder, k: int, size: int = 320):
    """Write ``folder/scene_<k>.tif``; return (path, H: target px -> reference px)."""
    with rasterio.open(ref) as ds:
        img, rw, rh = ds.read(), ds.width, ds.height
    H = scene_warp(k, (rw, rh), size)
    x, y = pixel_centres(size, size)
    src = to_centre(apply_h(H, np.column_stack([x.ravel(), y.ravel()])))
    mx, my = (src[:, i].reshape(size, size).astype(np.float32) for i in (0, 1))
    bands = np.stack([cv2.remap(b, mx, my, cv2.INTER_CUBIC, borderValue=0) for b in img])
    rng = np.random.default_rng(k)
    out = np.stack([np.clip(bands[2] * 0.8 + 20 + rng.normal(0, 2, (size, size)), 1, 255),
                    np.clip(bands[0] * 1.1 + rng.normal(0, 2, (size, size)), 1, 255),
                    np.clip(bands[1] * 0.9 + 10 + rng.normal(0, 2, (size, size)), 1, 255)]).astype(np.uint8)
    out[:, (bands == 0).all(axis=0)] = 0
    path = folder / f"scene_{k:03d}.tif"
    with rasterio.open(path, "w", driver="GTiff", width=size, height=size, count=3, dtype="uint8", nodata=0) as ds:
        ds.write(out)
    return path, H


def make_unmatchable(folder, name: str = "noise.tif", size: int = 200):
    """A scene of pure noise: nothing of the reference in it (registration must fail)."""
    data = np.random.default_rng(7).integers(1, 255, (1, size, size), dtype=np.uint8)
    path = folder / name
    with rasterio.open(path, "w", driver="GTiff", width=size, height=size, count=1, dtype="uint8") as ds:
        ds.write(data)
    return path


def model_error_px(report_path, ref, H, size: int) -> float:
    """RMS distance (reference pixels) between the registered model and the known warp over a
    dense grid of the target (the report's model, target pixel -> output map)."""
    rep = json.loads(open(report_path, encoding="utf-8").read())
    model = model_from_dict(rep["model"])
    with rasterio.open(ref) as ds:
        t = ds.transform
    x, y = pixel_centres(16, 16)
    grid = np.column_stack([x.ravel(), y.ravel()]) * (size / 16)
    err = np.hypot(*(model.forward(grid) - pixel_to_map(t, apply_h(H, grid))).T)
    return float(np.sqrt(np.mean(err ** 2)) / t.a)
