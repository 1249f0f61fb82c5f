"""A real image under a known warp: Landsat RGB as the reference, its warped, re-banded, noisy
copy (without georeference) as the target. Shared by tests/test_register.py and the benchmark."""
import cv2
import numpy as np
import rasterio

from fotogeo.pixels import pixel_centres, to_centre

# target pixel (corner convention) -> reference pixel: rotation 200°, scale 0.9, mild perspective
_C, _S = np.cos(np.radians(200)), np.sin(np.radians(200))
H_TRUE = np.array([[0.9 * _C, -0.9 * _S, 0], [0.9 * _S, 0.9 * _C, 0], [2e-5, -1e-5, 1.0]])


def apply_h(H, p):
    h = np.column_stack([p, np.ones(len(p))]) @ H.T
    return h[:, :2] / h[:, 2:]


def make_landsat_pair(ref, folder, w=640, h=600):
    """Write ``folder/target.tif``; return (reference, target, H: target px -> reference px)."""
    with rasterio.open(ref) as ds:
        img = ds.read()
        rw, rh = ds.width, ds.height
    c = apply_h(H_TRUE, [[w / 2, h / 2]])[0]  # centre the target on the reference
    H = np.array([[1, 0, rw / 2 - c[0]], [0, 1, rh / 2 - c[1]], [0, 0, 1]]) @ H_TRUE
    x, y = pixel_centres(w, h)
    src = to_centre(apply_h(H, np.column_stack([x.ravel(), y.ravel()])))
    mx, my = src[:, 0].reshape(h, w).astype(np.float32), src[:, 1].reshape(h, w).astype(np.float32)
    bands = [cv2.remap(b, mx, my, cv2.INTER_CUBIC, borderValue=0) for b in img]
    rng = np.random.default_rng(0)
    tgt_bands = np.stack([np.clip(bands[2] * 0.7 + 30 + rng.normal(0, 2, (h, w)), 1, 255),
                          np.clip(bands[0] * 1.1 + rng.normal(0, 2, (h, w)), 1, 255),
                          np.clip(bands[1] * 0.9 + 10 + rng.normal(0, 2, (h, w)), 1, 255)]).astype(np.uint8)
    tgt_bands[:, (np.stack(bands) == 0).all(axis=0)] = 0
    tgt = folder / "target.tif"
    with rasterio.open(tgt, "w", driver="GTiff", width=w, height=h, count=3, dtype="uint8", nodata=0) as ds:
        ds.write(tgt_bands)
    return ref, tgt, H
