"""GCP picker engine (issue 14): refit round trip through the session worker, and GCP proposals.

    .venv/bin/python benchmarks/picker_bench.py [--gcps 20] [--calls 50] [--models affine,dlt,collinearity]
                                                [--no-propose] [--no-preview]

1. ``fit_gcps`` with ``--gcps`` GCPs of the NGI frame 0182 (true geometry, tests/ngi_truth.py, 0.3 px
   image noise, a quarter check points, heights from ngi/dem.tif, 25 x 25 prediction grids), called
   ``--calls`` times per model through :class:`processing_provider.session.WorkerSession` (the
   dock's route: JSON over the pipe of one long-lived ``python -m fotogeo.worker --session``):
   the first call (process start and imports) and the warm round trips (median, 90th percentile);
   the same call in-process gives the share of the pipe and JSON.
2. the live preview (``preview_warp``, :mod:`fotogeo.tools.gcp.preview`): with the same GCPs and DEM, the refit
   and the warp of the frame onto a 1024 x 768 px canvas over the GCPs' extent in the preview's own session,
   plus what the dock then does in QGIS (the raw RGBA read into a QImage, drawn onto a canvas-sized image at
   60 % opacity), ``--calls`` times per model: median and 90th percentile of the whole (target: < 200 ms),
   and the in-process ``preview_warp`` alone.
3. ``propose_gcps`` on the frame against ngi/ortho/ngi_rgb_byte_1.tif (30 candidates), with and
   without the DEM, in-process, one run each.

Prints a table and writes ``benchmarks/results/picker_bench.json``. On a shared machine the
times are noisy: the load average is recorded with them.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
FRAME = "3324c_2015_1004_05_0182"
_KEEP: dict = {}


def gcps_of_frame(n: int, seed: int = 1) -> list[dict]:
    from ngi_truth import truth_points
    px, ground = truth_points(DATA / "ngi", FRAME, step=10)
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(px), n, replace=False)
    noisy = px[idx] + rng.normal(0, 0.3, (n, 2))
    return [{"id": f"g{k}", "col": float(c), "row": float(r), "x": float(ground[i, 0]), "y": float(ground[i, 1]),
             "z": None, "role": "check" if k % 4 == 3 else "control"} for k, ((c, r), i) in enumerate(zip(noisy, idx))]


def percentile(values, q):
    return float(np.percentile(np.asarray(values), q))


def bench_session(n_gcps: int, calls: int, models: list[str]) -> dict:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    os.environ.setdefault("FOTOGEO_PYTHON", sys.executable)
    from qgis.core import QgsApplication
    _KEEP["app"] = QgsApplication.instance() or QgsApplication([], False)  # the session reads QGIS settings
    from fotogeo.tools.gcp.fit import fit_gcps
    from processing_provider.session import WorkerSession
    ngi = DATA / "ngi"
    kwargs = dict(gcps=gcps_of_frame(n_gcps), crs="EPSG:32735", image=str(ngi / "frames" / f"{FRAME}_RGB.tif"),
                  dem=str(ngi / "dem.tif"), camera=str(ngi / "interior_orientation.yaml"), grid=25)
    session, rows = WorkerSession(), {}
    try:
        t = time.perf_counter()
        session.call("fit_gcps", model=models[0], **kwargs)
        first_ms = 1000 * (time.perf_counter() - t)
        for model in models:
            trips, local = [], []
            for _ in range(calls):
                t = time.perf_counter()
                result = session.call("fit_gcps", model=model, **kwargs)
                trips.append(1000 * (time.perf_counter() - t))
            for _ in range(max(5, calls // 5)):
                t = time.perf_counter()
                fit_gcps(model=model, **kwargs)
                local.append(1000 * (time.perf_counter() - t))
            rows[model] = {"median_ms": statistics.median(trips), "p90_ms": percentile(trips, 90),
                           "in_process_median_ms": statistics.median(local), "check_rms_px": result["rms"]["check_px"],
                           "ok": result["ok"]}
    finally:
        session.close()
    return {"gcps": n_gcps, "calls": calls, "first_call_ms": first_ms, "models": rows}


def bench_preview(n_gcps: int, calls: int, models: list[str], tmp: Path) -> dict:
    from qgis.PyQt.QtCore import QRectF
    from qgis.PyQt.QtGui import QImage, QPainter

    from fotogeo.tools.gcp.preview import preview_warp
    from processing_provider.picker.preview import read_rgba
    from processing_provider.session import WorkerSession
    ngi = DATA / "ngi"
    gcps = gcps_of_frame(n_gcps)
    xs, ys = [g["x"] for g in gcps], [g["y"] for g in gcps]
    kwargs = dict(gcps=gcps, crs="EPSG:32735", image=str(ngi / "frames" / f"{FRAME}_RGB.tif"), dem=str(ngi / "dem.tif"),
                  camera=str(ngi / "interior_orientation.yaml"), extent=[min(xs), min(ys), max(xs), max(ys)],
                  extent_crs="EPSG:32735", size=[1024, 768], output=str(tmp / "preview.rgba"))
    canvas = QImage(1024, 768, QImage.Format_ARGB32_Premultiplied)

    def redraw(result):
        painter = QPainter(canvas)
        painter.setOpacity(0.6)
        painter.drawImage(QRectF(0, 0, 1024, 768), read_rgba(result))
        painter.end()
    session, rows = WorkerSession(), {}
    try:
        session.call("preview_warp", model=models[0], **kwargs)  # process start, imports, the image read once
        for model in models:
            trips, local = [], []
            for _ in range(calls):
                t = time.perf_counter()
                result = session.call("preview_warp", model=model, **kwargs)
                redraw(result)
                trips.append(1000 * (time.perf_counter() - t))
            for _ in range(max(5, calls // 5)):
                t = time.perf_counter()
                preview_warp(model=model, **kwargs)
                local.append(1000 * (time.perf_counter() - t))
            rows[model] = {"median_ms": statistics.median(trips), "p90_ms": percentile(trips, 90),
                           "in_process_warp_median_ms": statistics.median(local), "ok": result["ok"],
                           "covered": result.get("covered")}
    finally:
        session.close()
    return {"gcps": n_gcps, "calls": calls, "canvas_px": [1024, 768], "models": rows}


def bench_propose() -> dict:
    from fotogeo.tools.gcp.propose import propose_gcps
    ngi = DATA / "ngi"
    out = {}
    for label, dem in (("with_dem", str(ngi / "dem.tif")), ("without_dem", None)):
        t = time.perf_counter()
        r = propose_gcps(str(ngi / "frames" / f"{FRAME}_RGB.tif"), str(ngi / "ortho" / "ngi_rgb_byte_1.tif"),
                         count=30, dem=dem)
        out[label] = {"seconds": time.perf_counter() - t, "candidates": len(r["candidates"]), "matches": r["matches"],
                      "consistent": r["consistent"], "model": r["model"]}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gcps", type=int, default=20)
    ap.add_argument("--calls", type=int, default=50)
    ap.add_argument("--models", default="affine,dlt,collinearity")
    ap.add_argument("--no-propose", action="store_true")
    ap.add_argument("--no-preview", action="store_true")
    args = ap.parse_args(argv)
    result = {"load_average_before": os.getloadavg(), "cores": os.cpu_count(),
              "session": bench_session(args.gcps, args.calls, args.models.split(","))}
    if not args.no_preview:
        import tempfile
        with tempfile.TemporaryDirectory(prefix="fotogeo-bench-") as tmp:
            result["preview"] = bench_preview(args.gcps, args.calls, args.models.split(","), Path(tmp))
    if not args.no_propose:
        result["propose"] = bench_propose()
    result["load_average_after"] = os.getloadavg()
    s = result["session"]
    print(f"fit_gcps, {s['gcps']} GCPs, {s['calls']} calls per model; first call {s['first_call_ms']:.0f} ms")
    print(f"{'model':14s} {'median ms':>10s} {'p90 ms':>8s} {'in-process ms':>14s}")
    for model, row in s["models"].items():
        print(f"{model:14s} {row['median_ms']:10.1f} {row['p90_ms']:8.1f} {row['in_process_median_ms']:14.1f}")
    if "preview" in result:
        v = result["preview"]
        print(f"live preview (refit + warp onto {v['canvas_px'][0]} x {v['canvas_px'][1]} px + QImage redraw), "
              f"{v['gcps']} GCPs, {v['calls']} calls per model")
        print(f"{'model':14s} {'median ms':>10s} {'p90 ms':>8s} {'in-process warp ms':>19s}")
        for model, row in v["models"].items():
            print(f"{model:14s} {row['median_ms']:10.1f} {row['p90_ms']:8.1f} {row['in_process_warp_median_ms']:19.1f}")
    for label, row in result.get("propose", {}).items():
        print(f"propose_gcps {label}: {row['seconds']:.1f} s, {row['candidates']} candidates of {row['consistent']} "
              f"consistent / {row['matches']} matches ({row['model']})")
    print(f"load average before {result['load_average_before']}, after {result['load_average_after']}")
    out = ROOT / "benchmarks" / "results" / "picker_bench.json"
    out.write_text(json.dumps(result, indent=1))
    print(f"written {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
