"""How close ``fotogeo ortho`` is to the I/O floor on small outputs (issue 30: ``ortho`` at 0.5x orthority's CPU time).

Run:  .venv/bin/python benchmarks/ortho_floor_bench.py --orthority-python VENV/bin/python [--rounds 6]
      [--cases ngi,ngi_dem_utm] [--resolution 5]

Per case (``ortho_bench_inputs``: the NGI frames, ``ngi_dem_utm`` their DEM in UTM 35S), in alternating rounds of
fresh processes under ``/usr/bin/time`` (CPU = user + system): ``fotogeo ortho`` (as ``ortho_bench.py`` runs it),
orthority's ``oty frame`` (the same flags as there) and the **floor**: a process that only imports numpy, rasterio
and OpenCV, reads the DEM and each frame whole and writes fotogeo's orthophotos again (their pixels, profile and
creation options: 256² tiles, DEFLATE level 1, predictor; both
files' MB in the JSON) with the same average overviews, in GDAL's reading and
writing of one thread — what any tool that reads these inputs with GDAL and writes these files pays, before it
computes a single position. Medians over the rounds; the ratios over orthority are the median of each round's own.
Writes benchmarks/results/ortho_floor_bench.json.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from pathlib import Path

from ortho_bench import FOTOGEO_ENV, FOTOGEO_RUN, ORTHORITY_RUN, ROOT, timed
from ortho_bench_inputs import ngi_inputs, ngi_variant

OUT = ROOT / "benchmarks" / "results" / "ortho_floor_bench.json"

FLOOR_RUN = """
import sys, glob, os
import numpy as np, rasterio, cv2
from rasterio.enums import Resampling
dem, src_dir, dst_dir, frames = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
with rasterio.Env(GDAL_NUM_THREADS="1", GDAL_CACHEMAX=256 * 2 ** 20, ZLEVEL_OVERVIEW="1"):
    with rasterio.open(dem) as d:
        d.read(1, masked=True)
    for f in frames:
        with rasterio.open(f) as s:
            a = np.empty((s.height, s.width, s.count), s.dtypes[0])
            s.read(out=a.transpose(2, 0, 1))
        name = os.path.splitext(os.path.basename(f))[0] + "_ortho.tif"
        with rasterio.open(os.path.join(src_dir, name)) as o:
            pixels, profile, factors = o.read(), o.profile, o.overviews(1)
        # the file's profile carries neither the DEFLATE level nor the predictor: fotogeo's are given
        options = {**profile, "zlevel": 1, "predictor": 2, "num_threads": "1"}
        with rasterio.open(os.path.join(dst_dir, name), "w", **options) as w:
            w.write(pixels)
            w.build_overviews(factors, Resampling.average)
"""


def run_case(case: str, work: Path, res: float, oty_py: str, rounds: int) -> dict:
    inp = ngi_inputs(work) if case == "ngi" else ngi_variant(work, case[4:])
    fg_dir, oty_dir, floor_dir = work / "fotogeo", work / "orthority", work / "floor"
    for d in (fg_dir, oty_dir, floor_dir):
        d.mkdir(exist_ok=True)
    fg = [sys.executable, "-c", FOTOGEO_RUN, "ortho", *inp["frames"], "-o", str(fg_dir), "--dem", inp["dem"],
          "--camera", inp["camera"], "--eo", inp["eo"], "--resolution", str(res), "--resampling", "bilinear",
          "--overwrite", "-q", *inp.get("fotogeo_args", [])]
    oty = [oty_py, "-c", ORTHORITY_RUN, "frame", "-d", inp["dem"], "-ip", inp["camera"], "-ep", inp["ext"],
           *inp["crs"], "-r", str(res), "-ap", "-i", "bilinear", "-di", "bilinear", "-cm", "deflate", "-nwm",
           "-od", str(oty_dir), "-o", *inp["frames"]]
    floor = [sys.executable, "-c", FLOOR_RUN, inp["dem"], str(fg_dir), str(floor_dir), *inp["frames"]]
    timed(fg, FOTOGEO_ENV)  # fotogeo's outputs, which the floor writes again
    runs = [(timed(fg, FOTOGEO_ENV), timed(oty), timed(floor)) for _ in range(rounds)]
    med = {k: round(statistics.median(r[i]["cpu_s"] for r in runs), 3)
           for i, k in enumerate(("fotogeo", "orthority", "floor"))}
    ratio = {k: round(statistics.median(r[i]["cpu_s"] / r[1]["cpu_s"] for r in runs), 3)
             for i, k in ((0, "fotogeo"), (2, "floor"))}
    mb = {k: round(sum(p.stat().st_size for p in d.glob("*.tif")) / 1e6, 3) for k, d in (("fotogeo", fg_dir),
                                                                                        ("floor", floor_dir))}
    return {"cpu_s": med, "mb": mb, "ratio_to_orthority": ratio,
            "fotogeo_above_floor_s": round(med["fotogeo"] - med["floor"], 3),
            "rounds": rounds, "cpu_s_each": {k: [round(r[i]["cpu_s"], 3) for r in runs]
                                             for i, k in enumerate(("fotogeo", "orthority", "floor"))}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--orthority-python", required=True, help="python of a venv with orthority 0.7.0 installed")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--cases", default="ngi,ngi_dem_utm")
    ap.add_argument("--resolution", type=float, default=5.0)
    a = ap.parse_args(argv)
    out = {"load_average_start": [round(v, 2) for v in os.getloadavg()], "cases": {}}
    with tempfile.TemporaryDirectory(prefix="ortho_floor_") as tmp:
        for case in a.cases.split(","):
            work = Path(tmp) / case
            work.mkdir()
            out["cases"][case] = run_case(case, work, a.resolution, a.orthority_python, a.rounds)
    out["load_average_end"] = [round(v, 2) for v in os.getloadavg()]
    print(f"{'case':12s} {'fotogeo':>8s} {'orthority':>9s} {'floor':>6s}  fotogeo/oty  floor/oty  "
          "fotogeo-floor (CPU s)")
    for case, r in out["cases"].items():
        c, q = r["cpu_s"], r["ratio_to_orthority"]
        print(f"{case:12s} {c['fotogeo']:8.3f} {c['orthority']:9.3f} {c['floor']:6.3f}  {q['fotogeo']:11.3f} "
              f"{q['floor']:10.3f}  {r['fotogeo_above_floor_s']:.3f}")
    print(f"load average: start {out['load_average_start']}, end {out['load_average_end']}")
    OUT.write_text(json.dumps({**out, "command": " ".join(sys.argv)}, indent=1))
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
