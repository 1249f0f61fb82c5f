"""A black collar without a nodata tag (issue 32): ``fotogeo mosaic`` of two overlapping orthophotos whose valid
area is a rectangle turned by ``--angle`` degrees inside a north-up raster, the outside 0,0,0 and no nodata tag
(what ``gdalwarp`` without ``-dstnodata`` writes for a turned scene, or a scanned map).

Run (from a folder outside any checkout, ``PYTHONPATH`` the tree measured)::

    cd /tmp && PYTHONPATH=/path/to/fotogeo /path/to/python /path/to/fotogeo/benchmarks/mosaic_collar_bench.py \
        [--angle 20] [--scale 1] [--data /work/shared/data] [--label NAME]

The truth is the NGI orthophoto ``ngi/ortho/ngi_rgb_byte_1.tif`` (5 m, RGB; its own outside, nodata 0, becomes
part of the collar once the tag is dropped; ``--scale k`` repeats each pixel k x k times, a larger file of the
same case). Two inputs cut from it overlap by ``--overlap`` columns; in each, the pixels outside its rectangle
(both turned alike) are set to 0 in every band and the nodata tag is dropped (``tests/collar_cases.py``). The
mosaic is compared with the truth where the truth is valid and at least one input's rectangle covers it, and over
the overlap of the two rectangles' bounding boxes (where a seamline or a blend could take the other input's
collar): mean grey level of mosaic and truth, mean absolute difference, and the share of cells darker than the
truth by more than 50 grey levels (the collar shows); and the ``fotogeo mosaic`` process's CPU seconds (user +
system) and peak resident memory (``RUSAGE_CHILDREN``). Writes benchmarks/results/mosaic_collar_bench.json.
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "mosaic_collar_bench.json"
sys.path.insert(0, str(ROOT / "tests"))
from collar_cases import ngi_turned_pair  # noqa: E402  (the case, shared with tests/test_mosaic_collar.py)


def measure(mosaic_path, truth, covers, both) -> dict:
    import rasterio
    with rasterio.open(mosaic_path) as ds:
        m = ds.read().astype(float)
    g_m, g_t = m.mean(axis=0), truth.astype(float).mean(axis=0)
    out = {}
    for name, area in (("covered", covers), ("overlap", covers & both)):
        d = g_m[area] - g_t[area]
        out[name] = {"cells": int(area.sum()), "mean_mosaic": round(float(g_m[area].mean()), 2),
                     "mean_truth": round(float(g_t[area].mean()), 2), "mae": round(float(np.abs(d).mean()), 2),
                     "dark_share": round(float((d < -50).mean()), 4)}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--angle", type=float, default=20.0)
    ap.add_argument("--overlap", type=int, default=300)
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--scale", type=int, default=1)
    ap.add_argument("--label", default="this tree")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="collar-bench-") as d:
        folder = Path(d)
        inputs, truth, covers, both = ngi_turned_pair(args.data / "ngi" / "ortho" / "ngi_rgb_byte_1.tif", folder,
                                                      args.angle, args.overlap * args.scale, args.scale)
        cmd = [sys.executable, "-m", "fotogeo", "mosaic", *map(str, inputs), "-o", str(folder / "m.tif")]
        t0 = time.perf_counter()
        run = subprocess.run(cmd, capture_output=True, text=True, cwd=d)
        if run.returncode:
            raise SystemExit(run.stderr)
        use = resource.getrusage(resource.RUSAGE_CHILDREN)  # the one child: the mosaic
        res = {"label": args.label, "angle_deg": args.angle, "overlap_px": args.overlap * args.scale,
               "scale": args.scale, "size": list(truth.shape[1:]), "wall_s": round(time.perf_counter() - t0, 2),
               "cpu_s": round(use.ru_utime + use.ru_stime, 2), "peak_rss_mb": round(use.ru_maxrss / 1024, 1),
               "notes": [ln for ln in run.stderr.splitlines() if ln.startswith(("Note:", "Warning:"))],
               **measure(folder / "m.tif", truth, covers, both)}
    print(json.dumps(res, indent=1))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(OUT.read_text()) if OUT.exists() else {}
    old[args.label + (f" scale {args.scale}" if args.scale > 1 else "")] = res
    OUT.write_text(json.dumps(old, indent=1) + "\n")


if __name__ == "__main__":
    main()
