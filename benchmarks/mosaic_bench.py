"""Mosaics (issue 21): ``fotogeo mosaic`` of a large block beside ``gdalbuildvrt`` + ``gdal_translate -of COG``.

Run:  .venv/bin/python benchmarks/mosaic_bench.py [--size 20000] [--grids 2 12] [--overlap 600] [--workers 1 2]

For each ``g`` of ``--grids``: ``g`` x ``g`` synthetic orthophotos (one uint8 band, a smooth texture without
repeats, 1 m pixels, EPSG:32635) overlapping by ``--overlap`` pixels and covering ``--size`` x ``--size``
together, each with its own gain and offset (a radiometric step of up to 1.3x + 15), written tiled and
DEFLATE-compressed in a temporary folder. Then, each in a fresh process under ``/usr/bin/time`` (wall time, CPU
time, peak resident memory of the largest process) while the resident memory of the whole process tree (Dask
workers included) is sampled every 0.1 s (``tree_peak_mb``):

* ``fotogeo mosaic`` — seamlines, balancing, feathering, tiles -> VRT -> COG with overviews and the seamline
  layers; in threads of one process, and for the first grid also on a local Dask cluster of each ``--workers``;
* ``gdalbuildvrt`` + ``gdal_translate -of COG`` (DEFLATE, all CPUs) — the same orthophotos stacked without
  seamlines or balancing: the floor to approach.

The grids show what grows with the number of orthophotos (2 x 2 = 4 against 12 x 12 = 144 on the same mosaic).
Writes benchmarks/results/mosaic_bench.json and prints a table.

``--nodata-inputs FILE...`` instead times, in this process (CPU s, ``time.process_time``), the count of the values
the mosaic's nodata must avoid (:func:`fotogeo.tools.ortho.mosaic_nodata.values_used`) on each file beside one plain
read of it, for the fotogeo on ``PYTHONPATH`` (run it with cwd outside any checkout to compare trees); adds one row
per tree and file to benchmarks/results/mosaic_nodata_bench.json.
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


def _tree_rss(proc) -> int:
    import psutil
    total = 0
    for p in [proc, *proc.children(recursive=True)]:
        try:
            total += p.memory_info().rss
        except psutil.Error:
            pass
    return total


def timed(cmd, env=None) -> dict:
    """Wall, CPU, peak RSS of the largest process (``/usr/bin/time``) and the sampled peak of the process tree."""
    import psutil
    p = subprocess.Popen(["/usr/bin/time", "-f", "TIME %e %M %U %S", *map(str, cmd)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env={**os.environ, **(env or {})})
    proc, tree = psutil.Process(p.pid), 0
    while p.poll() is None:
        tree = max(tree, _tree_rss(proc))
        time.sleep(0.1)
    out, err = p.communicate()
    if p.returncode != 0:
        raise RuntimeError(f"{cmd[0]} failed: {err[-800:]}")
    wall, rss, user, system = next(ln for ln in err.splitlines() if ln.startswith("TIME ")).split()[1:5]
    return {"wall_s": float(wall), "cpu_s": round(float(user) + float(system), 2), "peak_mb": round(int(rss) / 1024),
            "tree_peak_mb": round(tree / 2 ** 20)}


def write_block(folder: Path, size: int, grid: int, overlap: int, rng) -> list:
    step = (size - overlap) // grid
    side = step + overlap
    paths = []
    for i in range(grid):
        for j in range(grid):
            g, o = (1.0, 0.0) if not paths else (rng.uniform(0.8, 1.3), rng.uniform(-15, 15))
            p = folder / f"ortho_{i:02d}_{j:02d}.tif"
            write_tile(p, j * step, i * step, min(side, size - j * step), min(side, size - i * step), g, o)
            paths.append(p)
    return paths


def run_grid(size: int, grid: int, overlap: int, workers, rng) -> dict:
    res = {"grid": grid, "orthophotos": grid * grid}
    with tempfile.TemporaryDirectory(prefix="mosaic_bench_") as tmp:
        tmp = Path(tmp)
        paths = write_block(tmp, size, grid, overlap, rng)
        env = {"PYTHONPATH": str(ROOT)}
        cli = [sys.executable, "-c", "from fotogeo.cli import main; main()", "mosaic", *paths, "-q", "--overwrite"]
        res["fotogeo"] = timed([*cli, "-o", tmp / "mosaic.tif"], env)
        for w in workers:
            res[f"fotogeo_dask_{w}"] = timed([*cli, "-o", tmp / f"mosaic_{w}.tif", "--workers", w], env)
        listing = tmp / "orthos.txt"
        listing.write_text("\n".join(map(str, paths)) + "\n")
        res["gdal"] = {k: timed(cmd) for k, cmd in (
            ("gdalbuildvrt", ["gdalbuildvrt", "-q", "-input_file_list", listing, tmp / "m.vrt"]),
            ("gdal_translate_cog", ["gdal_translate", "-q", "-of", "COG", "-co", "COMPRESS=DEFLATE", "-co",
                                    "NUM_THREADS=ALL_CPUS", tmp / "m.vrt", tmp / "m_cog.tif"]))}
    g = res["gdal"]
    res["gdal_total"] = {"wall_s": round(sum(v["wall_s"] for v in g.values()), 2),
                         "cpu_s": round(sum(v["cpu_s"] for v in g.values()), 2),
                         "peak_mb": max(v["peak_mb"] for v in g.values()),
                         "tree_peak_mb": max(v["tree_peak_mb"] for v in g.values())}
    for k in [k for k in res if k.startswith("fotogeo")]:
        res[k]["ratio_wall"] = round(res[k]["wall_s"] / res["gdal_total"]["wall_s"], 2)
    return res


def table(res) -> str:
    lines = ["| orthophotos | run | wall s | CPU s | peak MB (largest process) | peak MB (process tree) "
             "| wall / GDAL |",
             "|---|---|---|---|---|---|---|"]
    for r in res["grids"]:
        for k in [k for k in r if k.startswith("fotogeo")] + ["gdal_total"]:
            v = r[k]
            name = {"fotogeo": "fotogeo mosaic (threads)", "gdal_total": "gdalbuildvrt + gdal_translate -of COG"}.get(
                k, k.replace("fotogeo_dask_", "fotogeo mosaic --workers "))
            lines.append(f"| {r['orthophotos']} | {name} | {v['wall_s']} | {v['cpu_s']} | {v['peak_mb']} | "
                         f"{v['tree_peak_mb']} | {v.get('ratio_wall', 1.0)} |")
    return "\n".join(lines)


def run_nodata(paths) -> list:
    """CPU s of ``values_used`` and of one plain read on each of ``paths`` (``--nodata-inputs``)."""
    import fotogeo
    from fotogeo.io.raster import ropen
    from fotogeo.tools.ortho.mosaic_nodata import values_used
    rows = []
    for p in paths:
        t = time.process_time()
        with ropen(p) as ds:
            shape, dtype = ds.read().shape, ds.dtypes[0]
        plain = time.process_time() - t
        t = time.process_time()
        used = values_used([p], np.dtype(dtype))
        rows.append({"tree": str(Path(fotogeo.__file__).parents[1]), "file": str(p), "shape": list(shape),
                     "dtype": dtype, "plain_read_cpu_s": round(plain, 3),
                     "values_used_cpu_s": round(time.process_time() - t, 3), "values_used": int(used.sum())})
        print(rows[-1])
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=20000)
    ap.add_argument("--grids", type=int, nargs="+", default=[2, 12])
    ap.add_argument("--overlap", type=int, default=600)
    ap.add_argument("--workers", type=int, nargs="*", default=[1, 2])
    ap.add_argument("--nodata-inputs", nargs="+", default=None)
    a = ap.parse_args(argv)
    if a.nodata_inputs:
        out = OUT.with_name("mosaic_nodata_bench.json")
        old = json.loads(out.read_text()) if out.exists() else []
        new = run_nodata(a.nodata_inputs)
        keep = [r for r in old if (r["tree"], r["file"]) not in {(n["tree"], n["file"]) for n in new}]
        out.write_text(json.dumps(keep + new, indent=1))
        return
    rng = np.random.default_rng(0)
    res = {"size": a.size, "overlap": a.overlap, "cpus": len(os.sched_getaffinity(0)),
           "load_before": os.getloadavg()[0], "grids": []}
    for k, grid in enumerate(a.grids):
        res["grids"].append(run_grid(a.size, grid, a.overlap, a.workers if k == 0 else [], rng))
    res["load_after"] = os.getloadavg()[0]
    print(table(res))
    OUT.write_text(json.dumps(res, indent=1))
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
