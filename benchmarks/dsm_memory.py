"""Peak memory and time of ``fotogeo dsm`` on large rendered pairs: memory bounded by the tile, not by the images
or the output grid.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_memory.py [--sizes 2000,4000,6000] [--kind frames|rpc]
      [--resolution M] [--bounds XMIN,YMIN,XMAX,YMAX] [--workers 0,2] [--scheduler ADDRESS] [--code DIR]
      [--keep DIR] [--fill D] [--point-cloud]

Each case is a pair of ``size x size`` pixels rendered over a known terrain by ``tests/rendered_pair.py`` (0.1 m
ground sample distance, ±16 m of relief): ``--kind frames`` (default) nadir frames with their camera and exterior
orientation files (base-to-height ratio 0.4); ``--kind rpc`` a converging pair seen from high up through a narrow
view (base-to-height ratio 0.25) whose images carry RPCs fitted to the frames (``dsm --rpc``). The DSM is made in a
child process (default resolution 2 GSD, or ``--resolution``; ``--bounds``: a grid larger than the pair, nodata
beyond it, which measures what the output grid alone costs) whose peak resident memory (``VmHWM``: its own, not
``ru_maxrss``, which on Linux keeps the peak of the parent that rendered the pair), CPU and wall time are measured;
the DSM is then compared with the terrain at its cell centres (RMSE, NMAD, median; read by blocks) and the
report's completeness is read.

``--workers 0,2``: each size in the main process (0) and with its output tiles as tasks on a local Dask cluster of
2 worker processes (``dsm --workers 2``; ``--scheduler ADDRESS``: on a running cluster instead). ``peak_rss_mb``
stays the main process's own peak — what the tiles' results cost it — and ``workers_peak_rss_mb`` is the largest
peak of one worker process (polled every 0.2 s, from ``/proc/PID/status`` of the child's descendants).

``--fill D``: ``dsm --fill --fill-max-distance D`` (the filled band and its inpainting per tile); ``--point-cloud``:
``dsm --point-cloud points.laz`` too (every triangulated point written): both must keep the main process's memory
bounded by the tile as the plain DSM does.

``--code DIR`` measures the fotogeo of another checkout (its root on the child's PYTHONPATH), e.g. the main
branch's whole-image version, on the same renders. Prints a table and writes
benchmarks/results/dsm_memory.json (per code label, the latest row of each size with its command and load).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
from rendered_pair import CRS, GSD, accuracy, render, render_rpc  # noqa: E402

CHILD = r"""
import json, resource, sys, time, warnings
a = json.loads(sys.argv[1])


