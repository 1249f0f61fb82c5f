"""Time per model fit on 1000 GCPs: fotogeo now, fotogeo before (issue 15), GDAL's GCP polynomials.

GCPs and check points come from the true geometry of NGI frame 0182 (camera, exterior
orientation, DEM; :func:`fotogeo.orientation.simulation.make_gcps`, homogeneous spread,
0.3 px noise, seed 0). Every model is fitted ground -> image on the GCPs (2-D models see X,
Y; ``rfm-i2g`` is fitted image -> ground and checked through its inverse) and timed as the
median of ``--repeats`` fits; its check RMSE per axis (pixels) shows that the answers agree.

"before" is the same code at the revision ``--before`` (default: the commit before the
one-decomposition fits), extracted with ``git archive`` into a temporary folder and run
in a child process with that folder first on ``PYTHONPATH``; "now" is the working tree,
also in a child process, so both see the same machine state (they run one after the
other, in the same invocation). "now, 1 BLAS" is the working tree again with
``OPENBLAS_NUM_THREADS=1`` (and OMP/MKL) in its environment: fotogeo pins its small fits to
one BLAS thread itself (:mod:`fotogeo.models.threads`), so "now" and "now, 1 BLAS" should
agree whatever the caller's BLAS setting. GDAL's ``GCP_POLYNOMIAL`` transformer (orders 1-3, the
peer of fotogeo's poly1-3) is timed as its creation, which fits the polynomial.

Run: ``.venv/bin/python benchmarks/fits_bench.py`` (about a minute; ``--repeats``,
``--gcps``, ``--before``). Prints a table and writes ``benchmarks/results/fits_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tarfile
import tempfile
import time
import warnings
from io import BytesIO
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "benchmarks" / "results" / "fits_bench.json"
FRAME = "3324c_2015_1004_05_0182"
BEFORE = "a25ed4c"
MODELS = ["affine", "projective", "bilinear", "poly1", "poly2", "poly3", "affine-height", "poly3d-2", "poly3d-3",
          "dlt", "rfm-poly", "rfm-common", "rfm", "rfm-i2g", "collinearity"]
GDAL = {"gdal-poly1": "poly1", "gdal-poly2": "poly2", "gdal-poly3": "poly3"}


def gcp_set(n_gcp: int, n_check: int):
    from fotogeo.io.raster import read_dem
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.orientation.simulation import make_gcps

    frame = load_ngi_frame(DATA / "ngi", FRAME)
    return frame, make_gcps(frame, read_dem(DATA / "ngi" / "dem.tif"), n_gcp, n_check, "homogeneous",
                            noise=0.3, seed=0)


def _median_time(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def time_fotogeo(n_gcp: int, n_check: int, repeats: int) -> dict:
    """Median fit time and check RMSE of every model, with the fotogeo found on sys.path."""
    import fotogeo
    from fotogeo.errors import IllPosedWarning
    from fotogeo.models import MODELS as REGISTRY

    frame, g = gcp_set(n_gcp, n_check)
    rows = {"fotogeo_path": str(Path(fotogeo.__file__).parent)}
    for name in MODELS:
        cls = REGISTRY[name]
        fit = cls.options_from(camera=frame.camera)
        if name.endswith("-i2g"):
            src, dst = np.column_stack([g.gcp_pixel, g.gcp_ground[:, 2]]), g.gcp_ground[:, :2]
        else:
            src, dst = (g.gcp_ground[:, :2] if cls.src_dims == 2 else g.gcp_ground), g.gcp_pixel
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IllPosedWarning)
            seconds, m = _median_time(lambda: cls.estimate(src, dst, **fit), repeats)
        if name.endswith("-i2g"):
            pred = m.inverse(g.check_ground[:, :2], g.check_ground[:, 2])[:, :2]
        else:
            pred = m.forward(g.check_ground[:, :2] if cls.src_dims == 2 else g.check_ground)
        e = pred - g.check_pixel
        rows[name] = {"seconds": seconds, "check_rms": np.sqrt(np.nanmean(e ** 2, axis=0)).tolist(),
                      "lambda_rel": m.info.get("lambda_rel"), "iterations": m.info.get("iterations")}
    return rows


def time_gdal(n_gcp: int, n_check: int, repeats: int) -> dict:
    """GDAL's GCP polynomial transformers: creation (the fit) time and check RMSE."""
    from osgeo import gdal

    gdal.UseExceptions()
    _, g = gcp_set(n_gcp, n_check)
    ds = gdal.GetDriverByName("MEM").Create("", 640, 1152, 1)
    ds.SetGCPs([gdal.GCP(float(X), float(Y), 0.0, float(c), float(r))
                for (X, Y, _), (c, r) in zip(g.gcp_ground, g.gcp_pixel)], "")
    rows = {"gdal": gdal.__version__}
    for name in GDAL:
        opts = ["METHOD=GCP_POLYNOMIAL", f"MAX_GCP_ORDER={name[-1]}"]
        seconds, tr = _median_time(lambda: gdal.Transformer(ds, None, opts), repeats)
        pts, ok = tr.TransformPoints(1, [(float(X), float(Y), 0.0) for X, Y, _ in g.check_ground])
        pred = np.array([p[:2] for p in pts], dtype=np.float64)
        pred[~np.asarray(ok, bool)] = np.nan
        e = pred - g.check_pixel
        rows[name] = {"seconds": seconds, "check_rms": np.sqrt(np.nanmean(e ** 2, axis=0)).tolist()}
    return rows


