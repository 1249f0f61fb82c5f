"""Interior orientation of rendered film scans with known truth (``fotogeo interior``).

Scans rendered by ``tests/film_scans.py``: a 240 mm film at 150 µm (1600² px), marks of two camera layouts
(8 marks after the Wild RC series, 4 mid-side marks after the Zeiss RMK; corner marks on the RC corners),
each mark type (x, cross, dot, corner), scan rotations k·90° plus a seeded few degrees, a scan affinity
(scales 1.002 / 0.998, skew 0.001), an offset of a few mm, noise σ 2 grey levels; the photo content is NGI
frame 0182 when the data folder is there (``--data``), else texture. Per scan: the largest fiducial error
against the truth (px), the transform's residual RMS (px), the largest error of the fitted pixel -> photo
transform over the scan corners (px), the time. Rotation is given (the layouts are symmetric under 90°).

Run: ``.venv/bin/python benchmarks/interior_bench.py`` (``--seeds``). Prints a table and writes
``benchmarks/results/interior_bench.json``.
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
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from film_scans import CORNERS, RC_LIKE, RMK_LIKE, render_scan, report_yaml  # noqa: E402
from fotogeo.tools.interior.tool import interior  # noqa: E402
from test_interior import write_scan  # noqa: E402

CASES = [("rc", RC_LIKE, "x"), ("rc", RC_LIKE, "dot"), ("rmk", RMK_LIKE, "cross"), ("rc-corners", CORNERS, "corner")]


def content(data: Path):
    path = data / "ngi" / "frames" / "3324c_2015_1004_05_0182_RGB.tif"
    if not path.exists():
        return None, "texture"
    import rasterio
    with rasterio.open(path) as ds:
        return ds.read().mean(axis=0), path.name


def run(seeds, data):
    photo, source = content(data)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, layout, kind in CASES:
            (tmp / "cal.yaml").write_text(report_yaml(layout, kind=kind))
            for k90 in range(4):
                for seed in range(seeds):
                    rng = np.random.default_rng([seed, k90])
                    theta = float(rng.uniform(-3, 3))
                    scan = render_scan(layout, kind=kind, k90=k90, theta=theta, content=photo, seed=seed,
                                       offset=tuple(rng.uniform(-15, 15, 2)))
                    path = write_scan(tmp / "scan.tif", scan)
                    t0 = time.perf_counter()
                    rec = interior(path, tmp / "cal.yaml", tmp / "io.json", scan_pixel_um=150, rotation=str(90 * k90),
                                   overwrite=True)[0]
                    dt = time.perf_counter() - t0
                    err = max(np.hypot(f["col"] - scan.marks[f["id"]][0], f["row"] - scan.marks[f["id"]][1])
                              for f in rec["fiducials"])
                    M = np.vstack([np.array(rec["pixel_to_photo"]), [0, 0, 1]])
                    Ai = np.linalg.inv(np.vstack([scan.A, [0, 0, 1]]))
                    c = np.array([[0, 0, 1], [1600, 0, 1], [0, 1600, 1], [1600, 1600, 1]], float)
                    terr = np.abs((c @ M.T)[:, :2] - (c @ Ai.T)[:, :2]).max() / 0.15
                    rows.append({"layout": name, "mark": kind, "rotation": 90 * k90 + theta, "seed": seed,
                                 "marks": len(rec["fiducials"]), "max_fiducial_error_px": float(err),
                                 "rms_px": rec["rms_px"], "transform_error_px": float(terr), "seconds": dt})
    return rows, source


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "interior_bench.json")
    a = ap.parse_args(argv)
    rows, source = run(a.seeds, a.data)
    print(f"{'layout':<11} {'mark':<7} {'scans':>5} {'max fid err':>11} {'max rms':>8} {'max transf':>10} {'s/scan':>7}")
    for name, _, kind in CASES:
        r = [x for x in rows if x["layout"] == name and x["mark"] == kind]
        print(f"{name:<11} {kind:<7} {len(r):>5} {max(x['max_fiducial_error_px'] for x in r):11.3f} "
              f"{max(x['rms_px'] for x in r):8.3f} {max(x['transform_error_px'] for x in r):10.3f} "
              f"{np.median([x['seconds'] for x in r]):7.2f}")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps({"benchmark": "interior_bench", "content": source, "seeds": a.seeds, "rows": rows},
                                indent=1))
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
