"""A rendered block adjusted, written as triangulate writes it, orthorectified with ``--uncertainty``, and the
true errors of its check points against the predicted σ (issue 21's acceptance: observed / predicted RMS).

Shared by ``tests/test_ortho_uncertainty.py`` and ``benchmarks/ortho_uncertainty_bench.py``.

One realisation (:func:`realisation`): a seeded block of 2 x 4 frames (400 x 600 px) is rendered
(:func:`fotogeo.orientation.block_render.render_block`), its tie points matched and refined by triangulate's own
matching, the block adjusted with its simulated control, and the adjustment written as triangulate writes it
(``exterior_orientation.txt``, ``report.json`` with the covariances). The DEM handed to ``fotogeo ortho`` is the
rendering DEM plus a stationary error field of σ ``dem_sigma`` (white noise smoothed over 3 cells, scaled to unit
variance: locally constant over the few metres a height error moves a ray). **Check points**: ground points drawn
uniformly over the block; in each frame that sees one, its true pixel (true camera) is put back on the ground
through the adjusted frame and the erroneous DEM — where the orthophoto shows it. Its error against the truth is
compared with the σ raster at that place.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pyproj
from scipy.ndimage import gaussian_filter

from fotogeo.geometry.camera import FrameCamera, OrientedFrame
from fotogeo.geometry.dem import Dem
from fotogeo.io.block import write_exterior_orientation, write_interior_orientation
from fotogeo.io.raster import ropen
from fotogeo.io.report import write_json
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import adjust_block
from fotogeo.tools.triangulate.match import matched_observations
from fotogeo.orientation.adjusted_frame import AdjustedFrame
from fotogeo.tools.triangulate.outputs import report
from rendered_block_ties import with_ties, write_frames

CRS = "EPSG:32635"  # the simulated block's coordinates start at (500000, 4420000)
CRS_OBJECT = pyproj.CRS(CRS)
CAMERA = FrameCamera(6.0, (4.0, 6.0), (400, 600))


def noisy_dem(dem: Dem, sigma: float, seed: int) -> Dem:
    """``dem`` plus a stationary error field of σ ``sigma`` (module docstring)."""
    field = gaussian_filter(np.random.default_rng(seed).normal(size=dem.data.shape), 3.0)
    return Dem(dem.data + sigma * field / field.std(), dem.transform, dem.crs, "noisy")


def write_dem(path: Path, dem: Dem) -> Path:
    with ropen(path, "w", driver="GTiff", width=dem.data.shape[1], height=dem.data.shape[0], count=1,
               dtype="float64", crs=CRS, transform=dem.transform) as ds:
        ds.write(dem.data[None])
    return path


def realisation(folder: Path, seed: int, dem_sigma: float, options=None, control_sigma_given=None, **shape) -> dict:
    """The block of ``seed`` adjusted (``options``: :class:`~fotogeo.orientation.bundle.BundleOptions`) and written
    into ``folder`` (module docstring); ``shape`` overrides :func:`simulate_block`'s 2 x 4 block of :data:`CAMERA`;
    ``control_sigma_given`` ``(plan, height)``: the control's σ handed to the adjustment when it is not the σ of
    its simulated errors (``shape["control_sigma"]``)."""
    shape = {"strips": 2, "frames_per_strip": 4, "camera": CAMERA, "point_spacing": 80.0, **shape}
    sb = simulate_block(seed=seed, blunder_fraction=0.0, margin=5.0, **shape)
    if control_sigma_given is not None:
        b = sb.block
        sig = np.where((b.role == "control")[:, None], np.array(control_sigma_given)[[0, 0, 1]], b.point_sigma)
        sb = dataclasses.replace(sb, block=dataclasses.replace(b, point_sigma=sig))
    images, dem = render_block(sb)
    paths = write_frames(folder, sb, images)
    height = float(np.nanmean(sb.block.point_xyz[:, 2]))
    obs, _ = matched_observations(paths, list(sb.block.frames), sb.block.camera, sb.block.eo, height)
    index = {n: k for k, n in enumerate(sb.block.frames)}
    frame = np.array([index[f] for f in obs.frame])
    track = np.array([int(p[3:]) for p in obs.point])
    block = with_ties(sb, frame, track, obs.pixel, obs.sigma, 0.3)
    result = adjust_block(block, options) if options is not None else adjust_block(block)
    write_exterior_orientation(folder / "exterior_orientation.txt", block.frames, result.eo, "adjusted")
    write_json(folder / "report.json", report(result, block, CRS_OBJECT, {}))
    write_interior_orientation(folder / "camera.yaml", "adjusted", result.camera, result.distortion)
    wrong = noisy_dem(dem, dem_sigma, seed + 1000)
    return {"sb": sb, "block": block, "result": result, "images": paths, "eo": folder / "exterior_orientation.txt",
            "camera": folder / "camera.yaml",
            "dem": dem, "noisy_dem": wrong, "dem_path": write_dem(folder / "dem.tif", wrong)}


def check_points(r: dict, n: int = 2000, seed: int = 0):
    """Per frame ``(true ground (k, 3), where the orthophoto puts it on the exact DEM, on the noisy DEM)``."""
    sb, result = r["sb"], r["result"]
    rng = np.random.default_rng(seed)
    lo, hi = sb.true_xyz[:, :2].min(axis=0), sb.true_xyz[:, :2].max(axis=0)
    out = []
    for true_eo, eo in zip(sb.true_eo, result.eo):
        XY = rng.uniform(lo, hi, (n, 2))
        G = np.column_stack([XY, r["dem"].heights(XY)])
        px = OrientedFrame(sb.true_camera, true_eo).world_to_pixel(G)
        w, h = sb.true_camera.image_size
        with np.errstate(invalid="ignore"):
            seen = np.isfinite(px).all(axis=1) & (px[:, 0] > 0) & (px[:, 0] < w) & (px[:, 1] > 0) & (px[:, 1] < h)
        model = AdjustedFrame(result.camera, eo, result.distortion)
        out.append((G[seen], model.inverse(px[seen], r["dem"]), model.inverse(px[seen], r["noisy_dem"])))
    return out


def sample_raster(path, XY) -> np.ndarray:
    """The raster's band 1 at map points (the cell they fall in; NaN outside)."""
    with ropen(path) as ds:
        data = ds.read(1)
        inv = ~ds.transform
    cr = np.array([inv * tuple(p) for p in XY]).reshape(-1, 2)
    c, rw = np.floor(cr[:, 0]).astype(int), np.floor(cr[:, 1]).astype(int)
    ok = (c >= 0) & (c < data.shape[1]) & (rw >= 0) & (rw < data.shape[0])
    out = np.full(len(XY), np.nan)
    out[ok] = data[rw[ok], c[ok]]
    return out


def rms_ratio(errors: list, sigmas: list) -> float:
    """Observed planimetric RMS of the errors ``(k, 2)`` over predicted ``√mean(σ²)``, pooled."""
    e, s = np.vstack(errors), np.concatenate(sigmas)
    ok = np.isfinite(e).all(axis=1) & np.isfinite(s)
    return float(np.sqrt(np.mean(np.sum(e[ok] ** 2, axis=1))) / np.sqrt(np.mean(s[ok] ** 2)))