def peak_mb():
    # VmHWM: this process's own peak; Linux's ru_maxrss keeps the parent's peak across fork + exec, so a child
    # of a parent that rendered a large pair would report the parent's memory
    try:
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("VmHWM:")) / 1024.0
    except (OSError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def hwm_mb(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("VmHWM:")) / 1024.0
    except (OSError, StopIteration):
        return 0.0


import threading
import psutil
workers_peak, done = {}, threading.Event()


def poll():  # the Dask worker processes' peaks (descendants of this process), until the run ends
    me = psutil.Process()
    while not done.wait(0.2):
        for ch in me.children(recursive=True):
            workers_peak[ch.pid] = max(workers_peak.get(ch.pid, 0.0), hwm_mb(ch.pid))


threading.Thread(target=poll, daemon=True).start()
from fotogeo.tools.dsm import dsm
c, w = time.process_time(), time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    rep = dsm(a["images"], a["out"], camera=a.get("camera"), eo=a.get("eo"), rpc="camera" not in a, crs=a["crs"],
              report=a["report"], resolution=a.get("resolution"), bounds=a.get("bounds"), overwrite=True,
              workers=a.get("workers") or None, scheduler=a.get("scheduler"), fill=a.get("fill", False),
              fill_max_distance=(a.get("fill_max_distance") or 4.0) if a.get("fill") else None,
              point_cloud=a.get("point_cloud"))
done.set()
kids = [psutil.Process(p) for p in list(workers_peak) if psutil.pid_exists(p)]
print(json.dumps({"cpu_s": time.process_time() - c, "wall_s": time.perf_counter() - w,
                  "children_cpu_s": resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
                  + resource.getrusage(resource.RUSAGE_CHILDREN).ru_stime,
                  "peak_rss_mb": peak_mb(), "workers_peak_rss_mb": max(workers_peak.values(), default=0.0),
                  "completeness": rep["completeness"], "grid": rep["grid"]}))
"""


def run(sc: dict, folder: Path, code: Path, resolution=None, bounds=None, workers=0, scheduler=None,
        fill=None, point_cloud=False) -> dict:
    tag = "" if code == ROOT else f"_{code.name}"  # another checkout's outputs beside, not over, this one's
    tag += (f"_{resolution:g}m" if resolution else "") + ("_bounds" if bounds else "")
    tag += f"_dask{workers}" if workers else ("_dask" if scheduler else "")
    tag += (f"_fill{fill:g}" if fill else "") + ("_las" if point_cloud else "")
    args = {**sc, "crs": CRS, "resolution": resolution, "bounds": bounds, "out": str(folder / f"dsm{tag}.tif"),
            "report": str(folder / f"report{tag}.json"), "workers": workers, "scheduler": scheduler,
            "fill": bool(fill), "fill_max_distance": fill,
            "point_cloud": str(folder / f"points{tag}.laz") if point_cloud else None}
    env = dict(os.environ, PYTHONPATH=str(code), GDAL_PAM_ENABLED="NO", OMP_NUM_THREADS="1")
    r = subprocess.run([sys.executable, "-c", CHILD, json.dumps(args)], env=env, capture_output=True, text=True)
    if r.returncode:
        raise SystemExit(f"the DSM run failed:\n{r.stderr[-3000:]}")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    return {**out, **accuracy(args["out"])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="2000,4000,6000")
    ap.add_argument("--code", default=str(ROOT), help="the fotogeo checkout to measure")
    ap.add_argument("--keep", default=None, help="render into (and reuse) this folder")
    ap.add_argument("--kind", default="frames", choices=("frames", "rpc"))
    ap.add_argument("--resolution", type=float, default=None, help="DSM cell size (m) [2 GSD]")
    ap.add_argument("--bounds", default=None, help="DSM extent 'xmin,ymin,xmax,ymax' in EPSG:32635 [the overlap]: "
                    "a grid larger than the pair (nodata beyond it) measures the memory of the output grid alone")
    ap.add_argument("--workers", default="0", help="comma-separated: 0 = the tiles in the main process, N = on a "
                    "local Dask cluster of N worker processes (dsm --workers N)")
    ap.add_argument("--scheduler", default=None, help="the tiles on the running Dask scheduler at this address")
    ap.add_argument("--fill", type=float, default=None, metavar="D",
                    help="dsm --fill --fill-max-distance D (cells) [no filling]")
    ap.add_argument("--point-cloud", action="store_true", help="also write the point cloud (dsm --point-cloud)")
    a = ap.parse_args()
    code = Path(a.code).resolve()
    label = ("this checkout" if code == ROOT else str(code)) + ("" if a.kind == "frames" else f" ({a.kind})")
    rows, load0 = [], os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(a.keep or tmp)
        for size in (int(s) for s in a.sizes.split(",")):
            folder = base / (f"pair_{size}" if a.kind == "frames" else f"rpc_pair_{size}")
            folder.mkdir(parents=True, exist_ok=True)
            t = time.perf_counter()
            sc = (json.loads((folder / "scene.json").read_text()) if (folder / "scene.json").is_file()
                  else (render if a.kind == "frames" else render_rpc)(folder, size))
            (folder / "scene.json").write_text(json.dumps(sc))
            render_s = time.perf_counter() - t
            for workers in (int(x) for x in a.workers.split(",")):
                r = run({k: v for k, v in sc.items() if k != "rpc_fit_px"}, folder, code, a.resolution, a.bounds,
                        workers, a.scheduler, a.fill, a.point_cloud)
                g = r.pop("grid")
                rows.append({"size_px": size, "resolution_m": g["resolution"], "bounds": a.bounds,
                             "tiles": "dask " + (a.scheduler or f"{workers} workers") if workers or a.scheduler
                             else "main process", "fill_max_distance": a.fill, "point_cloud": a.point_cloud,
                             "image_mb": round(2 * size * size / 2 ** 20, 1),
                             "dsm_cells": f"{g['width']}x{g['height']}",
                             "dsm_mcells": round(g["width"] * g["height"] / 1e6, 1), "render_s": round(render_s, 1),
                             **r})
                print(rows[-1], flush=True)
                _save(label, rows, load0)  # after every run: a long run stopped half way keeps what it measured
    head = ("size_px", "resolution_m", "tiles", "image_mb", "dsm_cells", "peak_rss_mb", "workers_peak_rss_mb", "cpu_s",
            "children_cpu_s", "wall_s", "rmse_m", "nmad_m", "completeness")
    print(" | ".join(head))
    for r in rows:
        print(" | ".join(f"{r[k]:.3f}" if isinstance(r[k], float) else str(r[k]) for k in head))


def _save(label: str, rows: list, load0) -> None:
    res = ROOT / "benchmarks" / "results" / "dsm_memory.json"
    old = json.loads(res.read_text()) if res.is_file() else {}
    key = lambda r: (r["size_px"], r.get("resolution_m"), r.get("bounds"), r.get("tiles", "main process"),  # noqa: E731
                     r.get("fill_max_distance"), r.get("point_cloud", False))
    sizes = {key(r) for r in rows}  # rows of other sizes from earlier runs stay, each with its command
    kept = [r for r in old.get(label, {}).get("rows", []) if key(r) not in sizes]
    now = {"command": "benchmarks/dsm_memory.py " + " ".join(sys.argv[1:]),
           "load_average": [round(load0[0], 1), round(os.getloadavg()[0], 1)]}
    old[label] = {"gsd_m": GSD, "rows": sorted(kept + [{**r, **now} for r in rows],
                                               key=lambda r: (r["size_px"], -(r.get("resolution_m") or 0)))}
    res.write_text(json.dumps(old, indent=1))


if __name__ == "__main__":
    main()
