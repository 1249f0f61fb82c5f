"""Keypoints of ``surf()`` at a Hessian threshold, box filters vs Gaussian-derivative layers, with and without
the fine octave (``upscale``): what :data:`fotogeo.features.surf.DEFAULT_THRESHOLD` gives.

Run:  .venv/bin/python benchmarks/surf_counts.py [--threshold 50]

Images: the three of ``surf_bench.py`` (NGI frame 0182, orthophoto tile 1, Landsat), loaded as there (band mean
stretched 1-99 % to 0..255, at the benchmark's size). Writes ``benchmarks/results/surf_counts.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from surf_bench import IMAGES, load  # noqa: E402

from fotogeo.features import surf  # noqa: E402
from fotogeo.features.surf import DEFAULT_THRESHOLD  # noqa: E402

OUT = HERE / "results" / "surf_counts.json"
COLUMNS = [(up, g) for up in (False, True) for g in (False, True)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threshold", type=float, default=DEFAULT_THRESHOLD)
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args()
    rows = []
    print(f"threshold {args.threshold:g}: keypoints")
    print(f"{'image':16s} {'size':>10s} " + " ".join(f"{('fine ' if up else '') + ('gauss' if g else 'box'):>10s}"
                                                    for up, g in COLUMNS))
    for name, rel in IMAGES.items():
        img, valid = load(rel)
        counts = {f"{'upscale' if up else 'plain'}_{'gaussian' if g else 'box'}":
                  len(surf(img, valid, hessian_threshold=args.threshold, upscale=up, gaussian=g)) for up, g in COLUMNS}
        rows.append({"image": name, "shape": list(img.shape), **counts})
        print(f"{name:16s} {img.shape[1]:>4d}x{img.shape[0]:<5d} " + " ".join(f"{v:>10d}" for v in counts.values()),
              flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"threshold": args.threshold, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
