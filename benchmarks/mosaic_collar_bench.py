"""A black collar without a nodata tag (issue 32): ``fotogeo mosaic`` of two overlapping orthophotos whose valid
area is a rectangle turned by ``--angle`` degrees inside a north-up raster, the outside 0,0,0 and no nodata tag
(what ``gdalwarp`` without ``-dstnodata`` writes for a turned scene, or a scanned map).

Run:  cd /tmp && .venv/bin/python benchmarks/mosaic_collar_bench.py [--angle 20] [--data ../shared/data]

The truth is the NGI orthophoto ``ngi/ortho/ngi_rgb_byte_1.tif`` (5 m, RGB; its own outside, nodata 0, becomes
part of the collar once the tag is dropped). Two inputs cut from it overlap by ``--overlap`` columns; in each,
the pixels outside its rectangle (both turned alike) are set to 0 in every band and the nodata tag is dropped. The mosaic is compared with the truth where the truth is valid
and at least one input's rectangle covers it, and over the overlap of the two rectangles' bounding boxes (where
a seamline or a blend could take the other input's collar): mean grey level of mosaic and truth, mean absolute
difference, and the share of cells darker than the truth by more than 50 grey levels (the collar shows).
Writes benchmarks/results/mosaic_collar_bench.json (the fotogeo on ``sys.path``: run it with ``PYTHONPATH``
pointing at the tree to measure, from a folder outside any checkout).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "mosaic_collar_bench.json"


def turned_inside(h: int, w: int, angle: float, shrink: float) -> np.ndarray:
    """Cells of an ``h`` x ``w`` grid inside a rectangle turned by ``angle`` degrees about the centre and scaled
    by ``shrink`` so that its corners stay inside the grid."""
    rows, cols = np.mgrid[0:h, 0:w] + 0.5
    a = np.radians(angle)
    x, y = cols - w / 2, rows - h / 2
    u, v = np.cos(a) * x + np.sin(a) * y, -np.sin(a) * x + np.cos(a) * y
    return (np.abs(u) <= shrink * w / 2) & (np.abs(v) <= shrink * h / 2)


def write(path, bands, transform, crs):
    import rasterio
    with rasterio.open(path, "w", driver="GTiff", width=bands.shape[2], height=bands.shape[1], count=bands.shape[0],
                       dtype="uint8", crs=crs, transform=transform) as ds:  # no nodata tag
        ds.write(bands)


def build(data: Path, folder: Path, angle: float, overlap: int):
    """The two inputs, the truth and the masks of the derived case."""
    import rasterio
    with rasterio.open(data / "ngi" / "ortho" / "ngi_rgb_byte_1.tif") as ds:
        truth, valid = ds.read(), ds.read_masks(1) > 0  # its own outside (nodata 0) is a collar too once untagged
        t, crs = ds.transform, ds.crs
    h, w = truth.shape[1:]
    half = (w + overlap) // 2
    inputs, covers = [], np.zeros((h, w), bool)
    for k, c0 in enumerate((0, w - half)):
        part = truth[:, :, c0:c0 + half].copy()
        inside = turned_inside(h, half, angle, 0.72)  # both turned alike: a seam must cross a collar
        part[:, ~inside] = 0
        write(folder / f"turned_{k}.tif", part, t * t.translation(c0, 0), crs)
        inputs.append(folder / f"turned_{k}.tif")
        covers[:, c0:c0 + half] |= inside
    both = np.zeros((h, w), bool)
    both[:, w - half:half] = True
    return inputs, truth, covers & valid, both


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
    ap.add_argument("--label", default="this tree")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="collar-bench-") as d:
        folder = Path(d)
        inputs, truth, covers, both = build(args.data, folder, args.angle, args.overlap)
        cmd = [sys.executable, "-m", "fotogeo", "mosaic", *map(str, inputs), "-o", str(folder / "m.tif")]
        t0 = time.perf_counter()
        run = subprocess.run(cmd, capture_output=True, text=True, cwd=d)
        if run.returncode:
            raise SystemExit(run.stderr)
        res = {"label": args.label, "angle_deg": args.angle, "overlap_px": args.overlap,
               "size": list(truth.shape[1:]), "wall_s": round(time.perf_counter() - t0, 2),
               "notes": [ln for ln in run.stderr.splitlines() if ln.startswith(("Note:", "Warning:"))],
               **measure(folder / "m.tif", truth, covers, both)}
    print(json.dumps(res, indent=1))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(OUT.read_text()) if OUT.exists() else {}
    old[args.label] = res
    OUT.write_text(json.dumps(old, indent=1) + "\n")


if __name__ == "__main__":
    main()
