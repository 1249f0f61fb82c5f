"""Resampling benchmark (issue 15): fotogeo's windowed warp vs gdalwarp and rasterio.warp.reproject.

Run:  .venv/bin/python benchmarks/resample_bench.py [--sizes 8000,20000] [--cog]

Source: an N x N x 3 uint8 tiled DEFLATE GeoTIFF (NGI orthophoto tile 1 up-sampled by
``gdal_translate -r cubic``, which streams) given a rotated geotransform (13.3 degrees, 0.5 m
pixels, EPSG:32735), so the north-up output grid (0.5 m, snapped) is about 1.22 N on a side and the
source is read through an affine mapping every program can express exactly. Every run writes
the same grid, nearest neighbour, nodata 0, 256² tiles, DEFLATE with predictor 2, BIGTIFF=IF_SAFER:

- ``fotogeo`` — :func:`fotogeo.io.warp.warp_to_grid` (threads = CPUs), without and with overviews;
- ``gdalwarp`` — ``gdalwarp -multi -wo NUM_THREADS=ALL_CPUS -et 0 -r near`` (+ ``gdaladdo -r nearest``
  with fotogeo's factors for the "with overviews" row);
- ``rasterio`` — ``rasterio.warp.reproject`` band objects to band objects (GDAL's chunked warp,
  ``num_threads`` = CPUs).

With ``--cog``, Cloud-Optimised GeoTIFF outputs too: ``register --cog``'s path (the warp with
overviews, then :func:`fotogeo.io.cog.convert_to_cog`), the tiled path
(:func:`fotogeo.io.warp_tiles.warp_tiled`: tiles by parallel tasks, VRT, one COG copy) and
``gdalwarp -of COG``, each timed against the last.

Each runs in its own process under ``/usr/bin/time`` (wall time and peak RSS). Pixels are compared
with gdalwarp's strip by strip (count of pixels differing in any band). fotogeo maps the source
through :class:`fotogeo.io.warp_gdal.GeotransformInverse` (GDAL's inverse geotransform arithmetic) and
takes GDAL's source pixel ``floor(x + 1e-10)`` in float64, so the expected count is 0. Writes
benchmarks/results/resample_bench.json.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
ORTHO = DATA / "ngi" / "ortho" / "ngi_rgb_byte_1.tif"
PY = sys.executable
CPUS = os.cpu_count() or 1

FOTOGEO = """
import sys, numpy as np, rasterio
from fotogeo.io.warp import warp_to_grid
from fotogeo.io.warp_gdal import GeotransformInverse
from affine import Affine
src, dst, ovr, t, w, h = sys.argv[1], sys.argv[2], sys.argv[3] == "1", Affine(*map(float, sys.argv[4:10])), int(sys.argv[10]), int(sys.argv[11])
with rasterio.open(src) as ds:
    inverse_map = GeotransformInverse(ds.transform)
warp_to_grid(src, dst, inverse_map, crs="EPSG:32735", transform=t, width=w, height=h, resampling="nearest", overviews=ovr)
"""
FOTOGEO_COG = """
import sys, rasterio
from affine import Affine
from fotogeo.io.cog import convert_to_cog
from fotogeo.io.warp import warp_to_grid
from fotogeo.io.warp_gdal import GeotransformInverse
from fotogeo.io.warp_tiles import warp_tiled
src, dst, tiled, t, w, h = sys.argv[1], sys.argv[2], sys.argv[3] == "1", Affine(*map(float, sys.argv[4:10])), int(sys.argv[10]), int(sys.argv[11])
with rasterio.open(src) as ds:
    inverse_map = GeotransformInverse(ds.transform)
kw = dict(crs="EPSG:32735", transform=t, width=w, height=h, resampling="nearest")
if tiled:
    warp_tiled(src, dst, inverse_map, **kw)
else:
    warp_to_grid(src, dst, inverse_map, **kw)
    convert_to_cog(dst, "nearest")
"""
RASTERIO = """
import sys, rasterio
from rasterio.warp import reproject, Resampling
from affine import Affine
from fotogeo.io.raster import geotiff_profile
src, dst, t, w, h = sys.argv[1], sys.argv[2], Affine(*map(float, sys.argv[3:9])), int(sys.argv[9]), int(sys.argv[10])
prof = geotiff_profile(width=w, height=h, count=3, dtype="uint8", crs="EPSG:32735", transform=t, nodata=0,
                       predictor=True, num_threads="ALL_CPUS")
