"""Time and accuracy of fotogeo's bundle block adjustment on synthetic blocks with known truth.

Blocks come from :func:`fotogeo.orientation.block_simulation.simulate_block` (60 % / 30 %
overlap, 40 m relief, 0.3 px image noise, 1.5 % blunders, 8 control points, seeded):

* ``small``: 3 strips x 8 frames (the 24-frame block of GUIDE.md §6);
* ``large``: 10 strips x 30 frames, point spacing chosen for about 60 000 tie points (the
  300-frame / 60 000-point target of issue 13).

For each block, in a child process (so that the peak memory is the block's own): the time of
the whole :func:`fotogeo.orientation.bundle.adjust_block` (Huber reweighting, correlation
check, data snooping, culling, re-solving), the check-point RMSE in GSD, blunders caught, σ₀
and the peak resident memory (``ru_maxrss``); then, on the same block without blunders, one
Levenberg–Marquardt solve of fotogeo and one bundle adjustment of pycolmap (Ceres, PyPI
``pycolmap``) on the same observations from the same approximate orientation and first
points, the camera fixed, the control points held fixed in pycolmap (it has no GCP input)
and weighted (σ 2–3 cm) in fotogeo: time and check-point RMSE of both, as a ratio in one run.
COLMAP's pixel convention is GDAL's corner convention (pixel centres at +0.5), so the
observations go in unchanged; its ``cam_from_world`` is ``(Rᵀ, −Rᵀ C)`` of fotogeo's
OpenCV-axis rotation ``R`` and centre ``C``.

With ``--image-sigma S`` each block is instead adjusted twice with its image points' a-priori σ stated as ``S`` px
(the simulated noise is 0.3 px): with the image variance component estimated (the default, at most three
warm-started re-solves when the image points drive σ₀) and without it — the time the estimation costs, σ₀ and the
check-point RMSE of both.

Run: ``.venv/bin/python benchmarks/bundle_bench.py [--blocks small,large] [--image-sigma 0.1]``. Prints a table
and writes ``benchmarks/results/bundle_bench.json`` (``bundle_bench_image_sigma.json`` with ``--image-sigma``).
"""
from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "bundle_bench.json"
BLOCKS = {"small": dict(strips=3, frames_per_strip=8, point_spacing=40.0),
          "large": dict(strips=10, frames_per_strip=30, point_spacing=30.0)}


def _check_rmse(X, truth, check, gsd):
    import numpy as np
    d = X[check] - truth[check]
    return (round(float(np.sqrt(np.mean(d[:, 0] ** 2 + d[:, 1] ** 2)) / gsd), 3),
            round(float(np.sqrt(np.mean(d[:, 2] ** 2)) / gsd), 3))


def pycolmap_solve(pb, s, camera):
    """pycolmap's bundle adjustment of the problem ``pb`` from state ``s`` (module docstring):
    ``(seconds, points (P, 3) local, iterations)``, or None without pycolmap."""
    try:
        import pycolmap
    except ImportError:
        return None
    import numpy as np
    st = pb.st
    rec = pycolmap.Reconstruction()
    rec.add_camera_with_trivial_rig(pycolmap.Camera(model="PINHOLE", width=camera.image_size[0],
                                                    height=camera.image_size[1],
                                                    params=[camera.fx, camera.fy, *camera.principal_point],
                                                    camera_id=1))
    local = np.empty(len(st.frame), dtype=int)
    for j, sel in enumerate(st.by_frame):
        local[sel] = np.arange(len(sel))
        Rcw = s.R[j].T
        rec.add_image_with_trivial_frame(pycolmap.Image(name=f"f{j}", keypoints=pb.pixel[sel], camera_id=1,
                                                        image_id=j + 1),
                                         pycolmap.Rigid3d(pycolmap.Rotation3d(Rcw), -Rcw @ s.C[j]))
    ids = []
    for i in range(st.n_points):
        track = pycolmap.Track()
        for a in range(st.starts[i], st.starts[i] + st.counts[i]):
            track.add_element(int(st.frame[a]) + 1, int(local[a]))
        ids.append(rec.add_point3D(s.X[i], track))
    config = pycolmap.BundleAdjustmentConfig()
    for j in range(st.n_frames):
        config.add_image(j + 1)
    config.set_constant_cam_intrinsics(1)
    for i in np.flatnonzero(pb.ctrl_w[:, 0] > 0):
        config.add_constant_point(ids[i])
    opts = pycolmap.BundleAdjustmentOptions()
    opts.refine_focal_length = opts.refine_principal_point = opts.refine_extra_params = False
    t0 = time.perf_counter()
    summary = pycolmap.create_default_bundle_adjuster(opts, config, rec).solve()
    seconds = time.perf_counter() - t0
    iterations = summary.ceres_summary.num_successful_steps + summary.ceres_summary.num_unsuccessful_steps
    return seconds, np.array([rec.point3D(p).xyz for p in ids]), iterations


