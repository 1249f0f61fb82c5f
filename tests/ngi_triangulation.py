"""The real NGI pair (frames 0182/0184) triangulated with automatic control, and its measures (issue 13).

One seed of the pipeline (:func:`run_seed`): a starting orientation (the professional EO perturbed,
or each frame's own terrain-aware registration), automatic control from the orthophotos + DEM
(:func:`fotogeo.tools.triangulate.control.automatic_control`), tie points
(:func:`fotogeo.tools.triangulate.match.matched_observations`), bundle adjustment; the adjusted
orientations against the truth and the dense-grid ground RMSE (:func:`dense_grid`,
:func:`ground_rmse`), beside the single-frame registration (:func:`registration_rmse`).

Shared by ``tests/test_triangulate_ngi.py`` and ``benchmarks/triangulate_ngi_bench.py`` (which puts
``tests/`` on its path, as the other benchmarks do for the test helpers).
"""
from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from fotogeo.geometry.camera import OrientedFrame
from fotogeo.io.raster import read_dem
from fotogeo.io.camera import load_camera, read_exterior_orientation
from fotogeo.orientation.bundle import Block, BundleOptions, adjust_block
from fotogeo.pixels import pixel_centres
from fotogeo.tools.triangulate.control import automatic_control
from fotogeo.tools.triangulate.match import matched_observations

NAMES = ("3324c_2015_1004_05_0182_RGB", "3324c_2015_1004_05_0184_RGB")
ORTHO = {NAMES[0]: "ngi_rgb_byte_1.tif", NAMES[1]: "ngi_rgb_byte_2.tif"}


def perturbed(eo, rng, metres: float, degrees: float):
    d, a = rng.normal(0, metres, 3), rng.normal(0, degrees, 3)
    return dataclasses.replace(eo, X=eo.X + d[0], Y=eo.Y + d[1], Z=eo.Z + d[2], omega=eo.omega + a[0],
                               phi=eo.phi + a[1], kappa=eo.kappa + a[2])


def make_block(camera, eos, obs, gcp, sigma_xy: float, sigma_z: float, gcp_sigma_px: float) -> Block:
    """One Block from the tie observations and the control (a GcpList), each point once."""
    index = {n: k for k, n in enumerate(NAMES)}
    ties = list(dict.fromkeys(obs.point))
    ctrl = list(dict.fromkeys(gcp.name))
    ids = tuple(ties + ctrl)
    where = {p: k for k, p in enumerate(ids)}
    xyz = np.full((len(ids), 3), np.nan)
    sig = np.full((len(ids), 3), np.nan)
    for n, g in zip(gcp.name, gcp.ground):
        xyz[where[n]] = g
        sig[where[n]] = [sigma_xy, sigma_xy, sigma_z]
    role = np.array(["tie"] * len(ties) + ["control"] * len(ctrl))
    frame = np.array([index[f] for f in list(obs.frame) + list(gcp.frame)])
    point = np.array([where[p] for p in list(obs.point) + list(gcp.name)])
    s = np.concatenate([obs.sigma if obs.sigma is not None else np.full(len(obs.frame), 0.3),
                        np.full(len(gcp.name), gcp_sigma_px)])
    return Block(camera, NAMES, tuple(eos), frame, point, np.vstack([obs.pixel, gcp.pixel]), ids, xyz, sig, role, s)


