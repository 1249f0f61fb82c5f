"""``fotogeo ortho --error-threshold``: exact cell positions (0) against the interpolated ones (default 0.125 px)
and orthority, in alternating rounds on the drone case of ``ortho_bench.py`` (eBee IMG_2188 and IMG_2281 on the
triangulated block's 2-m surface, bilinear).

Run:  .venv/bin/python benchmarks/ortho_threshold_bench.py --orthority-python ORTHORITY/bin/python --drone-dir DIR
      [--resolutions 0.1,0.2] [--rounds 8] [--thresholds 0,0.125] [--baseline-tree /work/main]

Each round runs fotogeo at every threshold and then orthority, each a fresh process under ``/usr/bin/time``
(``ortho_bench.timed``: CPU = user + system, steadier than the wall time on a shared machine). Per resolution it
prints the median CPU seconds, the median over the rounds of each round's own ratio to orthority's CPU time (and
their range), and the agreement of the last round's outputs (``ortho_bench.tile_shifts``: 128² tiles
phase-correlated, shifts in output pixels) with orthority's and with the exact run's. ``--baseline-tree``: another
fotogeo checkout (a copy of its ``fotogeo`` package, compiled) also runs in every round with its defaults (row
``baseline``): a change's before and after under the same load. Also the interpolated positions against the exact
ones over every window (image pixels; ``--rounds 0``: only those) and the source level each frame is read at, with
the narrowest cell that decides it. Writes benchmarks/results/ortho_threshold_bench.json (``--rounds 0``:
ortho_threshold_positions.json).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from ortho_bench import (DATA, FOTOGEO_ENV, FOTOGEO_RUN, ORTHORITY_RUN, ROOT, drone_inputs, tile_shifts,
                         timed)

OUT = ROOT / "benchmarks" / "results" / "ortho_threshold_bench.json"


def one_resolution(work: Path, inp: dict, res: float, thresholds, rounds: int, oty_py: str,
                   baseline: Path | None = None) -> dict:
    """Timed rounds at ``res`` (module docstring); ``baseline``: another fotogeo checkout run in the same rounds with
    its own defaults (key ``baseline``), so that a change is measured before and after under the same load."""
    frames = inp["frames"]
    runs = {f"et{t:g}": [] for t in thresholds} | ({"baseline": []} if baseline else {}) | {"orthority": []}
    oty_dir = work / "orthority"
    oty_dir.mkdir(parents=True, exist_ok=True)
    for _ in range(rounds):
        for t in thresholds:
            out = work / f"et{t:g}"
            out.mkdir(exist_ok=True)
            args = ["ortho", *frames, "-o", str(out), "--dem", inp["dem"], "--camera", inp["camera"], "--eo",
                    inp["eo"], "--resolution", str(res), "--resampling", "bilinear", "--error-threshold", str(t),
                    "--overwrite", "-q"]
            runs[f"et{t:g}"].append(timed([sys.executable, "-c", FOTOGEO_RUN, *args], FOTOGEO_ENV))
        if baseline:
            (work / "baseline").mkdir(exist_ok=True)
            args = ["ortho", *frames, "-o", str(work / "baseline"), "--dem", inp["dem"], "--camera", inp["camera"],
                    "--eo", inp["eo"], "--resolution", str(res), "--resampling", "bilinear", "--overwrite", "-q"]
            runs["baseline"].append(timed([sys.executable, "-c", FOTOGEO_RUN, *args], {"PYTHONPATH": str(baseline)}))
        runs["orthority"].append(timed([oty_py, "-c", ORTHORITY_RUN, "frame", "-d", inp["dem"], "-ip", inp["camera"],
                                        "-ep", inp["ext"], *inp["crs"], "-r", str(res), "-ap", "-i", "bilinear",
                                        "-di", "bilinear", "-cm", "deflate", "-nwm", "-od", str(oty_dir), "-o",
                                        *frames]))
    oty = [r["cpu_s"] for r in runs["orthority"]]
    out = {"rounds": rounds, "cpu_s": {k: round(statistics.median(r["cpu_s"] for r in v), 3) for k, v in runs.items()},
           "wall_s": {k: round(statistics.median(r["wall_s"] for r in v), 3) for k, v in runs.items()}}
    stems = [Path(f).stem for f in frames]
    for k in [f"et{t:g}" for t in thresholds] + (["baseline"] if baseline else []):
        ratios = [r["cpu_s"] / o for r, o in zip(runs[k], oty)]
        out[f"cpu_ratio_{k}"] = {"median": round(statistics.median(ratios), 3), "min": round(min(ratios), 3),
                                 "max": round(max(ratios), 3)}
        out[f"agreement_{k}"] = {s: tile_shifts(work / k / f"{s}_ortho.tif", oty_dir / f"{s}_ORTHO.tif")
                                 for s in stems}
    for t in thresholds:
        if t != thresholds[0]:
            out[f"vs_et{thresholds[0]:g}_et{t:g}"] = {
                s: tile_shifts(work / f"et{t:g}" / f"{s}_ortho.tif", work / f"et{thresholds[0]:g}" / f"{s}_ortho.tif")
                for s in stems}
    return out


def position_errors(inp: dict, res: float, tol: float) -> dict:
    """Per frame, the interpolated positions (``error_threshold=tol``) against the exact ones, every window of the
    grid at ``res`` (image pixels): largest, 99th percentile and mean distance, and CPU seconds of each; and the
    source level the command reads (``source_level`` f: 1/f, :mod:`fotogeo.io.warp_levels`) with the narrowest
    output cell it is decided by (``cell_px_min``, source pixels; the next level needs f·2 / 1.01): a frame within a
    few % of that bound reads another level, and costs another decoding time, when its orientation moves slightly."""
    import time

    import numpy as np

    from fotogeo.io.raster import ropen
    from fotogeo.io.warp import make_plan, windows_of
    from fotogeo.io.warp_levels import cell_scale, reduction_factor
    from fotogeo.tools.ortho.inputs import image_models, map_crs, terrain
    from fotogeo.tools.ortho.tool import OrthoMapping, plan_grid
    frames = inp["frames"]
    crs = map_crs("auto", inp["dem"], inp["eo"], frames, False, inp["camera"], None, "auto")[0]
    ims = image_models(frames, crs, camera=inp["camera"], eo=inp["eo"], rpc=False, model=None, sfm_frame="auto",
                       said=[])
    heights = terrain(inp["dem"], None, crs, ims)[0]
    out = {}
    for im in ims:
        g = plan_grid(im, heights, crs, res, "unused.tif", inp["dem"])
        wins = windows_of(g.height, g.width, 512)
        grids, cpu = {}, {}
        for t in (0.0, tol):
            m = OrthoMapping(im.model, heights, (im.width, im.height), error_threshold=t)
            c = time.process_time()
            grids[t] = [np.asarray(m.grid(g.transform, *w), np.float64) for w in wins]
            cpu[t] = round(time.process_time() - c, 3)
        err = np.concatenate([np.hypot(*(a - e)).ravel() for a, e in zip(grids[tol], grids[0.0])])
        with ropen(im.path) as src:  # the level warp_to_grid(reduce=True) reads, by the same rule
            chosen = reduction_factor(src, make_plan(src, m, g.transform, "bilinear"), g.width, g.height)
        narrowest = cell_scale(m, g.transform, g.width, g.height, im.width, im.height)
        out[im.name] = {"max_px": round(float(np.nanmax(err)), 4), "p99_px": round(float(np.nanpercentile(err, 99)), 4),
                        "mean_px": round(float(np.nanmean(err)), 4), "cpu_s_exact": cpu[0.0], "cpu_s": cpu[tol],
                        "source_level": 1 if chosen is None else chosen[0],
                        "cell_px_min": None if narrowest is None else round(narrowest, 4)}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--orthority-python", required=True)
    ap.add_argument("--drone-dir", type=Path, required=True, help="ortho_bench.py's --drone-dir (made if absent)")
    ap.add_argument("--resolutions", default="0.1,0.2")
    ap.add_argument("--thresholds", default="0,0.125")
    ap.add_argument("--rounds", type=int, default=8, help="0: only the positions' errors")
    ap.add_argument("--baseline-tree", type=Path, help="another fotogeo checkout (e.g. main) timed in the same rounds")
    ap.add_argument("--out", type=Path, help="the JSON written [results/ortho_threshold_bench.json; --rounds 0: "
                                             "results/ortho_threshold_positions.json]")
    a = ap.parse_args(argv)
    if not DATA.exists():
        sys.exit(f"real data not found at {DATA} (set FOTOGEO_DATA)")
    thresholds = [float(t) for t in a.thresholds.split(",")]
    results = {"load_average_start": [round(v, 2) for v in os.getloadavg()], "resolutions": {}}
    inp = drone_inputs(a.drone_dir)
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(ROOT / "fotogeo")], check=True,
                   env={**os.environ, "PYTHONDONTWRITEBYTECODE": ""})  # as ortho_bench.py: an installed package's
    with tempfile.TemporaryDirectory(prefix="ortho_threshold_") as tmp:
        baseline = None
        if a.baseline_tree:  # a copy, compiled like this checkout (nothing is written into the other checkout)
            baseline = Path(tmp) / "baseline_tree"
            shutil.copytree(a.baseline_tree / "fotogeo", baseline / "fotogeo",
                            ignore=shutil.ignore_patterns("__pycache__"))
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(baseline / "fotogeo")], check=True,
                           env={**os.environ, "PYTHONDONTWRITEBYTECODE": ""})
        for res in (float(r) for r in a.resolutions.split(",")):
            r = one_resolution(Path(tmp) / f"{res:g}", inp, res, thresholds, a.rounds, a.orthority_python,
                               baseline) if a.rounds else {"cpu_s": {}}
            r["positions"] = {f"et{t:g}": position_errors(inp, res, t) for t in thresholds if t > 0}
            results["resolutions"][f"{res:g}"] = r
            print(json.dumps({f"{res:g}": r}), flush=True)
    results["load_average_end"] = [round(v, 2) for v in os.getloadavg()]
    print(f"{'res':>5} {'run':>10} {'cpu s':>6} {'ratio (range)':>20}  shift to orthority med dx/dy, p95 (px)")
    for res, r in results["resolutions"].items():
        for k, cpu in r["cpu_s"].items():
            ratio = r.get(f"cpu_ratio_{k}")
            agree = r.get(f"agreement_{k}", {})
            shifts = "; ".join(f"{v['median_dx']:+.4f}/{v['median_dy']:+.4f}, {v['p95_px']:.3f}"
                               for v in agree.values() if v.get("tiles"))
            rtxt = f"{ratio['median']:.3f} ({ratio['min']:.2f}-{ratio['max']:.2f})" if ratio else ""
            print(f"{res:>5} {k:>10} {cpu:>6.2f} {rtxt:>20}  {shifts}")
    for res, r in results["resolutions"].items():
        for k, frames in r["positions"].items():
            print(f"{res:>5} {k:>10} positions vs exact: " + "; ".join(
                f"{n} max {v['max_px']:.4f} p99 {v['p99_px']:.4f} mean {v['mean_px']:.4f} px, reads"
                f" 1/{v.get('source_level')} (narrowest cell {v.get('cell_px_min')} px)"
                for n, v in frames.items()))
    print(f"load average: start {results['load_average_start']}, end {results['load_average_end']}")
    out = a.out or (OUT if a.rounds else OUT.with_name("ortho_threshold_positions.json"))
    out.write_text(json.dumps(results, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