def child(kind: str, args) -> None:
    fn = time_gdal if kind == "gdal" else time_fotogeo
    print(json.dumps(fn(args.gcps, args.checks, args.repeats)))


#: the environment of the "now, 1 BLAS" run
ONE_BLAS_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def run_child(kind: str, args, pythonpath: str | None, extra_env: dict | None = None) -> dict:
    env = {**os.environ, **(extra_env or {})}
    if pythonpath:
        env["PYTHONPATH"] = pythonpath + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, __file__, "--child", kind, "--gcps", str(args.gcps), "--checks", str(args.checks),
           "--repeats", str(args.repeats)]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True, cwd=pythonpath or ROOT)
    return json.loads(out.stdout.strip().splitlines()[-1])


def extract(rev: str, folder: Path) -> None:
    """The ``fotogeo`` package at git revision ``rev`` into ``folder``."""
    tar = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "fotogeo"], capture_output=True, check=True).stdout
    with tarfile.open(fileobj=BytesIO(tar)) as t:
        t.extractall(folder)


def table(before: dict, now: dict, gdal: dict, one: dict) -> str:
    lines = [f"{'model':<14} {'before s':>10} {'now s':>10} {'1 BLAS s':>10} {'before/now':>10} {'gdal s':>10} "
             f"{'now/gdal':>9}  {'check rms before (x, y)':>24}  {'now (x, y)':>18}"]
    peer = {v: k for k, v in GDAL.items()}
    for name in MODELS:
        b, n = before[name], now[name]
        g = gdal.get(peer.get(name, ""), {})
        gs = f"{g['seconds']:10.5f} {n['seconds'] / g['seconds']:9.2f}" if g else f"{'-':>10} {'-':>9}"
        lines.append(f"{name:<14} {b['seconds']:10.5f} {n['seconds']:10.5f} {one[name]['seconds']:10.5f} "
                     f"{b['seconds'] / n['seconds']:10.1f} {gs}  "
                     f"{b['check_rms'][0]:11.4f} {b['check_rms'][1]:11.4f}  "
                     f"{n['check_rms'][0]:8.4f} {n['check_rms'][1]:8.4f}")
    for name in GDAL:
        g = gdal[name]
        lines.append(f"{name:<14} {'':>10} {'':>10} {'':>10} {'':>10} {g['seconds']:10.5f} {'':>9}  {'':>24}  "
                     f"{g['check_rms'][0]:8.4f} {g['check_rms'][1]:8.4f}")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--gcps", type=int, default=1000)
    ap.add_argument("--checks", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--before", default=BEFORE, help="git revision of the 'before' implementation")
    ap.add_argument("--child", choices=["fotogeo", "gdal"], help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    if a.child:
        return child(a.child, a)
    if not (DATA / "ngi").is_dir():
        sys.exit(f"fits_bench: real data not found at {DATA} (set FOTOGEO_DATA)")
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        extract(a.before, Path(tmp))
        before = run_child("fotogeo", a, tmp)
    now = run_child("fotogeo", a, str(ROOT))
    one = run_child("fotogeo", a, str(ROOT), ONE_BLAS_THREAD)
    gdal = run_child("gdal", a, str(ROOT))
    print(table(before, now, gdal, one))
    from osgeo import gdal as _gdal

    result = {"benchmark": "fits_bench", "units": "seconds per fit (median); check RMSE in pixels (x = col, y = row)",
              "config": {"frame": FRAME, "gcps": a.gcps, "checks": a.checks, "repeats": a.repeats, "noise_px": 0.3,
                         "spread": "homogeneous", "seed": 0, "before": a.before},
              "environment": {"python": platform.python_version(), "numpy": np.__version__,
                              "gdal": _gdal.__version__, "cpus": os.cpu_count(),
                              "load_average": list(os.getloadavg())},
              "caller_blas_env": {k: os.environ.get(k) for k in ONE_BLAS_THREAD},
              "before": before, "now": now, "now_one_blas_thread": one, "gdal": gdal, "seconds": time.time() - t0}
    a.out.parent.mkdir(parents=True, exist_ok=True)
    tmp_out = a.out.with_suffix(".json.tmp")
    tmp_out.write_text(json.dumps(result, indent=1))
    tmp_out.replace(a.out)
    print(f"\nwrote {a.out} ({time.time() - t0:.0f} s; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cpus)")


if __name__ == "__main__":
    main()
