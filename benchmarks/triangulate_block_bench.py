"""A rendered 500-frame block end to end (tie-point matching + adjustment), in this process and on Dask (issue 20).

A block of 25 strips x 20 frames of 600 x 400 px (60 % forward, 30 % side overlap at the ground, each strip
flown 1000 m above the mean terrain under it — ``above_terrain``; hills of ``relief`` 40 m, which add up to a
terrain spanning about 230 m over a 10 x 10 block; ``--datum-height``: every frame 1000 m above the datum, the
block of the first runs, whose overlaps shrink to 46/7 % over the high ground;
:func:`fotogeo.orientation.block_simulation.simulate_block` and
:func:`fotogeo.orientation.block_render.render_block`) is matched by
:func:`fotogeo.tools.triangulate.match.block_tie_points` (pyramid level 1, epipolar RANSAC, tracks, Gruber
thinning 3 x 3 x 25, LSM) and adjusted with the block's simulated control
(:func:`fotogeo.orientation.bundle.adjust_block`), three ways:

* ``local`` — the default: every pair in this process, one after the other;
* ``dask-1``, ``dask-2`` — the pairs as Dask tasks (:mod:`fotogeo.tools.triangulate.pairs`) on a local cluster
  of 1 and 2 worker processes, one thread each (the cluster of ``--workers``, as ``register-batch``'s).

Per run: wall time of the pair matching, of the rest of the tie-point step (tracks, thinning, LSM — in this
process either way) and of the adjustment; the peak resident memory of this process and of each worker
process (psutil, sampled every 0.1 s); whether the tie points equal the local run's (they must); and the
accuracy against the truth the frames were rendered from: the tie points' true transfer error (first run;
:func:`true_transfer_errors`), RMSE of the adjusted projection centres (m) and angles (°), the worst frame,
check points (m), σ₀, the frames the frame check (:mod:`fotogeo.orientation.bundle_quality`) refuses; per
strip the pairs (by their first frame), their epipolar inliers, the tracks and the tracks of 3 or more rays
(``per_strip``). Printed as a table and written to
``benchmarks/results/triangulate_block_bench.json`` with the machine's load average (the times depend on it).

    .venv/bin/python benchmarks/triangulate_block_bench.py [--strips 25 --per-strip 20] [--work DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import psutil

from fotogeo.geometry.camera import FrameCamera, OrientedFrame
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.orientation.bundle_quality import frame_quality, undetermined_frames
from fotogeo.tools.common.dask_cluster import connect
from fotogeo.tools.triangulate import match as tri_match

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from rendered_block_ties import with_ties, write_frames  # noqa: E402

CAMERA = FrameCamera(6.0, (6.0, 4.0), (600, 400))  # 600 x 400 px; GSD 1.67 m at 1000 m


class PeakMemory:
    """Peak resident memory (MB) of a set of processes, sampled in a thread."""

    def __init__(self, pids: dict, every_s: float = 0.1):
        self.procs = {name: psutil.Process(pid) for name, pid in pids.items()}
        self.peak = {name: 0.0 for name in pids}
        self.every_s, self._stop = every_s, threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        while not self._stop.is_set():
            for name, p in self.procs.items():
                try:
                    self.peak[name] = max(self.peak[name], p.memory_info().rss / 2 ** 20)
                except psutil.Error:
                    pass
            self._stop.wait(self.every_s)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def rendered_block(work: Path, strips: int, per_strip: int, above_terrain: bool = True):
    """The simulated block and its frames in ``work`` (rendered once; the same seed and flight render the same
    frames — a folder rendered with the other flight must not be reused)."""
    sb = simulate_block(seed=3, strips=strips, frames_per_strip=per_strip, camera=CAMERA, point_spacing=80.0,
                        blunder_fraction=0.0, margin=5.0, n_control=9, n_check=40, above_terrain=above_terrain)
    paths = [work / f"{n}.tif" for n in sb.block.frames]
    if not all(p.is_file() for p in paths):
        t0 = time.perf_counter()
        images, _ = render_block(sb, seed=3)
        paths = write_frames(work, sb, images)
        print(f"rendered {len(paths)} frames in {time.perf_counter() - t0:.0f} s", flush=True)
    return sb, paths


class StepTimes:
    """Times the pair matching and the LSM of block_tie_points (module functions wrapped while in use)."""

    STEPS = {"_pair_results": "pairs_s", "refine_tracks": "lsm_s"}

    def __enter__(self):
        self.spent, self.originals = {}, {name: getattr(tri_match, name) for name in self.STEPS}
        for name, original in self.originals.items():
            setattr(tri_match, name, self._timed(original, self.STEPS[name]))
        return self.spent

    def _timed(self, original, key):
        def wrapper(*a, **k):
            t0 = time.perf_counter()
            try:
                return original(*a, **k)
            finally:
                self.spent[key] = self.spent.get(key, 0.0) + time.perf_counter() - t0
        return wrapper

    def __exit__(self, *exc):
        for name, original in self.originals.items():
            setattr(tri_match, name, original)


def accuracy(sb, res) -> dict:
    """RMSE of the adjusted centres (m) and angles (°) against the truth, check points, σ₀."""
    true = {n: e for n, e in zip(sb.block.frames, sb.true_eo)}
    dc = np.array([e.centre - true[n].centre for n, e in zip(res.frames, res.eo)])
    da = np.array([[e.omega - true[n].omega, e.phi - true[n].phi, (e.kappa - true[n].kappa + 180) % 360 - 180]
                   for n, e in zip(res.frames, res.eo)])
    chk = res.stats["check"]
    worst = int(np.argmax(np.sum(dc ** 2, axis=1)))
    return {"centre_rmse_m": float(np.sqrt(np.mean(np.sum(dc ** 2, axis=1)))),
            "centre_median_m": float(np.median(np.sqrt(np.sum(dc ** 2, axis=1)))),
            "worst_frame": res.frames[worst], "worst_centre_m": float(np.sqrt(np.sum(dc[worst] ** 2))),
            "worst_angle_deg": float(np.abs(da[worst]).max()),
            "worst_frame_sigma": np.round(res.eo_sigma[worst], 4).tolist(),
            "centre_rmse_xyz_m": np.sqrt(np.mean(dc ** 2, axis=0)).round(4).tolist(),
            "angle_rmse_deg": float(np.sqrt(np.mean(da ** 2))),
            "angle_rmse_opk_deg": np.sqrt(np.mean(da ** 2, axis=0)).round(5).tolist(),
            "check_n": chk["n"], "check_plan_m": chk["rmse_planimetric_m"], "check_z_m": chk["rmse_z_m"],
            "sigma0": float(res.sigma0), "image_rms_px": res.stats.get("image_rms_px")}


def run(sb, paths, name, workers, adjust=True):
    """One end-to-end run: ``workers`` None = in this process, else a local cluster of that many workers;
    ``adjust`` False: the tie points only."""
    b = sb.block
    height = float(np.nanmean(b.point_xyz[:, 2]))
    pids, client, close = {"main": os.getpid()}, None, lambda: None
    t_cluster = time.perf_counter()
    if workers:
        client, close = connect(workers=workers, what="the Dask runs")
        pids.update({f"worker{k + 1}": pid for k, pid in enumerate(sorted(client.run(os.getpid).values()))})
    t_cluster = time.perf_counter() - t_cluster
    try:
        with PeakMemory(pids) as mem, StepTimes() as spent:
            t0 = time.perf_counter()
            ties = tri_match.block_tie_points(paths, b.camera, b.eo, height, client=client)
            t1 = time.perf_counter()
            blk = with_ties(sb, *ties[:4], 0.3)
            res = adjust_block(blk, BundleOptions()) if adjust else None
            t2 = time.perf_counter()
    finally:
        close()
    rep = ties[4]
    row = {"run": name, "workers": workers or 0, "frames": len(paths), "pairs": len(rep["pairs"]),
           "tracks": rep["tracks"], "observations": int(len(ties[0])), "rays_per_track": rep["rays_per_track"],
           "cluster_start_s": t_cluster, **spent, "ties_s": t1 - t0, "adjust_s": (t2 - t1) if adjust else None,
           "total_s": (t2 - t0) if adjust else None, "peak_rss_mb": {k: round(v, 1) for k, v in mem.peak.items()}}
    if adjust:
        row.update(adjust_timings=res.timings, iterations=res.iterations, **accuracy(sb, res),
                   undetermined_frames=sorted(undetermined_frames(frame_quality(res, blk))))
    return row, ties


def per_strip(sb, per_strip_frames: int, frame, track, pairs) -> list:
    """Per strip: pairs whose first frame is in it, their epipolar inliers, tracks observed in it and those of
    3 or more rays."""
    rays = np.bincount(track)[track]
    rows = []
    for s in range(len(sb.block.frames) // per_strip_frames):
        mine = [p for p in pairs if p["pair"][0] // per_strip_frames == s]
        seen = frame // per_strip_frames == s
        rows.append({"strip": s + 1, "pairs": len(mine), "inliers": int(sum(p["inliers"] for p in mine)),
                     "tracks": int(len(np.unique(track[seen]))),
                     "tracks_3_rays": int(len(np.unique(track[seen & (rays >= 3)])))})
    return rows


def true_transfer_errors(sb, frame, track, pixel) -> dict:
    """The tie points against the rendered truth: each track's anchor (its lowest frame) ray meets the true
    surface (8 fixed-point steps), the ground point is projected into the track's other frames through the
    true cameras; the distance to the matched pixel (px)."""
    order = np.lexsort((frame, track))
    first = order[np.r_[True, np.diff(track[order]) != 0]]
    err = np.full(len(frame), np.nan)
    members = np.split(order, np.flatnonzero(np.diff(track[order])) + 1)
    for fa in np.unique(frame[first]):
        a = first[frame[first] == fa]
        of = OrientedFrame(sb.true_camera, sb.true_eo[fa])
        Z = np.full(len(a), float(np.nanmean(sb.block.point_xyz[:, 2])))
        for _ in range(8):
            ground = of.pixel_to_world_at(pixel[a], Z)
            Z = sb.surface(ground[:, :2])
        ground[:, 2] = Z
        for k, g in zip(a, ground):
            for o in members[track[k]]:
                if o != k:
                    err[o] = np.hypot(*(OrientedFrame(sb.true_camera, sb.true_eo[frame[o]]).world_to_pixel(g[None])[0]
                                        - pixel[o]))
    e = err[np.isfinite(err)]
    bad = np.unique(track[err > 10])
    return {"transfers": int(len(e)), "median_px": float(np.median(e)), "share_above_2px": float(np.mean(e > 2)),
            "share_above_10px": float(np.mean(e > 10)), "tracks_with_a_transfer_above_10px": int(len(bad))}


def same_ties(a, b) -> dict:
    """Whether two runs' tie points are the same: frames, tracks and pair matches equal; the largest LSM pixel
    and σ difference (px; 0 unless BLAS threads differ: the workers run with one thread, this process with many)."""
    same = (len(a[0]) == len(b[0]) and np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
            and a[4]["pairs"] == b[4]["pairs"])
    return {"same_tracks": bool(same), "max_pixel_diff_px": float(np.abs(a[2] - b[2]).max()) if same else None,
            "max_sigma_diff_px": (float(np.abs(a[3] - b[3]).max()) if same and a[3] is not None else None)}


def _num(v, fmt):
    return "-".rjust(len(format(0.0, fmt))) if v is None else format(v, fmt)


def table(rows) -> str:
    """The runs side by side; speed-up of the tie points (pairs + LSM) against the first run."""
    lines = [f"{'run':7s} {'pairs s':>8s} {'LSM s':>7s} {'ties s':>7s} {'speed-up':>8s} {'adjust s':>8s} "
             f"{'total s':>8s} {'peak MB main / workers':>24s} {'centres m':>9s} {'angles °':>9s} "
             f"{'check xy/z m':>13s} same tracks (max px diff)"]
    base = rows[0]["ties_s"]
    for r in rows:
        workers = " ".join(f"{v:.0f}" for k, v in r["peak_rss_mb"].items() if k != "main") or "-"
        check = "-" if "check_plan_m" not in r else f"{r['check_plan_m']:.3f}/{r['check_z_m']:.3f}"
        lines.append(f"{r['run']:7s} {r['pairs_s']:8.1f} {r['lsm_s']:7.1f} {r['ties_s']:7.1f} "
                     f"{base / r['ties_s']:8.2f} {_num(r['adjust_s'], '8.1f')} {_num(r['total_s'], '8.1f')} "
                     f"{r['peak_rss_mb']['main']:8.0f} / {workers:13s} {_num(r.get('centre_rmse_m'), '9.3f')} "
                     f"{_num(r.get('angle_rmse_deg'), '9.4f')} {check:>13s} {r['same_tracks']} "
                     f"({_num(r['max_pixel_diff_px'], '.1e')})")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--strips", type=int, default=25)
    ap.add_argument("--per-strip", type=int, default=20)
    ap.add_argument("--runs", default="local,dask-1,dask-2", help="comma-separated: local, dask-N")
    ap.add_argument("--adjust", choices=("all", "first"), default="all",
                    help="adjust in every run, or in the first only (the tie points are the same, so is the adjustment)")
    ap.add_argument("--datum-height", action="store_true",
                    help="fly every frame 1000 m above the datum (the first runs' block) instead of each strip "
                         "1000 m above its terrain")
    ap.add_argument("--work", help="folder for the rendered frames (kept; reused when present) [a temporary one]")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "triangulate_block_bench.json"))
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(a.work or tmp)
        work.mkdir(parents=True, exist_ok=True)
        sb, paths = rendered_block(work, a.strips, a.per_strip, above_terrain=not a.datum_height)
        rows, reference = [], None
        for name in a.runs.split(","):
            load = os.getloadavg()
            row, ties = run(sb, paths, name, None if name == "local" else int(name.split("-")[1]),
                            adjust=a.adjust == "all" or not rows)
            reference = reference or ties
            row.update(same_ties(ties, reference))
            if len(rows) == 0:
                row["tie_truth"] = true_transfer_errors(sb, *ties[:3])
                row["per_strip"] = per_strip(sb, a.per_strip, ties[0], ties[1], ties[4]["pairs"])
            row["load_average_1_5_15"] = [round(x, 2) for x in load]
            rows.append(row)
            print(f"{name}: {json.dumps({k: v for k, v in row.items() if k != 'adjust_timings'})}", flush=True)
            print(table(rows), flush=True)
            Path(a.out).write_text(json.dumps({  # after every run: a long benchmark keeps what it measured
                "note": "wall times on a shared 2-core machine (load average per run)", "cpus": os.cpu_count(),
                "frame_size": list(CAMERA.image_size), "strips": a.strips, "frames_per_strip": a.per_strip,
                "gsd_m": sb.gsd, "above_terrain": not a.datum_height,
                "terrain_m": [round(float(sb.true_xyz[:, 2].min()), 1), round(float(sb.true_xyz[:, 2].max()), 1)],
                "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