def dense_grid(camera, true_eo, dem, step: int = 10):
    """Frame pixels every ``step`` px and their true ground points (ray–DEM intersection)."""
    w, h = camera.image_size
    x, y = pixel_centres(w // step, h // step)
    px = np.column_stack([x.ravel(), y.ravel()]) * step
    g = OrientedFrame(camera, true_eo).pixel_to_world(px, dem)
    ok = np.isfinite(g).all(axis=1)
    return px[ok], g[ok]


def ground_rmse(to_ground, px, truth) -> float:
    """RMSE (m) in plan of ``to_ground(px, Z)`` against the true ground points."""
    XY = to_ground(px, truth[:, 2])
    d = np.hypot(*(XY - truth[:, :2]).T)
    return float(np.sqrt(np.nanmean(d ** 2)))


def orientation_errors(eo, true) -> dict:
    dp = np.array([eo.X - true.X, eo.Y - true.Y, eo.Z - true.Z])
    da = np.array([eo.omega - true.omega, eo.phi - true.phi, (eo.kappa - true.kappa + 180) % 360 - 180])
    return {"position_m": float(np.linalg.norm(dp)), "dX_m": dp[0], "dY_m": dp[1], "dZ_m": dp[2],
            "angle_deg": float(np.max(np.abs(da))), "domega": da[0], "dphi": da[1], "dkappa": da[2]}


def registered(ngi, name, model):
    """The single-frame terrain-aware registration of a frame to its orthophoto (``fotogeo register --dem``)."""
    from fotogeo.tools.register.tool import register
    with tempfile.TemporaryDirectory() as tmp:
        return register(ngi / "ortho" / ORTHO[name], ngi / "frames" / f"{name}.tif", Path(tmp) / "r.tif",
                        dem=ngi / "dem.tif", camera=ngi / "interior_orientation.yaml", model=model, seed=0)


def registration_rmse(ngi, name, model, px, truth) -> float:
    """Dense-grid RMSE of the single-frame terrain-aware registration."""
    r = registered(ngi, name, model)
    return ground_rmse(lambda p, z: r.model.inverse(p, heights=z)[:, :2], px, truth)


def starting_orientation(ngi, true, rng, start: str, perturb):
    """The approximate orientation: ``perturbed`` truth, or ``registration`` — each frame's own
    collinearity fit to its orthophoto (the orthophotos' CRS is the block's), no orientation given."""
    if start == "registration":
        return [registered(ngi, n, "collinearity").model.frame.eo for n in NAMES]
    return [perturbed(true[n], rng, *perturb) for n in NAMES]


def through_tool(ngi, approx, crs) -> tuple:
    """The same block through ``fotogeo triangulate --reference ORTHO... --dem DEM`` (the tool's own tie
    points and merging; control σ as here): ``(adjusted orientations by name, report)``."""
    from fotogeo.io.block import write_exterior_orientation
    from fotogeo.tools.triangulate import triangulate
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_exterior_orientation(tmp / "eo.txt", NAMES, approx)
        (tmp / "out").mkdir()
        rep = triangulate([ngi / "frames" / f"{n}.tif" for n in NAMES], ngi / "interior_orientation.yaml",
                          tmp / "eo.txt", None, tmp / "out", reference=sorted((ngi / "ortho").glob("*.tif")),
                          dem=ngi / "dem.tif", crs=crs, reference_sigma_xy=2.5, reference_sigma_z=5.0,
                          image_sigma=0.5)
        return read_exterior_orientation(tmp / "out" / "exterior_orientation.txt"), rep


def run_seed(ngi, seed: int, level: int, perturb=(20.0, 0.5), tool: bool = False, start: str = "perturbed") -> dict:
    cam = load_camera(ngi / "interior_orientation.yaml")
    true = read_exterior_orientation(ngi / "exterior_orientation.txt")
    dem = read_dem(ngi / "dem.tif")
    rng = np.random.default_rng(seed)
    approx = starting_orientation(ngi, true, rng, start, perturb)
    frames = [ngi / "frames" / f"{n}.tif" for n in NAMES]
    t0 = time.perf_counter()
    gcp = automatic_control(frames, NAMES, cam, approx, sorted((ngi / "ortho").glob("*.tif")), dem, dem.crs)
    t1 = time.perf_counter()
    obs, rep = matched_observations(frames, NAMES, cam, approx, float(np.nanmean(dem.data)), level=level)
    t2 = time.perf_counter()
    res = adjust_block(make_block(cam, approx, obs, gcp, 2.5, 5.0, 0.5), BundleOptions())
    t3 = time.perf_counter()
    out = {"seed": seed, "start": start, "control_points": int(len(set(gcp.name))),
           "control_measurements": int(len(gcp.name)),
           "tie_tracks": rep["tracks"], "tie_observations": int(len(obs.frame)), "sigma0": res.sigma0,
           "image_rms_px": res.stats["image_rms_px"], "blunders": res.stats["n_blunders"],
           "control_rejected": res.stats["n_control_rejected"],
           "times_s": {"control": t1 - t0, "ties": t2 - t1, "adjust": t3 - t2}, "frames": {}}
    by_tool, out["tool"] = {}, None
    if tool:
        by_tool, rep = through_tool(ngi, approx, dem.crs.to_wkt())
        out["tool"] = {"sigma0": rep["statistics"]["sigma0"], "tie_tracks": rep["matching"]["tracks"],
                       "seconds": time.perf_counter() - t3}
    for k, n in enumerate(NAMES):
        px, truth = dense_grid(cam, true[n], dem)
        f = {"approx": orientation_errors(approx[k], true[n]), "adjusted": orientation_errors(res.eo[k], true[n]),
             "sigma_position_m": float(np.linalg.norm(res.eo_sigma[k, :3])),
             "dense_rmse_m": {}}
        if n in by_tool:
            f["tool"] = orientation_errors(by_tool[n], true[n])
        for label, eo in (("approx", approx[k]), ("bundle", res.eo[k]), ("truth", true[n]), ("tool", by_tool.get(n))):
            if eo is None:
                continue
            fr = OrientedFrame(cam, eo)
            f["dense_rmse_m"][label] = ground_rmse(lambda p, z, fr=fr: fr.pixel_to_world_at(p, z)[:, :2], px, truth)
        out["frames"][n] = f
    return out
