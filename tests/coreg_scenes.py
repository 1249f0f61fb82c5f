"""Scenes with a known displacement field for the co-registration tests and benchmark.

A target is made from a real image by ``target(q) = source(q + E(q))`` (float64 Keys cubic,
no 1/32-px quantisation), so the field that corrects it, ``corrected(p) = target(p + D(p))``,
is ``D(p) = −E(p + D(p))`` — solved by fixed-point iteration (:func:`true_field`).
Coordinates are target pixels, corner convention.
"""
from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
import rasterio
from affine import Affine

from fotogeo.matching.interpolation import sample

DATA = Path(os.environ.get("FOTOGEO_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
S2_CROP = DATA / "ngi" / "sentinel2_b432_byte.tif"
LANDSAT = DATA / "landsat_rgb" / "RGB.byte.tif"
S2_PAIR = DATA / "s2_pair"
NGI_ORTHO = DATA / "ngi" / "ortho" / "ngi_rgb_byte_1.tif"


def sinusoid(amplitude=2.0, wavelength=400.0, offset=(0.3, -0.2)):
    """``E(x, y)``: a constant offset plus a ripple — x moves with y, y with x."""
    def E(x, y):
        return (offset[0] + amplitude * np.sin(2 * np.pi * y / wavelength + 0.5),
                offset[1] + amplitude * np.sin(2 * np.pi * x / wavelength + 1.0))
    return E


def rotation_ripple(centre, angle_deg=0.3, scale=1.003, shift=(1.3, -0.7), amplitude=1.0, wavelength=300.0):
    """``E``: a small rotation and scale about ``centre``, a shift and a ripple."""
    th, (cx, cy) = np.deg2rad(angle_deg), centre

    def E(x, y):
        ax = (scale * np.cos(th) - 1) * (x - cx) - scale * np.sin(th) * (y - cy) + shift[0]
        ay = scale * np.sin(th) * (x - cx) + (scale * np.cos(th) - 1) * (y - cy) + shift[1]
        return (ax + amplitude * np.sin(2 * np.pi * y / wavelength),
                ay + amplitude * np.sin(2 * np.pi * x / wavelength + 1.0))
    return E


def warp(image: np.ndarray, E) -> np.ndarray:
    """``target(q) = image(q + E(q))`` on the image's own grid (NaN outside / at NaN)."""
    H, W = image.shape
    y, x = np.mgrid[0:H, 0:W] + 0.5
    ex, ey = E(x, y)
    out, _ = sample(np.asarray(image, dtype=np.float64), x + ex - 0.5, y + ey - 0.5, "bicubic")
    return out


def true_field(E, x, y, iterations: int = 60):
    """``D(p) = −E(p + D(p))`` at points ``(x, y)`` (arrays): ``(dx, dy)``."""
    dx, dy = np.zeros_like(x, dtype=np.float64), np.zeros_like(y, dtype=np.float64)
    for _ in range(iterations):
        ex, ey = E(x + dx, y + dy)
        dx, dy = -ex, -ey
    return dx, dy


def misregistration(reference, raster, spacing: int = 32, window: int = 64) -> dict:
    """The shifts (px) a grid of windows measures between ``reference`` and ``raster``, nothing corrected:
    ``coregister``'s ``before`` (n, median, rms, ce90 ...)."""
    from fotogeo.tools.coreg.tool import coregister
    return coregister(reference, raster, None, grid_spacing=spacing, window=window, iterations=1)["before"]


def time_series(folder, dates: int = 3, size: int = 320):
    """One area on several dates, each under its own smooth local distortion: ``(reference, {target: E})``.

    The reference is a ``size``² corner of band 1 of the Sentinel-2 scene (:func:`s2_crop`); date
    ``k`` is the same area, same grid, with another gain, offset and noise (σ 2) and warped by a
    sinusoid of its own amplitude (1.2–2 px), wavelength and offset (:func:`sinusoid`)."""
    src = s2_crop()[:size, :size]
    ref = write_geotiff(Path(folder) / "reference.tif", src, dtype="uint8")
    targets = {}
    for k in range(dates):
        E = sinusoid(amplitude=1.2 + 0.4 * k, wavelength=240.0 + 60 * k, offset=(0.3 + 0.2 * k, -0.4 + 0.3 * k))
        noise = np.random.default_rng(k).normal(0, 2.0, src.shape)
        targets[write_geotiff(Path(folder) / f"date_{k}.tif", warp(src * (0.8 + 0.15 * k) + 15 * k + noise, E),
                              dtype="uint8")] = E
    return ref, targets


def s2_crop() -> np.ndarray:
    """Band 1 of the Sentinel-2 scene of the NGI valley (797 x 1361, 10 m), float64."""
    with rasterio.open(S2_CROP) as ds:
        return ds.read(1).astype(np.float64)


def seasonal_landsat(seed: int = 0, E=None):
    """A seasonal/sensor pair from the Landsat-7 clip: ``(reference, target, E)``.

    Reference: band 1 (red). Target: band 3 (blue) — other surfaces bright and dark — with
    gamma 0.6, contrast inverted, blurred (σ 1 px), noise (σ 3 grey values), warped by
    :func:`rotation_ripple`. NaN = nodata.
    """
    with rasterio.open(LANDSAT) as ds:
        a = ds.read().astype(np.float64)
        valid = ds.read_masks(1) > 0
    ref = np.where(valid, a[0], np.nan)
    src = 1.0 - (a[2] / 255.0) ** 0.6
    src = cv2.GaussianBlur(src, (0, 0), 1.0) * 200 + np.random.default_rng(seed).normal(0, 3.0, src.shape)
    src[~valid] = np.nan
    E = E or rotation_ripple((a.shape[2] / 2, a.shape[1] / 2))
    return ref, warp(src, E), E


def write_geotiff(path, image: np.ndarray, *, transform=None, crs="EPSG:32633", dtype="float32", nodata=None):
    """Write ``image`` (NaN = nodata) as a one-band GeoTIFF (default: 10 m pixels, UTM 33N)."""
    transform = transform or Affine(10.0, 0.0, 400000.0, 0.0, -10.0, 5800000.0)
    data = np.asarray(image, dtype=np.float64)
    if np.dtype(dtype).kind in "iu":
        nodata = 0 if nodata is None else nodata
        info = np.iinfo(dtype)
        data = np.where(np.isfinite(data), np.clip(np.round(data), max(info.min, 1), info.max), nodata)
    elif nodata is None:
        nodata = np.nan
    with rasterio.open(path, "w", driver="GTiff", width=data.shape[1], height=data.shape[0], count=1, dtype=dtype,
                       crs=crs, transform=transform, nodata=nodata) as ds:
        ds.write(data.astype(dtype), 1)
    return Path(path)
