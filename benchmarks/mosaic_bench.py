"""Mosaics (issue 21): ``fotogeo mosaic`` of a large block beside ``gdalbuildvrt`` + ``gdal_translate -of COG``.

Run:  .venv/bin/python benchmarks/mosaic_bench.py [--size 20000] [--tiles 2] [--overlap 600]

``--tiles`` x ``--tiles`` synthetic orthophotos (one uint8 band, a smooth texture without repeats, 1 m pixels,
EPSG:32635) overlapping by ``--overlap`` pixels and covering ``--size`` x ``--size`` together, each with its own
gain and offset (a radiometric step of up to 1.3x + 15), written tiled and DEFLATE-compressed in a temporary
folder. Then, each in a fresh process under ``/usr/bin/time`` (wall time, CPU time, peak resident memory):

* ``fotogeo mosaic`` — seamlines, balancing, feathering, the mosaic with overviews and the seamline layers;
* ``gdalbuildvrt`` + ``gdal_translate -of COG`` (DEFLATE, all CPUs) — the same orthophotos stacked without
  seamlines or balancing: the floor to approach.

Writes benchmarks/results/mosaic_bench.json and prints it.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "mosaic_bench.json"
X0, Y1 = 500000.0, 4420000.0


def texture(x, y):
    return 100 + 40 * np.sin(x / 9.0) * np.cos(y / 13.0) + 25 * np.sin((x + 2 * y) / 37.0) + 10 * np.cos(x / 101.0)


def write_tile(path, c0, r0, w, h, gain, offset):
    import rasterio
    from affine import Affine
    from rasterio.windows import Window
    t = Affine(1.0, 0, X0 + c0, 0, -1.0, Y1 - r0)
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=1, dtype="uint8", crs="EPSG:32635",
                       transform=t, nodata=0, tiled=True, blockxsize=512, blockysize=512, compress="deflate",
                       predictor=2, zlevel=1) as ds:
        for r in range(0, h, 1024):
            hh = min(1024, h - r)
            cols, rows = np.meshgrid(np.arange(w) + c0 + 0.5, np.arange(hh) + r0 + r + 0.5)
            v = gain * texture(cols, rows) + offset
            ds.write(np.clip(np.rint(v), 1, 255).astype(np.uint8)[None], window=Window(0, r, w, hh))
        ds.update_tags(FOTOGEO_NADIR=f"{X0 + c0 + w / 2} {Y1 - r0 - h / 2}")


def timed(cmd, env=None) -> dict:
    p = subprocess.run(["/usr/bin/time", "-f", "TIME %e %M %U %S", *map(str, cmd)], capture_output=True, text=True,
                       env={**os.environ, **(env or {})})
    if p.returncode != 0:
        raise RuntimeError(f"{cmd[0]} failed: {p.stderr[-500:]}")
    wall, rss, user, system = next(ln for ln in p.stderr.splitlines() if ln.startswith("TIME ")).split()[1:5]
    return {"wall_s": float(wall), "cpu_s": round(float(user) + float(system), 2), "peak_mb": round(int(rss) / 1024)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=20000)
    ap.add_argument("--tiles", type=int, default=2)
    ap.add_argument("--overlap", type=int, default=600)
    a = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    res = {"size": a.size, "tiles": a.tiles, "overlap": a.overlap, "cpus": len(os.sched_getaffinity(0))}
    with tempfile.TemporaryDirectory(prefix="mosaic_bench_") as tmp:
        tmp = Path(tmp)
        step = (a.size - a.overlap) // a.tiles
        side = step + a.overlap
        paths, steps = [], []
        for i in range(a.tiles):
            for j in range(a.tiles):
                g, o = (1.0, 0.0) if not paths else (rng.uniform(0.8, 1.3), rng.uniform(-15, 15))
                p = tmp / f"ortho_{i}_{j}.tif"
                write_tile(p, j * step, i * step, min(side, a.size - j * step), min(side, a.size - i * step), g, o)
                paths.append(p)
                steps.append((g, o))
        res["tile_gain_offset"] = steps
        env = {"PYTHONPATH": str(ROOT)}
        res["fotogeo"] = timed([sys.executable, "-c", "from fotogeo.cli import main; main()", "mosaic", *paths, "-o",
                                tmp / "mosaic.tif", "-q"], env)
        res["gdal"] = {k: timed(cmd) for k, cmd in (
            ("gdalbuildvrt", ["gdalbuildvrt", "-q", tmp / "m.vrt", *paths]),
            ("gdal_translate_cog", ["gdal_translate", "-q", "-of", "COG", "-co", "COMPRESS=DEFLATE", "-co",
                                    "NUM_THREADS=ALL_CPUS", tmp / "m.vrt", tmp / "m_cog.tif"]))}
        res["gdal_total_wall_s"] = round(sum(v["wall_s"] for v in res["gdal"].values()), 2)
        res["ratio_wall"] = round(res["fotogeo"]["wall_s"] / res["gdal_total_wall_s"], 2)
    print(json.dumps(res, indent=1))
    OUT.write_text(json.dumps(res, indent=1))
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
