"""How far ``fotogeo dsm --fill``'s interpolated heights are from the truth, by distance to the matched cells.

``--fill`` fills the holes inside the convex hull of each output tile's matched cells by Telea's inpainting (Telea
2004), at most ``--fill-max-distance`` cells from a matched cell, and marks them in the fourth band. Each case runs
``fotogeo dsm ... --fill --fill-max-distance D`` for each D of ``--max-distances`` as a user does (a child process,
``cwd`` outside any checkout, ``PYTHONPATH`` the tree measured: this checkout and ``--baseline-tree`` in the same run)
and compares the DSM with a truth at its cell centres:

* ``rendered`` — the rendered nadir pair of ``tests/rendered_pair.py`` (``--size`` pixels, 0.1 m ground sample
  distance, ±16 m of smooth relief): the terrain function itself;
* ``ngi`` — NGI frames 0182/0184 with their camera, EO and ``--dem ngi/dem.tif`` at 12 m: the 24 m DEM resampled
  bilinearly (a coarse reference: the matched cells' own RMSE against it is the floor).

Per case, tree and D: the matched cells' RMSE, the filled cells' count, RMSE and largest error in bins of distance
(cells) to the nearest matched cell, and CPU = user + system of the child. Printed as a table and written to
``benchmarks/results/dsm_fill_bench.json`` (keys ``CASE TREE md=D``; a D above the tree's range, or a baseline tree
without the option, is run without it).

    PYTHONPATH=. .venv/bin/python benchmarks/dsm_fill_bench.py [--cases rendered,ngi] [--size 400]
        [--max-distances 2,4,8,64] [--baseline-tree OLD] [--work DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "benchmarks" / "results" / "dsm_fill_bench.json"
BINS = ((0, 1), (1, 2), (2, 4), (4, 8), (8, 16), (16, 32), (32, 10 ** 9))


def inputs(case: str, work: Path, size: int) -> tuple:
    """``(dsm arguments, truth(x, y, dsm_dataset) -> heights)`` of a case."""
    if case == "rendered":
        import rendered_pair
        p = rendered_pair.render(work, size)
        args = [*p["images"], "--camera", p["camera"], "--eo", p["eo"], "--crs", rendered_pair.CRS]
        return args, lambda x, y, ds: rendered_pair.terrain(x - rendered_pair.ORIGIN[0], y - rendered_pair.ORIGIN[1])
    ngi = DATA / "ngi"
    frames = [str(ngi / "frames" / f"3324c_2015_1004_05_{n}_RGB.tif") for n in ("0182", "0184")]
    args = [*frames, "--camera", str(ngi / "interior_orientation.yaml"), "--eo", str(ngi / "exterior_orientation.txt"),
            "--dem", str(ngi / "dem.tif"), "--resolution", "12"]
    return args, dem_truth(ngi / "dem.tif")


def dem_truth(path: Path):
    """The DEM at ``path`` resampled bilinearly onto a DSM's grid."""
    def truth(_x, _y, ds):
        import rasterio
        from rasterio.warp import Resampling, reproject
        out = np.full((ds.height, ds.width), np.nan)
        with rasterio.open(path) as r:
            reproject(r.read(1).astype(float), out, src_transform=r.transform, src_crs=r.crs,
                      dst_transform=ds.transform, dst_crs=ds.crs, resampling=Resampling.bilinear, dst_nodata=np.nan)
        return out
    return truth


