"""What warping a DEM into the map's CRS first would cost in heights (issue 30, ``ortho_bench.py``'s ``ngi_dem_utm``).

Run:  .venv/bin/python benchmarks/dem_resample_error.py [--points 400000] [--factors 1,2,4] [--out JSON]

The NGI DEM warped to UTM 35S + EGM2008 (``ortho_bench_inputs.ngi_variant``, 24 m) is warped back onto a north-up
grid of the frames' Lo25 whose cells are the DEM's divided by each factor (``rasterio.warp.reproject``, bilinear:
what orthority does with a DEM in another CRS than the output's); at random points of that grid the bilinear heights
of the warped grid are compared with fotogeo's (:class:`fotogeo.geometry.dem.DemSampler`: the point transformed into
the DEM's CRS exactly, the DEM's own bilinear height). Reports the height differences (max, 99th percentile, mean,
m), the points the warped grid loses at the DEM's edge, and the CPU time of the warp. Writes
benchmarks/results/dem_resample_error.json (or ``--out``).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ortho_bench_inputs import NGI_LO25, ngi_variant  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=400_000)
    ap.add_argument("--factors", default="1,2,4")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "dem_resample_error.json")
    a = ap.parse_args(argv)
    from affine import Affine
    from rasterio.crs import CRS as RioCRS
    from rasterio.warp import Resampling, reproject

    from fotogeo.crs import parse_crs, transform_points
    from fotogeo.geometry.dem import Dem, DemSampler
    from fotogeo.geometry.vertical import horizontal_crs
    from fotogeo.io.raster import read_dem
    from fotogeo.pixels import outline
    out = {"command": " ".join(sys.argv), "factors": {}}
    with tempfile.TemporaryDirectory(prefix="dem_resample_") as tmp:
        d = read_dem(ngi_variant(Path(tmp), "dem_utm")["dem"])
    crs = parse_crs(NGI_LO25)
    exact = DemSampler(d, crs)
    rows, cols = d.shape
    rim = np.array([d.transform * tuple(p) for p in outline(cols, rows, 33)])
    xy = transform_points(horizontal_crs(d.crs), crs, rim)
    (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
    P = np.random.default_rng(0).uniform((x0, y0), (x1, y1), (a.points, 2))
    he = exact.heights(P)
    for k in (int(f) for f in a.factors.split(",")):
        size = abs(d.transform.a) / k
        w, h = int(np.ceil((x1 - x0) / size)), int(np.ceil((y1 - y0) / size))
        grid = np.full((h, w), np.nan)
        t0 = time.process_time()
        reproject(np.where(np.isfinite(d.data), d.data, np.nan), grid, src_transform=d.transform,
                  src_crs=RioCRS.from_wkt(horizontal_crs(d.crs).to_wkt()), src_nodata=np.nan,
                  dst_transform=Affine(size, 0, x0, 0, -size, y1), dst_crs=RioCRS.from_wkt(crs.to_wkt()),
                  dst_nodata=np.nan, resampling=Resampling.bilinear)
        cpu = time.process_time() - t0
        hw = Dem(grid, Affine(size, 0, x0, 0, -size, y1)).heights(P)
        ok = np.isfinite(he) & np.isfinite(hw)
        diff = np.abs(he - hw)[ok]
        out["factors"][k] = {"cell_m": size, "cells": [h, w], "warp_cpu_s": round(cpu, 3),
                             "max_m": round(float(diff.max()), 3), "p99_m": round(float(np.percentile(diff, 99)), 3),
                             "mean_m": round(float(diff.mean()), 4), "points": int(ok.sum()),
                             "lost": int((np.isfinite(he) & ~np.isfinite(hw)).sum()),
                             "gained": int((~np.isfinite(he) & np.isfinite(hw)).sum())}
        print(json.dumps({k: out["factors"][k]}), flush=True)
    a.out.write_text(json.dumps(out, indent=1))
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
