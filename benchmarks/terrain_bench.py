"""Terrain-aware registration (issue 6) beside the homography pipeline and the best homography.

For each NGI raw frame registered to its orthophoto (and to the 10 m Sentinel-2 scene), with
truth from the camera, exterior orientation and DEM on a dense grid of frame pixels:

* ``best H``  — the best homography that exists (least squares to the truth grid);
* ``H``       — fotogeo's 2-D pipeline (SURF, RANSAC, balanced projective fit);
* ``dlt``, ``collinearity``, ``auto`` — ``register(..., dem=...)`` with that 3-D model,
  each also with ``--refine lsm`` (``auto`` alone is the default: ``--refine auto`` is no LSM
  terrain-aware).

Dense RMSE: the model's ground position of each grid pixel (at its true height) against the
truth, in metres. Run: ``.venv/bin/python benchmarks/terrain_bench.py [--surf-layers box|gaussian]`` (3-6 min);
writes ``benchmarks/results/terrain_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from ngi_truth import FRAMES, truth_points  # noqa: E402

from fotogeo.crs import transform_points  # noqa: E402
from fotogeo.models import Projective  # noqa: E402
from fotogeo.tools.register.tool import register  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
#: the CRS of ngi_truth.truth_points (its default); the output's map coordinates are compared in it
TRUTH_CRS = "EPSG:32735"


def rms(e):
    return float(np.sqrt(np.mean(np.sum(np.asarray(e) ** 2, axis=1))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "terrain_bench.json")
    ap.add_argument("--surf-layers", choices=("pipeline", "box", "gaussian"), default="pipeline",
                    help="SURF's layers in the pipeline: its default (detect.PIPELINE_GAUSSIAN), box or Gaussian")
    args = ap.parse_args()
    if args.surf_layers != "pipeline":
        from fotogeo.features import detect
        detect.PIPELINE_GAUSSIAN = args.surf_layers == "gaussian"
    ngi = args.data / "ngi"
    cam = ngi / "interior_orientation.yaml"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, ortho in FRAMES:
            px, truth = truth_points(ngi, name)
            refs = [("ortho 5 m", ngi / "ortho" / ortho), ("Sentinel-2 10 m", ngi / "sentinel2_b432_byte.tif")]
            best = rms(Projective.estimate(px, truth[:, :2]).forward(px) - truth[:, :2])
            for ref_name, ref in refs:
                cases = [("H", {}), ("dlt", {"dem": ngi / "dem.tif", "model": "dlt"}),
                         ("dlt+lsm", {"dem": ngi / "dem.tif", "model": "dlt", "refine": "lsm"}),
                         ("collinearity", {"dem": ngi / "dem.tif", "model": "collinearity", "camera": cam}),
                         ("collinearity+lsm", {"dem": ngi / "dem.tif", "model": "collinearity", "camera": cam,
                                               "refine": "lsm"}),
                         ("auto", {"dem": ngi / "dem.tif", "model": "auto"}),
                         ("auto+lsm", {"dem": ngi / "dem.tif", "model": "auto", "refine": "lsm"})]
                for label, kw in cases:
                    t0 = time.perf_counter()
                    try:
                        r = register(ref, ngi / "frames" / f"{name}_RGB.tif", Path(tmp) / "o.tif", overwrite=True,
                                     seed=0, **kw)
                    except Exception as e:  # noqa: BLE001 - a failure is a result here
                        rows.append({"frame": name, "reference": ref_name, "method": label, "error": str(e)})
                        continue
                    m = r.model
                    on = r.georeference.with_heights(truth[:, 2]).pixel_to_map(px)
                    on = transform_points(r.georeference.crs, TRUTH_CRS, on)  # output CRS: the reference's
                    rows.append({"frame": name, "reference": ref_name, "method": label,
                                 "model": r.report.get("terrain", {}).get("chosen", m.name),
                                 "dense_rmse_m": rms(on - truth[:, :2]), "best_homography_m": best,
                                 "check_rmse_m": r.report["check"].get("rmse_m"), "inliers": r.report["inliers"],
                                 "because": r.report.get("terrain", {}).get("chosen_because"),
                                 "seconds": time.perf_counter() - t0})
                    x = rows[-1]
                    print(f"{name[-4:]} {ref_name:16s} {label:17s} {x['model']:13s} dense {x['dense_rmse_m']:7.2f} m"
                          f"  best H {best:6.2f} m  check {x['check_rmse_m']:6.2f} m  inl {x['inliers']:5d}"
                          f"  {x['seconds']:5.1f} s", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"benchmark": "terrain_bench", "surf_layers": args.surf_layers, "rows": rows},
                                   indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