def run_block(name: str) -> dict:
    """Simulate and adjust one block (in this process); the measurements as a dict."""
    import resource

    import numpy as np

    from fotogeo.orientation.block_simulation import simulate_block
    from fotogeo.orientation.bundle import _Run, BundleOptions, adjust_block
    from fotogeo.orientation.bundle_lm import levenberg_marquardt

    t0 = time.perf_counter()
    sb = simulate_block(seed=0, **BLOCKS[name])
    t_sim = time.perf_counter() - t0
    b = sb.block
    t0 = time.perf_counter()
    r = adjust_block(b)
    t_full = time.perf_counter() - t0
    check = r.stats["check"]
    row = {"block": name, "frames": len(b.frames), "points": len(b.point_ids), "observations": len(b.obs_frame),
           "simulate_s": round(t_sim, 2), "adjust_s": round(t_full, 2), "iterations": r.iterations,
           "timings_s": {k: round(v, 2) for k, v in r.timings.items()}, "sigma0": round(r.sigma0, 3),
           "check_planimetric_gsd": round(check["rmse_planimetric_m"] / sb.gsd, 3),
           "check_height_gsd": round(check["rmse_z_m"] / sb.gsd, 3),
           "blunders_planted": int(len(sb.blunders)),
           "blunders_caught": int(np.sum(r.status[sb.blunders] != "used")),
           "peak_rss_mb_adjust": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)}
    clean = simulate_block(seed=0, blunder_fraction=0.0, **BLOCKS[name])
    run = _Run(clean.block, BundleOptions())
    pb, s = run.problem()
    truth = clean.true_xyz[pb.point_ids] - run.origin
    is_check = clean.block.role[pb.point_ids] == "check"
    t0 = time.perf_counter()
    s_fg, info = levenberg_marquardt(pb, s, pb.p0)
    row.update(fotogeo_solve_s=round(time.perf_counter() - t0, 3), fotogeo_solve_iterations=info.iterations,
               fotogeo_solve_check_gsd=_check_rmse(s_fg.X, truth, is_check, clean.gsd))
    cm = pycolmap_solve(pb, s, clean.block.camera)
    if cm is not None:
        row.update(pycolmap_solve_s=round(cm[0], 3), pycolmap_iterations=cm[2],
                   pycolmap_check_gsd=_check_rmse(cm[1], truth, is_check, clean.gsd),
                   time_ratio_fotogeo_to_pycolmap=round(row["fotogeo_solve_s"] / cm[0], 2))
    row["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    return row


def variance_component_cost(name: str, image_sigma: float) -> dict:
    """Adjust block ``name`` with its image σ stated as ``image_sigma`` px, with and without the image variance
    component (module docstring); the measurements as a dict."""
    from dataclasses import replace

    import numpy as np

    from fotogeo.orientation.block_simulation import simulate_block
    from fotogeo.orientation.bundle import BundleOptions, adjust_block

    sb = simulate_block(seed=0, **BLOCKS[name])
    b = replace(sb.block, obs_sigma=np.full(len(sb.block.obs_frame), image_sigma))
    row = {"block": name, "frames": len(b.frames), "observations": len(b.obs_frame), "image_sigma_px": image_sigma}
    for key, estimate in (("estimated", True), ("given", False)):
        t0, c0 = time.perf_counter(), time.process_time()
        r = adjust_block(b, BundleOptions(estimate_image_sigma=estimate))
        check = r.stats["check"]
        image = r.stats["variance_components"]["image"]
        row[key] = {"adjust_s": round(time.perf_counter() - t0, 2), "adjust_cpu_s": round(time.process_time() - c0, 2),
                    "iterations": r.iterations,
                    "sigma0": round(r.sigma0, 3), "image_sigma0": round(image["sigma0"], 3),
                    "factor": image.get("factor"),
                    "check_planimetric_gsd": round(check["rmse_planimetric_m"] / sb.gsd, 3),
                    "check_height_gsd": round(check["rmse_z_m"] / sb.gsd, 3)}
    row["time_ratio"] = round(row["estimated"]["adjust_s"] / row["given"]["adjust_s"], 2)
    row["cpu_ratio"] = round(row["estimated"]["adjust_cpu_s"] / row["given"]["adjust_cpu_s"], 2)
    return row


def _image_sigma_main(args):
    rows = []
    for name in args.blocks.split(","):
        out = subprocess.run([sys.executable, __file__, "--child", name, "--image-sigma", str(args.image_sigma)],
                             capture_output=True, text=True, check=True, cwd=ROOT)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(r)
        for key in ("estimated", "given"):
            e = r[key]
            print(f"{r['block']:6s} {r['frames']:4d} frames, image σ {args.image_sigma} px {key:9s}: adjust "
                  f"{e['adjust_s']:7.2f} s, CPU {e['adjust_cpu_s']:7.2f} s ({e['iterations']} it), σ0 {e['sigma0']:.3f} (image {e['image_sigma0']:.3f},"
                  f" factor {e['factor']}), check {e['check_planimetric_gsd']:.3f} / {e['check_height_gsd']:.3f} GSD")
        print(f"       with the variance component / without: wall {r['time_ratio']}, CPU {r['cpu_ratio']}")
    out = OUT.with_name("bundle_bench_image_sigma.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    ran = {r["block"] for r in rows}  # the blocks run now replace their earlier rows
    old = json.loads(out.read_text())["rows"] if out.is_file() else []
    rows = [r for r in old if r["block"] not in ran] + rows
    out.write_text(json.dumps({"machine": platform.platform(), "python": platform.python_version(),
                               "rows": rows}, indent=2) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", default="small,large")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--image-sigma", type=float, help="state the image points' σ as this many px (noise 0.3 px) and "
                    "time the adjustment with and without the image variance component")
    args = ap.parse_args()
    if args.child:
        print(json.dumps(run_block(args.child) if args.image_sigma is None
                         else variance_component_cost(args.child, args.image_sigma)))
        return
    if args.image_sigma is not None:
        return _image_sigma_main(args)
    rows = []
    for name in args.blocks.split(","):
        out = subprocess.run([sys.executable, __file__, "--child", name], capture_output=True, text=True,
                             check=True, cwd=ROOT)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
        r = rows[-1]
        print(f"{r['block']:6s} {r['frames']:4d} frames {r['points']:6d} points {r['observations']:7d} obs: "
              f"adjust {r['adjust_s']:7.2f} s, check {r['check_planimetric_gsd']:.2f} / {r['check_height_gsd']:.2f} "
              f"GSD, blunders {r['blunders_caught']}/{r['blunders_planted']}, peak {r['peak_rss_mb']:.0f} MB")
        print(f"       one solve: fotogeo {r['fotogeo_solve_s']:.2f} s ({r['fotogeo_solve_iterations']} it, check "
              f"{r['fotogeo_solve_check_gsd']} GSD)" + (
                  f", pycolmap {r['pycolmap_solve_s']:.2f} s ({r['pycolmap_iterations']} it, check "
                  f"{r['pycolmap_check_gsd']} GSD), ratio {r['time_ratio_fotogeo_to_pycolmap']}"
                  if "pycolmap_solve_s" in r else ", pycolmap not installed"))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps({"machine": platform.platform(), "python": platform.python_version(),
                               "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
