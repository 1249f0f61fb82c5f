"""Real images under exact projective warps (issue 19), shared by tests/test_register_precision.py and
benchmarks/register_precision_bench.py.

A real image is the georeferenced reference; the target is the same image under ``H`` (target
pixel -> reference pixel, corner convention: rotation, scale, perspective), sampled at full
float64 precision with the Keys bicubic kernel of :func:`fotogeo.matching.interpolation.sample`
(``cv2.remap`` would quantise positions to 1/32 px), after a Gaussian pre-filter when the target
is coarser than the reference (no aliasing), then given another radiometry (gain 0.8, offset +20,
Gaussian noise σ 1 grey level, uint8, nodata 0 where the reference does not cover it).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from synthetic_pair import apply_h

#: name -> (image under the data folder, crop (col, row, width, height) or None, target size)
IMAGES = {
    "ngi": ("ngi/ortho/ngi_rgb_byte_1.tif", None, 600),
    "s2": ("ngi/sentinel2_b432_byte.tif", (100, 380, 600, 600), 500),
    "landsat": ("landsat_rgb/RGB.byte.tif", (245, 209, 300, 300), 300),
}
#: name -> (rotation degrees, scale (target px in reference px), perspective (h31, h32) x target size)
WARPS = {
    "r30_s0.85_p": (30.0, 0.85, (0.06, -0.04)),
    "r200_s0.9_p": (200.0, 0.9, (0.05, 0.03)),
    "r45_s1.2_p": (45.0, 1.2, (-0.04, 0.06)),
}


def warp_matrix(deg: float, scale: float, persp, size: int, ref_centre) -> np.ndarray:
    """H: target pixel -> reference pixel (corner convention), the target centre on ``ref_centre``."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    A = np.array([[scale * c, -scale * s, 0.0], [scale * s, scale * c, 0.0], [0.0, 0.0, 1.0]])
    P = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [persp[0] / size, persp[1] / size, 1.0]])
    T = np.array([[1.0, 0.0, -size / 2], [0.0, 1.0, -size / 2], [0.0, 0.0, 1.0]])
    H = A @ P @ T
    centre = apply_h(H, np.array([[size / 2, size / 2]]))[0]
    return np.array([[1, 0, ref_centre[0] - centre[0]], [0, 1, ref_centre[1] - centre[1]], [0, 0, 1]]) @ H


def reference_image(data: Path, name: str, folder: Path) -> Path:
    """The reference of ``name``: the file itself, or its crop written as a GeoTIFF into ``folder``."""
    import rasterio
    from rasterio.windows import Window
    rel, crop, _ = IMAGES[name]
    path = Path(data) / rel
    if crop is None:
        return path
    out = Path(folder) / f"{name}_reference.tif"
    with rasterio.open(path) as ds:
        win = Window(*crop)
        data = ds.read(window=win)
        profile = dict(driver="GTiff", width=crop[2], height=crop[3], count=ds.count, dtype=ds.dtypes[0],
                       crs=ds.crs, transform=ds.window_transform(win), nodata=ds.nodata)
    with rasterio.open(out, "w", **profile) as dst:
        dst.write(data)
    return out


def warped_target(reference: Path, H, size: int, scale: float, out: Path, seed: int = 0) -> np.ndarray:
    """Write the ``size`` x ``size`` target ``out``: ``reference`` under ``H`` (module docstring);
    returns the mask of target pixels whose interpolation support is valid reference."""
    import cv2
    import rasterio
    from fotogeo.matching.interpolation import sample
    from fotogeo.pixels import pixel_centres, to_centre
    with rasterio.open(reference) as ds:
        img = ds.read().astype(np.float64)
        nodata = ds.nodata
    valid_ref = np.ones(img.shape[1:], bool) if nodata is None else ~(img == nodata).all(axis=0)
    x, y = pixel_centres(size, size)
    src = to_centre(apply_h(H, np.column_stack([x.ravel(), y.ravel()])))
    rng = np.random.default_rng(seed)
    sigma = 0.5 * np.sqrt(max(scale ** 2 - 1.0, 0.0))  # coarser target: pre-filter, no aliasing
    bands, inside = [], np.ones(size * size, bool)
    for b in img:
        if sigma > 0:
            b = cv2.GaussianBlur(b, (0, 0), sigma)
        v, ok = sample(b, src[:, 0], src[:, 1], "bicubic")
        inside &= ok
        bands.append(v)
    vr, _ = sample(valid_ref.astype(np.float64), src[:, 0], src[:, 1], "bilinear")
    inside &= np.nan_to_num(vr) > 0.999
    out_bands = []
    for v in bands:
        t = np.clip(np.round(0.8 * np.nan_to_num(v) + 20 + rng.normal(0, 1.0, v.shape)), 1, 255)
        t[~inside] = 0
        out_bands.append(t.reshape(size, size).astype(np.uint8))
    with rasterio.open(out, "w", driver="GTiff", width=size, height=size, count=len(out_bands), dtype="uint8",
                       nodata=0) as ds:
        ds.write(np.stack(out_bands))
    return inside.reshape(size, size)


def dense_grid(inside: np.ndarray, n: int = 20) -> np.ndarray:
    """Target pixels on an ``n x n`` grid whose pixel lies inside the reference's valid area."""
    size = inside.shape[0]
    c = (np.arange(n) + 0.5) * size / n
    gx, gy = np.meshgrid(c, c)
    g = np.column_stack([gx.ravel(), gy.ravel()])
    return g[inside[g[:, 1].astype(int), g[:, 0].astype(int)]]