with rasterio.Env(GDAL_CACHEMAX=256 * 2 ** 20), rasterio.open(src) as s, rasterio.open(dst, "w", **prof) as d:
    reproject(rasterio.band(s, [1, 2, 3]), rasterio.band(d, [1, 2, 3]), resampling=Resampling.nearest,
              src_nodata=None, dst_nodata=0, num_threads=%d, warp_mem_limit=256)
""" % CPUS


def timed(cmd, env=None) -> dict:
    """Wall time (s) and peak RSS (MB) of ``cmd`` under /usr/bin/time."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as f:
        subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", f.name, *cmd], check=True, env=env,
                       stdout=subprocess.DEVNULL)
        wall, rss = f.read().split()[-2:]
    return {"s": float(wall), "peak_mb": round(int(rss) / 1024, 1)}


def make_source(n: int, folder: Path) -> Path:
    import rasterio
    from affine import Affine
    path = folder / f"src_{n}.tif"
    subprocess.run(["gdal_translate", "-q", "-outsize", str(n), str(n), "-r", "cubic", "-co", "TILED=YES",
                    "-co", "COMPRESS=DEFLATE", "-co", "BIGTIFF=IF_SAFER", "--config", "GDAL_CACHEMAX", "256",
                    str(ORTHO), str(path)], check=True)
    with rasterio.open(path, "r+") as ds:
        ds.crs = "EPSG:32735"
        ds.transform = Affine.translation(500000, 7000000) * Affine.rotation(13.3) * Affine.scale(0.5, -0.5)
    return path


def differing(path, reference) -> int:
    """Pixels (any band) that differ between two rasters of the same grid, compared strip by strip."""
    import rasterio
    n = 0
    with rasterio.open(path) as a, rasterio.open(reference) as b:
        for r0 in range(0, a.height, 1024):
            win = rasterio.windows.Window(0, r0, a.width, min(1024, a.height - r0))
            n += int((a.read(window=win) != b.read(window=win)).any(axis=0).sum())
    return n


def cog_runs(src, folder: Path, grid, te, size) -> dict:
    """Cloud-Optimised GeoTIFF outputs: fotogeo's two paths (``register --cog``'s warp + COG copy,
    and the tiled warp whose tiles are assembled into a COG) and ``gdalwarp -of COG``."""
    runs = {"fotogeo warp+cog": timed([PY, "-c", FOTOGEO_COG, str(src), str(folder / "c_grid.tif"), "0", *grid]),
            "fotogeo tiled cog": timed([PY, "-c", FOTOGEO_COG, str(src), str(folder / "c_tiled.tif"), "1", *grid]),
            "gdalwarp -of COG": timed(["gdalwarp", "-q", "-multi", "-wo", "NUM_THREADS=ALL_CPUS", "-et", "0", "-r",
                                       "near", "-t_srs", "EPSG:32735", "-te", *te, "-ts", *size, "-dstnodata", "0",
                                       "--config", "GDAL_CACHEMAX", "256", "-of", "COG", "-co", "COMPRESS=DEFLATE",
                                       "-co", "PREDICTOR=2", "-co", "BIGTIFF=IF_SAFER", "-co", "NUM_THREADS=ALL_CPUS",
                                       str(src), str(folder / "c_gdal.tif")])}
    for k, v in runs.items():
        v["ratio_to_gdalwarp"] = round(v["s"] / runs["gdalwarp -of COG"]["s"], 2)
    names = {"fotogeo warp+cog": "c_grid", "fotogeo tiled cog": "c_tiled", "gdalwarp -of COG": "c_gdal"}
    diff = {k: differing(folder / f"{names[k]}.tif", folder / "g.tif") for k in runs}
    return {"runs": runs, "pixels_differing_from_gdalwarp": diff}


