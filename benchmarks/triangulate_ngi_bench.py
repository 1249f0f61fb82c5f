"""The real NGI pair (frames 0182/0184, one strip) triangulated with automatic control (issue 13).

Inputs: ``../shared/data/ngi`` — two raw DMC frames (640 x 1152, about 6.3 m on the ground), the
camera, a 24 m DEM, two 5 m orthophoto tiles, and ``exterior_orientation.txt`` from a
professional aerial triangulation (the truth). Per seed:

1. the approximate orientation is the true one perturbed (Gaussian, 20 m per axis, 0.5° per angle),
   or (``--start registration``) each frame's own terrain-aware registration to its orthophoto
   (collinearity with the camera): no orientation given at all;
2. automatic control (:func:`fotogeo.tools.triangulate_control.automatic_control`): each frame
   matched to the orthophoto tiles, DEM heights, robust terrain fit, thinned to 90 per frame;
3. tie points between the frames (:func:`fotogeo.tools.triangulate_match.matched_observations`:
   pyramid level ``--level``, Gruber thinning, LSM with σ);
4. bundle adjustment (:func:`fotogeo.orientation.bundle.adjust_block`): control σ 2.5 m in plan
   (half a 5 m orthophoto pixel, the measured reprojection noise of the automatic control) and
   5 m in height (24 m DEM over steep relief);
5. the adjusted orientations against the truth (projection centre m, angles °), and the dense-grid
   ground accuracy: every 10th frame pixel put on the ground at its true height (ray–DEM
   intersection with the true geometry) through the adjusted orientation, RMSE in m against the
   true ground point — beside the same measure for the approximate orientation and for the
   single-frame terrain-aware registration of the same frame (``fotogeo register --dem``, the model
   ``auto`` and ``collinearity`` with the camera).

Prints a table and writes ``benchmarks/results/triangulate_ngi_bench.json``.

With ``--tool`` the same block also goes through ``fotogeo triangulate --reference ... --dem ...``
(its own tie points and control merging), to show what the command gives.

    .venv/bin/python benchmarks/triangulate_ngi_bench.py [--seeds 3] [--level 1] [--tool]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from fotogeo.geometry.camera import OrientedFrame
from fotogeo.geometry.dem import Dem
from fotogeo.io.camera import load_camera, read_exterior_orientation
from fotogeo.orientation.bundle import Block, BundleOptions, adjust_block
from fotogeo.pixels import pixel_centres
from fotogeo.tools.triangulate_control import automatic_control
from fotogeo.tools.triangulate_match import matched_observations

ROOT = Path(__file__).resolve().parents[1]
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
    from fotogeo.tools.register import register
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
    dem = Dem.open(ngi / "dem.tif")
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


def add_registration(ngi, rows) -> dict:
    """Dense RMSE of the single-frame terrain-aware registration (independent of the seed)."""
    cam = load_camera(ngi / "interior_orientation.yaml")
    true = read_exterior_orientation(ngi / "exterior_orientation.txt")
    dem = Dem.open(ngi / "dem.tif")
    reg = {}
    for n in NAMES:
        px, truth = dense_grid(cam, true[n], dem)
        reg[n] = {m: registration_rmse(ngi, n, m, px, truth) for m in ("collinearity", "auto")}
    return reg


def print_table(rows, reg):
    print(f"{'seed':>4} {'frame':>5} {'approx pos/ang':>15} {'bundle pos/ang':>16} {'dense approx':>12} "
          f"{'dense bundle':>12} {'register coll/auto':>19}")
    for r in rows:
        for n, f in r["frames"].items():
            a, b, d = f["approx"], f["adjusted"], f["dense_rmse_m"]
            print(f"{r['seed']:>4} {n[-8:-4]:>5} {a['position_m']:7.1f} m {a['angle_deg']:.3f}° "
                  f"{b['position_m']:7.2f} m {b['angle_deg']:.4f}° {d['approx']:10.2f} m {d['bundle']:10.2f} m "
                  f"{reg[n]['collinearity']:8.2f} / {reg[n]['auto']:.2f} m")
            if "tool" in f:
                print(f"{'':>10} through fotogeo triangulate: {f['tool']['position_m']:7.2f} m "
                      f"{f['tool']['angle_deg']:.4f}°, dense {d['tool']:.2f} m ({r['tool']['tie_tracks']} tie tracks)")
        print(f"     σ0 {r['sigma0']:.2f}, image RMS {r['image_rms_px']:.3f} px, {r['control_points']} control points "
              f"({r['control_measurements']} measurements), {r['tie_tracks']} tie tracks, "
              f"{r['blunders']} blunders, {r['control_rejected']} control rejected; "
              f"times {', '.join(f'{k} {v:.1f} s' for k, v in r['times_s'].items())}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "ngi"))
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--level", type=int, default=1, help="pyramid level of the tie-point detection")
    ap.add_argument("--start", choices=("perturbed", "registration"), default="perturbed",
                    help="approximate orientation: the truth perturbed (20 m, 0.5°, seeded) or "
                         "single-frame registration")
    ap.add_argument("--tool", action="store_true", help="also run the block through fotogeo triangulate")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "triangulate_ngi_bench.json"))
    a = ap.parse_args(argv)
    ngi = Path(a.data)
    rows = [run_seed(ngi, s, a.level, tool=a.tool, start=a.start) for s in range(a.seeds)]
    reg = add_registration(ngi, rows)
    print_table(rows, reg)
    Path(a.out).write_text(json.dumps({"note": "times load-dependent (2 shared cores)", "level": a.level,
                                       "rows": rows, "registration_dense_rmse_m": reg}, indent=1, default=float))


if __name__ == "__main__":
    main()
