"""The registration pipeline's tie points against the true geometry: box filters vs Gaussian layers.

Each NGI raw frame matched to its orthophoto tile by :func:`fotogeo.tools.register.match.find_tie_points` (the
pipeline's detection and matching, default options, ``PIPELINE_GAUSSIAN`` set each way); the frame keypoint is put
on the DEM through the true camera and exterior orientation (``tests/ngi_truth``) and into the orthophoto's pixels;
the error is the matched orthophoto keypoint minus that position (orthophoto pixels, 5 m). Matches within 3 px count
(the truth itself agrees with the orthophotos to 0.7-0.8 px RMSE, tests/test_camera.py): their number, mean (bias),
median and RMS error.

Run:  .venv/bin/python benchmarks/tie_truth_bench.py; writes ``benchmarks/results/tie_truth_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import rasterio
from pyproj import CRS

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from ngi_truth import FRAMES  # noqa: E402

from fotogeo.crs import transform_points  # noqa: E402
from fotogeo.features import detect  # noqa: E402
from fotogeo.io.camera import load_ngi_frame  # noqa: E402
from fotogeo.io.raster import open_raster, read_dem  # noqa: E402
from fotogeo.options import RegisterOptions  # noqa: E402
from fotogeo.tools.register.match import find_tie_points  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
NEAR = 3.0  # orthophoto pixels


def errors(ngi, name, ortho, dem):
    """(n matches, (k, 2) errors of the matches within NEAR px) for one frame."""
    frame = load_ngi_frame(ngi, name)
    ref = open_raster(ngi / "ortho" / ortho, "reference")
    tgt = open_raster(ngi / "frames" / f"{name}_RGB.tif", "target")
    with rasterio.open(ngi / "ortho" / ortho) as ds:
        inv, ocrs = ~ds.transform, ds.crs
    txy, rxy, _ = find_tie_points(ref, tgt, RegisterOptions())
    w = frame.pixel_to_world(txy, dem)
    ok = np.isfinite(w).all(axis=1)
    xy = transform_points(CRS.from_wkt(dem.crs.to_wkt()), CRS.from_wkt(ocrs.to_wkt()), w[ok, :2])
    col, row = inv * (xy[:, 0], xy[:, 1])
    e = rxy[ok] - np.column_stack([col, row])
    return len(txy), e[np.hypot(*e.T) < NEAR]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "tie_truth_bench.json")
    args = ap.parse_args()
    ngi = args.data / "ngi"
    dem = read_dem(ngi / "dem.tif")
    rows = []
    for name, ortho in FRAMES:
        for gaussian in (False, True):
            detect.PIPELINE_GAUSSIAN = gaussian
            n, e = errors(ngi, name, ortho, dem)
            row = {"frame": name, "detector": "gaussian" if gaussian else "box", "matches": n, "near": len(e),
                   "bias_px": e.mean(axis=0).tolist(), "median_px": float(np.median(np.hypot(*e.T))),
                   "rms_px": float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))}
            rows.append(row)
            print(f"{name[-4:]} {row['detector']:8s} matches {n:5d}  within {NEAR:g} px {len(e):5d}  bias "
                  f"{row['bias_px'][0]:+.3f} {row['bias_px'][1]:+.3f}  median {row['median_px']:.3f}  "
                  f"rms {row['rms_px']:.3f} px", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"near_px": NEAR, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