def run_size(n: int, folder: Path, cog: bool = False) -> dict:
    import rasterio
    from fotogeo.io.warp import grid_covering
    from fotogeo.pixels import outline, pixel_to_map
    src = make_source(n, folder)
    with rasterio.open(src) as ds:
        t, w, h = grid_covering(pixel_to_map(ds.transform, outline(ds.width, ds.height, 5)), 0.5)
    grid = [str(v) for v in list(t)[:6]] + [str(w), str(h)]
    factors = [str(f) for f in (2, 4, 8, 16, 32, 64) if min(w, h) / f >= 128]
    co = ["-co", "TILED=YES", "-co", "COMPRESS=DEFLATE", "-co", "PREDICTOR=2", "-co", "BIGTIFF=IF_SAFER",
          "-co", "NUM_THREADS=ALL_CPUS"]
    te = [str(t.c), str(t.f + t.e * h), str(t.c + t.a * w), str(t.f)]
    out = {"source": f"{n}x{n}x3 uint8", "grid": f"{w}x{h}", "cpus": CPUS}
    runs = {}
    runs["fotogeo"] = timed([PY, "-c", FOTOGEO, str(src), str(folder / "f.tif"), "0", *grid])
    runs["gdalwarp"] = timed(["gdalwarp", "-q", "-multi", "-wo", "NUM_THREADS=ALL_CPUS", "-et", "0", "-r", "near",
                              "-t_srs", "EPSG:32735", "-te", *te, "-ts", str(w), str(h), "-dstnodata", "0",
                              "--config", "GDAL_CACHEMAX", "256", *co, str(src), str(folder / "g.tif")])
    runs["rasterio"] = timed([PY, "-c", RASTERIO, str(src), str(folder / "r.tif"), *grid])
    diff = {k: differing(folder / f"{k[0]}.tif", folder / "g.tif") for k in runs}
    runs["fotogeo+overviews"] = timed([PY, "-c", FOTOGEO, str(src), str(folder / "fo.tif"), "1", *grid])
    add = timed(["gdaladdo", "-q", "-r", "nearest", "--config", "GDAL_NUM_THREADS", "ALL_CPUS", "--config",
                 "COMPRESS_OVERVIEW", "DEFLATE", str(folder / "g.tif"), *factors])
    runs["gdalwarp+gdaladdo"] = {"s": round(runs["gdalwarp"]["s"] + add["s"], 2),
                                 "peak_mb": max(runs["gdalwarp"]["peak_mb"], add["peak_mb"])}
    for k, v in runs.items():
        peer = "gdalwarp+gdaladdo" if "overviews" in k else "gdalwarp"
        v["ratio_to_gdalwarp"] = round(v["s"] / runs[peer]["s"], 2)
    out["runs"] = runs
    out["pixels"] = w * h
    out["pixels_differing_from_gdalwarp"] = diff
    if cog:
        out["cog"] = cog_runs(src, folder, grid, te, [str(w), str(h)])
    for f in folder.glob("*.tif"):
        f.unlink()
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="8000", help="comma-separated source sizes (8000,20000)")
    ap.add_argument("--cog", action="store_true", help="also time the Cloud-Optimised GeoTIFF paths")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "resample_bench.json"))
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="resample_bench."))
    try:
        results = {"machine": {"python": platform.python_version(), "cpus": CPUS, "load": os.getloadavg()},
                   "sizes": [run_size(int(n), folder, args.cog) for n in args.sizes.split(",")]}
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    Path(args.out).write_text(json.dumps(results, indent=1))
    for s in results["sizes"]:
        print(f"\n{s['source']} -> {s['grid']} (nearest, DEFLATE, {CPUS} CPUs)")
        print(f"{'program':22s} {'time s':>8s} {'x gdalwarp':>10s} {'peak MB':>8s}  pixels differing from gdalwarp (of {s['pixels']})")
        for k, v in s["runs"].items():
            same = s["pixels_differing_from_gdalwarp"].get(k, "")
            print(f"{k:22s} {v['s']:8.2f} {v['ratio_to_gdalwarp']:10.2f} {v['peak_mb']:8.0f}  {same}")
        for k, v in s.get("cog", {}).get("runs", {}).items():
            same = s["cog"]["pixels_differing_from_gdalwarp"][k]
            print(f"{k:22s} {v['s']:8.2f} {v['ratio_to_gdalwarp']:10.2f} {v['peak_mb']:8.0f}  {same}  (x gdalwarp -of COG)")
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
