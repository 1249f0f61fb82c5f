"""Tie points of a rendered synthetic block, before and after the pyramid / Gruber / LSM steps (issue 13).

A block of rendered frames (:func:`fotogeo.orientation.block_render.render_block`: texture on the
terrain, every frame through its true camera) is matched by
:func:`fotogeo.tools.triangulate_match.block_tie_points` in several configurations and adjusted
with the block's simulated control (:func:`fotogeo.orientation.bundle.adjust_block`):

* ``before`` — the first version: SURF on the full-resolution frames, every epipolar inlier, no
  thinning, no LSM, one a priori σ for all observations;
* ``pyramid`` — detection on pyramid level 1, thinned to Gruber positions (3 x 3 regions, 25 each), no LSM;
* ``after`` — the same, followed down by least-squares matching at full resolution, each
  observation with its LSM σ;
* ``full+lsm`` — level-0 detection, thinned, LSM.

Printed and written to ``benchmarks/results/triangulate_ties_bench.json``: tracks, observations,
σ₀, image RMS (px), check RMSE in plan and height (m and GSD), wall time of matching and adjustment.

    .venv/bin/python benchmarks/triangulate_ties_bench.py [--quick]
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import rasterio
import rasterio.errors

from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.tools.triangulate_match import block_tie_points

VARIANTS = {
    "before": dict(level=0, per_region=None, lsm=False),
    "pyramid": dict(level=1, per_region=25, lsm=False),
    "after": dict(level=1, per_region=25, lsm=True),
    "full+lsm": dict(level=0, per_region=25, lsm=True),
}


def write_frames(folder: Path, sb, images) -> list:
    paths = []
    for name, img in zip(sb.block.frames, images):
        path = folder / f"{name}.tif"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            with rasterio.open(path, "w", driver="GTiff", width=img.shape[1], height=img.shape[0], count=1,
                               dtype="uint8") as ds:
                ds.write(img[None])
        paths.append(path)
    return paths


def with_ties(sb, frame, track, pixel, sigma, a_priori: float):
    """The simulated block's control and check observations plus the matched tie points."""
    import dataclasses
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


def run_variant(sb, paths, name, kw, a_priori):
    b = sb.block
    height = float(np.nanmean(b.point_xyz[:, 2]))
    t0 = time.perf_counter()
    frame, track, pixel, sigma, rep = block_tie_points(paths, b.camera, b.eo, height, **kw)
    t1 = time.perf_counter()
    res = adjust_block(with_ties(sb, frame, track, pixel, sigma, a_priori), BundleOptions())
    t2 = time.perf_counter()
    st, gsd = res.stats, sb.gsd
    chk = st["check"]
    return {"variant": name, **kw, "tracks": rep["tracks"], "observations": int(len(frame)),
            "median_sigma_px": float(np.median(sigma)) if sigma is not None else a_priori,
            "lsm": rep.get("lsm"), "sigma0": res.sigma0, "image_rms_px": st.get("image_rms_px"),
            "check_n": chk["n"], "check_plan_m": chk["rmse_planimetric_m"], "check_z_m": chk["rmse_z_m"],
            "check_plan_gsd": chk["rmse_planimetric_m"] / gsd, "check_z_gsd": chk["rmse_z_m"] / gsd,
            "blunders": st["n_blunders"], "match_s": t1 - t0, "adjust_s": t2 - t1}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one seed, 400x600 frames")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "triangulate_ties_bench.json"))
    a = ap.parse_args(argv)
    size = (400, 600) if a.quick else (800, 1200)
    cam = FrameCamera(6.0, (4.0, 6.0), size)  # the same footprints; 800x1200: half the GSD
    rows = []
    for seed in range(1 if a.quick else a.seeds):
        sb = simulate_block(seed=seed + 1, strips=2, frames_per_strip=4, camera=cam, point_spacing=80.0,
                            blunder_fraction=0.0, margin=5.0)
        images, _ = render_block(sb, seed=seed)
        with tempfile.TemporaryDirectory() as tmp:
            paths = write_frames(Path(tmp), sb, images)
            for name, kw in VARIANTS.items():
                r = run_variant(sb, paths, name, kw, 0.3)
                r["seed"], r["frame_size"] = seed + 1, list(size)
                rows.append(r)
                print(f"seed {seed + 1} {name:9s} tracks {r['tracks']:5d} obs {r['observations']:6d} "
                      f"σ0 {r['sigma0']:.3f} image RMS {r['image_rms_px']:.3f} px  check {r['check_n']:2d}: "
                      f"plan {r['check_plan_gsd']:.3f} GSD, Z {r['check_z_gsd']:.3f} GSD  "
                      f"(match {r['match_s']:.1f} s, adjust {r['adjust_s']:.1f} s)", flush=True)
    Path(a.out).write_text(json.dumps({"note": "load-dependent times (2 shared cores)", "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
