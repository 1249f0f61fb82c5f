"""A rendered block's frames written to disk and its simulated control joined with matched tie points.

Shared by ``tests/test_triangulate_ties.py`` and ``benchmarks/triangulate_ties_bench.py`` (which puts
``tests/`` on its path, as the other benchmarks do for the test helpers).
"""
from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np
import rasterio
import rasterio.errors


def write_frames(folder: Path, sb, images) -> list:
    """Each rendered frame (``(rows, cols)`` or ``(bands, rows, cols)``) as an ungeoreferenced 8-bit GeoTIFF
    ``folder/<frame name>.tif``; the paths in frame order."""
    paths = []
    for name, img in zip(sb.block.frames, images):
        img = img if img.ndim == 3 else img[None]
        path = folder / f"{name}.tif"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(path, "w", driver="GTiff", width=img.shape[2], height=img.shape[1], count=len(img),
                               dtype="uint8") as ds:
                ds.write(img)
        paths.append(path)
    return paths


def with_ties(sb, frame, track, pixel, sigma, a_priori: float):
    """The simulated block's control and check observations plus the matched tie points."""
    b = sb.block
    known = b.role[b.obs_point] != "tie"
    pts = np.unique(b.obs_point[known])
    remap = np.full(len(b.point_ids), -1)
    remap[pts] = np.arange(len(pts))
    n_t = int(track.max()) + 1
    ids = tuple(b.point_ids[p] for p in pts) + tuple(f"tie{t}" for t in range(n_t))
    xyz = np.vstack([b.point_xyz[pts], np.full((n_t, 3), np.nan)])
    psig = np.vstack([b.point_sigma[pts], np.full((n_t, 3), np.nan)])
    role = np.concatenate([b.role[pts], np.full(n_t, "tie")])
    s = np.full(len(frame), a_priori) if sigma is None else sigma
    return dataclasses.replace(b, obs_frame=np.concatenate([b.obs_frame[known], frame]),
                               obs_point=np.concatenate([remap[b.obs_point[known]], len(pts) + track]),
                               obs_pixel=np.vstack([b.obs_pixel[known], pixel]), point_ids=ids, point_xyz=xyz,
                               point_sigma=psig, role=role, obs_sigma=np.concatenate([b.obs_sigma[known], s]))
