"""Batch co-registration benchmark (issue 15): throughput on a local Dask cluster with 1 and 2 workers.

Run:  .venv/bin/python benchmarks/batch_bench.py [--scenes 40] [--workers 1,2]

Scenes: Landsat RGB (``../shared/data/landsat_rgb``) as the reference; each target a 320² crop
of it under a known similarity-plus-perspective warp (rotation, scale and position vary with the
scene number; tests/batch_scenes.py), re-banded and noisy, without georeference. Every run
registers all scenes with :func:`fotogeo.tools.register.batch.register_batch` (SIFT, 2000 keypoints, the
reference's CRS) on ``LocalCluster(n_workers=W, threads_per_worker=1, processes=True)``; the
cluster start is timed apart. Each result is checked against its known warp (RMS over a dense
grid of the target, reference pixels; correct = below 0.5 px). Throughput = scenes / batch time;
scaling = throughput(W) / throughput(1). Writes benchmarks/results/batch_bench.json.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
REF = DATA / "landsat_rgb" / "RGB.byte.tif"
OPTIONS = {"detector": "sift", "max_keypoints": 2000, "dst_crs": "EPSG:32618"}


def run(workers: int, scenes: dict, folder: Path) -> dict:
    import distributed
    from batch_scenes import model_error_px
    from fotogeo.io.manifest import read_csv
    from fotogeo.tools.register.batch import SINGLE_THREAD_ENV, register_batch
    t0 = time.perf_counter()
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                                  env=dict(SINGLE_THREAD_ENV)) as cluster, distributed.Client(cluster) as client:
        client.wait_for_workers(workers)
        start = time.perf_counter() - t0
        out = folder / f"out_{workers}"
        t1 = time.perf_counter()
        r = register_batch(REF, list(scenes), out, client=client, **OPTIONS)
        elapsed = time.perf_counter() - t1
    rows = read_csv(r.manifest_csv)
    errors = [model_error_px(out / f"{Path(row['target']).stem}.json", REF, scenes[Path(row["target"])], 320)
              if row["status"] == "ok" else None for row in rows]
    correct = sum(e is not None and e < 0.5 for e in errors)
    ok_errors = [e for e in errors if e is not None]
    return {"workers": workers, "scenes": len(rows), "ok": r.ok, "failed": r.failed, "correct_below_0.5px": correct,
            "max_model_error_px": round(max(ok_errors), 3) if ok_errors else None,
            "cluster_start_s": round(start, 2), "batch_s": round(elapsed, 2),
            "scenes_per_s": round(len(rows) / elapsed, 3),
            "mean_scene_s": round(sum(row["seconds"] for row in rows) / len(rows), 3)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=40)
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "batch_bench.json"))
    args = ap.parse_args()
    from batch_scenes import make_scene
    folder = Path(tempfile.mkdtemp(prefix="batch_bench."))
    try:
        (folder / "scenes").mkdir()
        scenes = {p.resolve(): H for p, H in (make_scene(REF, folder / "scenes", k) for k in range(args.scenes))}
        runs = [run(int(w), scenes, folder) for w in args.workers.split(",")]
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    base = runs[0]["scenes_per_s"]
    for r in runs:
        r["scaling"] = round(r["scenes_per_s"] / base, 2)
    result = {"machine": {"python": platform.python_version(), "cpus": os.cpu_count(), "load": os.getloadavg()},
              "options": OPTIONS, "runs": runs}
    Path(args.out).write_text(json.dumps(result, indent=1))
    print(f"{'workers':>7s} {'scenes':>6s} {'ok':>4s} {'correct':>7s} {'batch s':>8s} {'scenes/s':>9s} {'scaling':>7s} "
          f"{'start s':>7s} {'max err px':>10s}")
    for r in runs:
        print(f"{r['workers']:7d} {r['scenes']:6d} {r['ok']:4d} {r['correct_below_0.5px']:7d} {r['batch_s']:8.2f} "
              f"{r['scenes_per_s']:9.3f} {r['scaling']:7.2f} {r['cluster_start_s']:7.2f} {r['max_model_error_px']:10.3f}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
