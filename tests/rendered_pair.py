"""A rendered pair of nadir frames of any size over a known smooth terrain, written row block by row block (never
whole in memory): the large-image case of ``fotogeo dsm`` (benchmarks/dsm_memory.py) and its small twin in the tests.

The pair: ``size x size`` pixels (8 bits, tiled GeoTIFF, no georeference), focal length ``size`` pixels (a 53°
field of view), 0.1 m ground sample distance, 60 % forward overlap (base-to-height ratio 0.4), small attitude
angles; the terrain ±16 m of sines (:func:`terrain`); the ground a fractal texture
(:func:`fotogeo.orientation.block_render.texture`: one tile wider than the pair's ground, half a ground pixel
per texel) with
Gaussian grey noise of 2 levels. Each pixel's ray meets the terrain by fixed-point iteration on the height.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

GSD, OVERLAP, TILE = 0.1, 0.6, 4096
ORIGIN = np.array([500000.0, 4420000.0])
CRS = "EPSG:32635"


def terrain(x, y):
    """Heights (m) of the rendered terrain at map ``x``, ``y`` (offsets from the scene origin)."""
    return (12.0 * np.sin(2 * np.pi * x / 300.0) * np.cos(2 * np.pi * y / 250.0)
            + 4.0 * np.sin(2 * np.pi * (x + y) / 90.0))


def _texture(rng, n: int) -> np.ndarray:
    """An ``n x n`` ground texture with the statistics per texel of
    :func:`fotogeo.orientation.block_render.texture` on a ``TILE``² tile (the same one for ``n = TILE``): finer
    fractal octaves and patches of the same size in texels on a larger tile."""
    from fotogeo.orientation.block_render import _fractal
    octaves = 8 + max(0, int(round(np.log2(n / TILE))))
    img = 128 + 40 * _fractal(rng, (n, n), octaves=octaves)
    side = max(5, min(n, TILE) // 60)
    for _ in range(n * n // 2000):
        r, c = rng.integers(0, n), rng.integers(0, n)
        h, w = rng.integers(4, side), rng.integers(4, side)
        img[r:r + h, c:c + w] += rng.choice([-60.0, 60.0])
    return np.clip(img, 0, 255).astype(np.float32)


def render(folder: Path, size: int, seed: int = 0, focal: float | None = None, converge: float = 0.0) -> dict:
    """Write the pair (module docstring) into ``folder``: ``{"images", "camera", "eo"}``; ``focal`` the focal
    length in pixels [``size``] (longer: a narrower view from higher up, the base-to-height ratio
    ``0.4 size / focal``); ``converge`` > 0: that base-to-height ratio instead, both frames tilted along the base
    to look at its middle (the views' directions then differ by the base-to-height angle, as a satellite pair's
    do, and the frames overlap nearly whole)."""
    import cv2
    import rasterio
    from rasterio.windows import Window

    from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
    from fotogeo.io.block import write_exterior_orientation, write_interior_orientation
    rng = np.random.default_rng(seed)
    # one texture tile wider than the pair's ground (a repeated texture would give repeated matches)
    texel = GSD / 2
    tex = _texture(rng, max(TILE, int(1.6 * size * GSD / texel)))
    f = float(focal or size)  # focal length in pixels: size gives a 53° field of view
    H = f * GSD
    base = converge * H if converge else (1 - OVERLAP) * size * GSD
    cam = FrameCamera(f * 0.005, (size * 0.005, size * 0.005), (size, size))
    tilt = np.degrees(np.arctan(0.5 * base / H)) if converge else 0.0  # phi > 0 turns the view towards -X
    eos = [ExteriorOrientation(*ORIGIN, H, 0.4, -0.3 - tilt, 1.5),
           ExteriorOrientation(ORIGIN[0] + base, ORIGIN[1] + 0.02 * base, H + 3.0, -0.3, 0.5 + tilt, 0.8)]
    names = [f"r{size}_a", f"r{size}_b"]
    paths = []
    for name, eo in zip(names, eos):
        p = folder / f"{name}.tif"
        M = eo.rotation_cv
        with rasterio.open(p, "w", driver="GTiff", width=size, height=size, count=1, dtype="uint8", tiled=True,
                           blockxsize=256, blockysize=256, compress="deflate") as ds:
            for r0 in range(0, size, 256):
                rows = min(256, size - r0)
                u, v = np.meshgrid(np.arange(size) + 0.5, np.arange(r0, r0 + rows) + 0.5)
                d = np.stack([(u - size / 2) / f, (v - size / 2) / f, np.ones_like(u)], -1) @ M.T
                z = np.zeros(u.shape)
                for _ in range(15):  # the ray's point at the terrain's height there (a contraction: slopes < 1)
                    t = (z - eo.Z) / d[..., 2]
                    x, y = eo.X + t * d[..., 0] - ORIGIN[0], eo.Y + t * d[..., 1] - ORIGIN[1]
                    z = terrain(x, y)
                mx = (x / texel - 0.5).astype(np.float32)
                my = (-y / texel - 0.5).astype(np.float32)
                img = cv2.remap(tex, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
                img = img + rng.normal(0, 2.0, img.shape).astype(np.float32)
                ds.write(np.clip(np.round(img), 1, 255).astype(np.uint8)[None], window=Window(0, r0, size, rows))
        paths.append(str(p))
    camera, eo_path = folder / "camera.yaml", folder / "eo.txt"
    write_interior_orientation(camera, "cam", cam, {})
    write_exterior_orientation(eo_path, names, eos)
    return {"images": paths, "camera": str(camera), "eo": str(eo_path)}


#: the height range the rendered pair's RPCs are fitted over (their HEIGHT_OFF ± HEIGHT_SCALE)
RPC_HEIGHTS = (-40.0, 40.0)


def render_rpc(folder: Path, size: int, seed: int = 0, focal_factor: float = 20.0, base_height: float = 0.25) -> dict:
    """The converging pair of :func:`render` (focal length ``focal_factor x size`` pixels: a narrow view from high
    up, as a satellite's; base-to-height ratio ``base_height``) with each
    frame's exact geometry replaced by an RPC fitted to it (:func:`fotogeo.orientation.rpc.frame_rpc`: a 15 x 15
    pixel grid at 7 heights over ``RPC_HEIGHTS``, heights taken as ellipsoidal) and written as GDAL RPC metadata
    into the image: ``{"images", "rpc_fit_px"}`` (the fit's largest error at the grid points)."""
    import rasterio
    from pyproj import Transformer

    from fotogeo.geometry.camera import OrientedFrame
    from fotogeo.io.camera import read_exterior_orientation, read_interior_orientation
    from fotogeo.orientation.rpc import frame_rpc
    sc = render(folder, size, seed, focal=focal_factor * size, converge=base_height)
    cam = next(iter(read_interior_orientation(sc["camera"]).values()))
    eos = read_exterior_orientation(sc["eo"])
    worst, tr = 0.0, Transformer.from_crs(CRS, "EPSG:4326", always_xy=True)
    for p in sc["images"]:
        frame = OrientedFrame(cam, eos[Path(p).stem])
        rpc, model = frame_rpc(frame, CRS, RPC_HEIGHTS)
        u, v = np.meshgrid(np.linspace(0, size, 9), np.linspace(0, size, 9))
        px = np.column_stack([u.ravel(), v.ravel()])
        for z in np.linspace(*RPC_HEIGHTS, 5):
            g = frame.pixel_to_world_at(px, z)
            lon, lat = tr.transform(g[:, 0], g[:, 1])
            worst = max(worst, float(np.abs(model.forward(np.column_stack([lon, lat, g[:, 2]])) - px).max()))
        with rasterio.open(p, "r+") as ds:
            ds.update_tags(ns="RPC", **rpc.to_gdal_metadata())
    return {"images": sc["images"], "rpc_fit_px": worst}


def accuracy(dsm_path, rows_per_block: int = 1024, sample: int = 4_000_000) -> dict:
    """DSM − terrain at the cell centres where the DSM has a height, read by blocks of rows (a large DSM is never
    whole in memory): RMSE over every cell, median and NMAD over a regular sample of at most about ``sample``
    cells (every cell when fewer)."""
    import rasterio
    from rasterio.windows import Window
    n, s2, kept = 0, 0.0, []
    with rasterio.open(dsm_path) as ds:
        t, nodata = ds.transform, ds.nodata
        stride = max(1, ds.width * ds.height // sample)
        for r0 in range(0, ds.height, rows_per_block):
            h = ds.read(1, window=Window(0, r0, ds.width, min(rows_per_block, ds.height - r0)))
            rows, cols = np.nonzero(h != nodata)
            x, y = t * (cols + 0.5, rows + r0 + 0.5)
            d = h[rows, cols] - terrain(np.asarray(x) - ORIGIN[0], np.asarray(y) - ORIGIN[1])
            n, s2 = n + len(d), s2 + float(np.sum(d.astype(np.float64) ** 2))
            kept.append(d[::stride])
    d = np.concatenate(kept) if kept else np.zeros(0)
    med = float(np.median(d)) if len(d) else float("nan")
    return {"rmse_m": float(np.sqrt(s2 / max(n, 1))), "nmad_m": float(1.4826 * np.median(np.abs(d - med))),
            "median_m": med, "cells_with_height": int(n)}
