"""Near-duplicate SURF keypoints and CPU time: box filters, Gaussian layers with and without the
cross-octave de-duplication (``fotogeo.features.octaves``).

Run:  .venv/bin/python benchmarks/surf_duplicates.py [--threshold 10] [--no-time]

Near-duplicates: keypoint pairs closer than 1.5 px with the same Laplacian sign and scales
within 1.5x (the definition of the earlier count in docs/benchmarks/matching.md), and pairs
closer than 1 px with scales within 1.3x (any sign). Tiles: the two development tiles of
``surf_heldout.py`` it was counted on (IMG_2186 2200 px crop, NGI frame 0182), loaded as there.
CPU time: ``surf`` at the default threshold on IMG_2186 crops of 1 Mpx and 4.8 Mpx, best of 2
runs alternating the three modes in one process (CPU seconds of this process).
Writes ``benchmarks/results/surf_duplicates.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import surf_protocol as sp  # noqa: E402
from surf_bench import DATA  # noqa: E402

OUT = HERE / "results" / "surf_duplicates.json"
TILES = [("drone_2186_big", "drone_snowpeak/img/IMG_2186.JPG", (0, 0, 2200, 2200)),
         ("ngi_frame_0182", "ngi/frames/3324c_2015_1004_05_0182_RGB.tif", None)]
TIMED = [("IMG_2186 1 Mpx", "drone_snowpeak/img/IMG_2186.JPG", (1200, 1800, 1000, 1000)),
         ("IMG_2186 4.8 Mpx", "drone_snowpeak/img/IMG_2186.JPG", (0, 0, 2200, 2200))]
MODES = ("box", "gaussian, no de-duplication", "gaussian")


def run(img, valid, mode, **kw):
    """``surf`` in one of :data:`MODES` (the de-duplication switched off by patching it out)."""
    from fotogeo.features import octaves, surf
    keep = octaves.drop_duplicates
    if mode == "gaussian, no de-duplication":
        octaves.drop_duplicates = lambda kp, s, b: np.ones(len(kp["x"]), bool)
    try:
        return surf(img, valid, gaussian=mode != "box", **kw)
    finally:
        octaves.drop_duplicates = keep


def near_duplicates(r, dist, ratio, same_sign):
    """Keypoint pairs closer than ``dist`` px whose scales are within ``ratio`` (and signs equal)."""
    i, j = np.array(sorted(cKDTree(r.xy).query_pairs(dist)), dtype=np.int64).reshape(-1, 2).T
    ok = np.abs(np.log(r.scale[i] / r.scale[j])) < np.log(ratio)
    if same_sign:
        ok &= r.laplacian[i] == r.laplacian[j]
    return int(ok.sum())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threshold", type=float, default=10.0, help="Hessian threshold of the counts")
    ap.add_argument("--no-time", action="store_true", help="counts only")
    args = ap.parse_args(argv)
    out = {"threshold": args.threshold, "counts": [], "cpu_s": []}
    for name, rel, crop in TILES:
        img, valid = sp.load_tile(DATA, rel, crop)
        for mode in MODES:
            r = run(img, valid, mode, hessian_threshold=args.threshold)
            row = {"tile": name, "mode": mode, "keypoints": len(r),
                   "dup_1.5px_1.5x_same_sign": near_duplicates(r, 1.5, 1.5, True),
                   "dup_1px_1.3x": near_duplicates(r, 1.0, 1.3, False)}
            out["counts"].append(row)
            print(f"{name:16s} {mode:28s} keypoints {row['keypoints']:6d}  near-duplicates "
                  f"(1.5 px, 1.5x, sign) {row['dup_1.5px_1.5x_same_sign']:5d}  (1 px, 1.3x) {row['dup_1px_1.3x']:5d}")
    for name, rel, crop in ([] if args.no_time else TIMED):
        img, valid = sp.load_tile(DATA, rel, crop)
        best = {m: np.inf for m in MODES}
        n = {}
        for _ in range(2):
            for mode in MODES:
                t = time.process_time()
                n[mode] = len(run(img, valid, mode))
                best[mode] = min(best[mode], time.process_time() - t)
        for mode in MODES:
            out["cpu_s"].append({"tile": name, "mode": mode, "cpu_s": round(best[mode], 2), "keypoints": n[mode]})
            print(f"{name:16s} {mode:28s} CPU {best[mode]:6.2f} s  keypoints {n[mode]}")
    OUT.write_text(json.dumps(out, indent=1))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
