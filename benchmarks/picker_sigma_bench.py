"""The picker's blunder flags against its Click σ: a 5 px blunder among 15 DLT GCPs at 0.8 px click noise.

    .venv/bin/python benchmarks/picker_sigma_bench.py [--trials 40]

GCPs of NGI frame 0182 from its true geometry (heights from the DEM), each trial another 23 of 60 points and
another noise draw (0.8 px per axis): 15 with one 5 px blunder in a random direction, 8 clean. Each set is fitted
with ``fit_gcps`` (what the dock calls) at the dock's Click σ of 1 px, at the true 0.8 px and with σ estimated
from the residuals. Prints a table and writes ``benchmarks/results/picker_sigma_bench.json``: how often the
blunder is flagged alone, flagged with others, missed; how often the 8 clean GCPs get a flag.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DATA = ROOT.parent / "shared" / "data"


def truth(n=60):
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.simulation import make_gcps
    dem = read_dem(DATA / "ngi" / "dem.tif")
    s = make_gcps(load_ngi_frame(DATA / "ngi", "3324c_2015_1004_05_0182"), dem, n, 0, "homogeneous", noise=0.0, seed=3)
    return [{"col": float(p[0]), "row": float(p[1]), "x": float(g[0]), "y": float(g[1])}
            for p, g in zip(s.gcp_pixel, s.gcp_ground)], dem.crs.to_wkt()


def flagged(fit) -> list:
    return sorted(p["id"] for p in fit["points"] if p.get("flag") and ("blunder" in p["flag"] or "suspect" in p["flag"]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=40)
    args = ap.parse_args()
    from fotogeo.tools.gcp.fit import fit_gcps
    gcps, crs = truth()
    dem = str(DATA / "ngi" / "dem.tif")
    rows = []
    for sigma in (1.0, 0.8, None):
        alone = with_others = missed = clean_flagged = 0
        for t in range(args.trials):
            rng = np.random.default_rng(1000 + t)
            pts = [{**gcps[i], "id": str(k + 1), "role": "control", "col": gcps[i]["col"] + rng.normal(0, 0.8),
                    "row": gcps[i]["row"] + rng.normal(0, 0.8)}
                   for k, i in enumerate(rng.choice(len(gcps), 23, replace=False))]
            noisy, clean = pts[:15], pts[15:]
            a = rng.uniform(0, 2 * np.pi)
            noisy[3] = {**noisy[3], "col": noisy[3]["col"] + 5 * np.cos(a), "row": noisy[3]["row"] + 5 * np.sin(a)}
            f = flagged(fit_gcps(noisy, "dlt", crs=crs, dem=dem, image_sigma=sigma, grid=0))
            alone += f == ["4"]
            with_others += "4" in f and f != ["4"]
            missed += "4" not in f
            clean_flagged += bool(flagged(fit_gcps(clean, "dlt", crs=crs, dem=dem, image_sigma=sigma, grid=0)))
        rows.append({"click_sigma_px": sigma, "trials": args.trials, "flagged_alone": alone,
                     "flagged_with_others": with_others, "missed": missed, "clean_sets_with_a_flag": clean_flagged})
    print(f"{'Click σ':>10} {'alone':>6} {'+others':>8} {'missed':>7} {'8 clean: a flag':>16}")
    for r in rows:
        s = "estimated" if r["click_sigma_px"] is None else f"{r['click_sigma_px']:g} px"
        print(f"{s:>10} {r['flagged_alone']:>6} {r['flagged_with_others']:>8} {r['missed']:>7} "
              f"{r['clean_sets_with_a_flag']:>16}   (of {r['trials']})")
    out = ROOT / "benchmarks" / "results" / "picker_sigma_bench.json"
    out.write_text(json.dumps({"rows": rows, "noise_px": 0.8, "blunder_px": 5.0, "gcps": 15, "clean_gcps": 8,
                               "model": "dlt"}, indent=1))


if __name__ == "__main__":
    main()