def run(tree: Path, args: list, out: Path, md: float | None) -> float:
    """``fotogeo dsm ARGS --fill [--fill-max-distance MD] -o OUT`` with ``tree``'s fotogeo; returns the child's CPU
    seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    limit = [] if md is None else ["--fill-max-distance", f"{md:g}"]
    p = subprocess.run([sys.executable, "-m", "fotogeo", "-q", "dsm", *args, "--fill", *limit, "-o", str(out)],
                       env=dict(os.environ, PYTHONPATH=str(tree)), cwd=out.parent, capture_output=True, text=True)
    if p.returncode:
        raise SystemExit(f"dsm failed with {tree}: {p.stderr.strip()[-400:]}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def errors(dsm: Path, truth) -> dict:
    """Matched and filled cells' errors against ``truth``, the filled ones by distance to the matched cells."""
    import rasterio
    from scipy import ndimage
    with rasterio.open(dsm) as ds:
        h = ds.read(1).astype(float)
        h[h == ds.nodata] = np.nan
        mask = ds.read(4)
        rows, cols = np.mgrid[0:ds.height, 0:ds.width]
        x, y = ds.transform * (cols + 0.5, rows + 0.5)
        d = h - truth(np.asarray(x), np.asarray(y), ds)
    matched, filled = np.isfinite(d) & (mask == 0), np.isfinite(d) & (mask == 1)
    dist = ndimage.distance_transform_edt(~(np.isfinite(h) & (mask == 0)))
    row = {"matched_cells": int(matched.sum()), "matched_rmse_m": rms(d[matched]), "filled_cells": int(filled.sum()),
           "filled_rmse_m": rms(d[filled]), "by_distance": {}}
    for lo, hi in BINS:
        s = filled & (dist > lo) & (dist <= hi)
        if s.any():
            row["by_distance"][f"{lo}-{hi if hi < 10 ** 9 else 'inf'}"] = {
                "cells": int(s.sum()), "rmse_m": rms(d[s]), "max_m": round(float(np.abs(d[s]).max()), 2)}
    return row


def rms(v) -> float:
    return round(float(np.sqrt(np.mean(v ** 2))), 2) if len(v) else float("nan")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="rendered,ngi")
    ap.add_argument("--size", type=int, default=400, help="the rendered pair's size in pixels [400]")
    ap.add_argument("--max-distances", default="2,4,8,64",
                    help="the --fill-max-distance values run, in cells [2,4,8,64; 64: the largest]")
    ap.add_argument("--baseline-tree", type=Path, help="a second checkout measured in the same run (no distance "
                    "limit: run once, without --fill-max-distance)")
    ap.add_argument("--work", type=Path, help="folder for the inputs and DSMs [a temporary one]")
    a = ap.parse_args(argv)
    if "ngi" in a.cases and not DATA.exists():
        sys.exit(f"real data not found at {DATA} (set FOTOGEO_DATA)")
    trees = {"this checkout": ROOT, **({"baseline": a.baseline_tree.resolve()} if a.baseline_tree else {})}
    results = json.loads(OUT.read_text()) if OUT.is_file() else {}
    with tempfile.TemporaryDirectory() as tmp:
        work = a.work or Path(tmp)
        for case in a.cases.split(","):
            (work / case).mkdir(parents=True, exist_ok=True)
            args, truth = inputs(case, work / case, a.size)
            for label, tree, md in [(k, t, None if k == "baseline" else float(d)) for k, t in trees.items()
                                    for d in (a.max_distances.split(",") if k != "baseline" else [None])]:
                dsm = work / case / f"dsm_{label.replace(' ', '_')}_{md}.tif"
                dsm.unlink(missing_ok=True)
                cpu = run(tree, args, dsm, md)
                row = {"cpu_s": round(cpu, 2), "fill_max_distance": md, **errors(dsm, truth),
                       "command": " ".join(sys.argv), "load_average": [round(v, 1) for v in os.getloadavg()[:2]]}
                key = f"{case} {label}" + ("" if md is None else f" md={md:g}")
                results[key] = row
                print(f"{key:24s} matched {row['matched_rmse_m']:6.2f} m ({row['matched_cells']}), "
                      f"filled {row['filled_rmse_m']:6.2f} m ({row['filled_cells']}), CPU {cpu:.1f} s")
                for k, b in row["by_distance"].items():
                    print(f"{'':25s} distance {k:>7s} cells: {b['cells']:6d}, RMSE {b['rmse_m']:6.2f} m, "
                          f"max {b['max_m']:6.2f} m")
    OUT.write_text(json.dumps(results, indent=1))
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