def known_warp(data: Path, name: str, warp: str, folder: Path):
    """``(reference, target, grid, truth)``: the pair of ``name`` under ``warp`` written into ``folder``, a
    dense grid of target pixels and their true reference map positions (the reference's CRS)."""
    import rasterio
    from fotogeo.pixels import pixel_to_map
    ref = reference_image(data, name, folder)
    with rasterio.open(ref) as ds:
        t_ref, rw, rh = ds.transform, ds.width, ds.height
    size = IMAGES[name][2]
    deg, scale, persp = WARPS[warp]
    H = warp_matrix(deg, scale, persp, size, (rw / 2, rh / 2))
    tgt = Path(folder) / f"{name}_{warp}.tif"
    grid = dense_grid(warped_target(ref, H, size, scale, tgt))
    return ref, tgt, grid, pixel_to_map(t_ref, apply_h(H, grid))


#: band sets (other sensors' band counts) built from a real RGB image's bands R, G, B (float): name ->
#: (reference bands, target bands); the extra bands are fixed combinations of the real ones, as a
#: multispectral sensor's NIR, red-edge or SWIR bands relate to the visible (not the same PCA as RGB)
BAND_SETS = {
    "ref8_tgt3": ("rgb8", "rgb"),  # the 8-band reference's bands 2-4 are the target's 3 (reversed)
    "ref4_tgt1": ("rgbn", "pan"),
    "ref3_tgt2": ("rgb", "ng"),
    "ref3_tgtN": ("rgb", "n"),  # a NIR-only target: its vegetation bright where the visible bands are dark
    "ref3_tgtS": ("rgb", "s"),  # a SWIR-only target: water dark, the visible bands mixed in other weights
    "ref1_tgt3": ("pan", "rgb"),  # a panchromatic reference, an RGB target
    "ref8_tgt1": ("rgb8", "r"),  # an 8-band reference, a red-only target
}


def derived_bands(rgb: np.ndarray, kind: str) -> np.ndarray:
    """The bands ``kind`` from ``rgb`` (3, rows, cols) float: ``rgb``; ``rgbn`` + a NIR-like band;
    ``rgb8`` as an 8-band sensor (coastal, B, G, R, red edge, NIR, SWIR 1, SWIR 2); ``pan`` the mean of
    R, G, B; ``ng`` the NIR-like band and G; ``n`` the NIR-like band alone; ``s`` the first SWIR-like band
    alone; ``r`` R alone. The NIR-like band
    is bright where green exceeds red (vegetation) and dark where blue exceeds green (water): not a monotone
    function of the brightness, as real NIR is not, so the 8-band PCA is not the RGB one."""
    R, G, B = rgb
    nir = np.clip(60 + R + 3.0 * (G - R) - 2.0 * np.maximum(B - G, 0), 0, 255)
    swir1 = np.clip(30 + 0.9 * R + 0.3 * G - 1.5 * np.maximum(B - G, 0), 0, 255)
    if kind == "rgb":
        return rgb
    if kind == "pan":
        return ((R + G + B) / 3)[None]
    if kind == "ng":
        return np.stack([nir, G])
    if kind == "n":
        return nir[None]
    if kind == "s":
        return swir1[None]
    if kind == "r":
        return R[None]
    if kind == "rgbn":
        return np.stack([R, G, B, nir])
    return np.stack([np.clip(0.8 * B + 25, 0, 255), B, G, R, 0.5 * (R + nir), nir, swir1, 0.7 * swir1 + 10])


def _write_like(path: Path, like: Path, bands: np.ndarray) -> Path:
    import rasterio
    with rasterio.open(like) as ds:
        profile = ds.profile.copy()
        nodata_px = (ds.read() == ds.nodata).all(axis=0) if ds.nodata is not None else None
    out = np.clip(np.round(bands), 1 if nodata_px is not None else 0, 255).astype(np.uint8)
    if nodata_px is not None:
        out[:, nodata_px] = profile["nodata"]
    profile.update(driver="GTiff", count=len(out), dtype="uint8")
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(out)
    return path


def known_warp_bands(data: Path, name: str, warp: str, band_set: str, folder: Path):
    """:func:`known_warp` with the reference and the target in the bands of ``BAND_SETS[band_set]``."""
    import rasterio
    from fotogeo.pixels import pixel_to_map
    rgb_ref = reference_image(data, name, folder)
    with rasterio.open(rgb_ref) as ds:
        rgb, t_ref, rw, rh = ds.read()[:3].astype(np.float64), ds.transform, ds.width, ds.height
    kinds = BAND_SETS[band_set]
    ref = _write_like(Path(folder) / f"{name}_{band_set}_reference.tif", rgb_ref, derived_bands(rgb, kinds[0]))
    source = _write_like(Path(folder) / f"{name}_{band_set}_source.tif", rgb_ref, derived_bands(rgb, kinds[1]))
    size = IMAGES[name][2]
    deg, scale, persp = WARPS[warp]
    H = warp_matrix(deg, scale, persp, size, (rw / 2, rh / 2))
    tgt = Path(folder) / f"{name}_{band_set}_{warp}.tif"
    grid = dense_grid(warped_target(source, H, size, scale, tgt))
    return ref, tgt, grid, pixel_to_map(t_ref, apply_h(H, grid))
