"""Area-based co-registration (issue 19, part 2): fotogeo ``coregister`` beside AROSICS ``COREG_LOCAL``.

Run:  .venv/bin/python benchmarks/coreg_bench.py [--cases s2_pair,landsat,ngi] [--threads 1]
      [--arosics ../arosics-venv/bin/python]

AROSICS (Scheffler et al. 2017) is installed in its own venv (``../shared/peers/arosics/install.sh
VENV``). Both tools run on the same pair with the same grid (spacing, window), each in a fresh
subprocess on ``--threads`` cores (AROSICS ``CPUs``; fotogeo ``threads``; BLAS, OpenMP and
OpenCV limited alike): wall time and peak memory (the largest resident set of the process
tree, sampled every 0.2 s) are measured around the whole call, outputs written.

Each corrected output is then measured by neutral measures:

- ``fg-orient`` / ``fg-intens``: fotogeo's window matcher (one pass, no field: the raw window
  shifts) on the gradient orientation / the grey values, output against the reference;
- ``aro``: AROSICS ``COREG_LOCAL`` itself on the output (its kept points' shifts);
- ``truth`` (synthetic pairs): the output against the target's own radiometry without the
  warp (so same-radiometry matching, grey values): what is left of the known warp.

Cases: ``s2_pair`` (two dates, clouds; nodata 0; the pair of AROSICS' tests), ``landsat``
(Landsat red vs a gamma-changed, inverted, blurred, noisy blue band under a known rotation,
scale, shift and ripple, tests/coreg_scenes.py; feature registration, SURF and SIFT, is tried
on it too), ``ngi`` (NGI 5-m orthophoto against the Sentinel-2 10-m scene: other sensor,
date, pixel size). The 10980 x 10980 scene: ``coreg_large_bench.py`` (same JSON file).

Writes benchmarks/results/coreg_bench.json and prints tables.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
import coreg_scenes as cs  # noqa: E402

PY = str(ROOT / ".venv" / "bin" / "python")
LIMITS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS")

FOTOGEO_RUN = """
import json, sys, cv2
cv2.setNumThreads({threads})
from fotogeo.tools.coreg.tool import coregister
kw = json.loads(sys.argv[1])
rep = coregister(**kw)
print("RESULT " + json.dumps(rep))
"""

AROSICS_RUN = """
import json, sys, time
import numpy as np
from arosics import COREG_LOCAL
kw = json.loads(sys.argv[1])
t = time.time()
crl = COREG_LOCAL(kw["ref"], kw["tgt"], grid_res=kw["grid"], window_size=(kw["window"], kw["window"]),
                  path_out=kw.get("out"), fmt_out="GTiff", CPUs=kw["cpus"], q=True, progress=False,
                  nodata=tuple(kw.get("nodata", (None, None))))
tbl = crl.CoRegPoints_table
t1 = time.time()
if kw.get("out"):
    crl.correct_shifts()
kept = tbl[tbl["OUTLIER"].astype(str) == "False"]
valid = tbl[tbl["ABS_SHIFT"] != crl.outFillVal]
sx, sy = kept["X_SHIFT_PX"].to_numpy(float), kept["Y_SHIFT_PX"].to_numpy(float)
r = np.hypot(sx, sy)
print("RESULT " + json.dumps({"points": int(len(tbl)), "valid": int(len(valid)), "kept": int(len(kept)),
      "median": float(np.median(r)) if len(r) else None, "rms": float(np.sqrt((r ** 2).mean())) if len(r) else None,
      "ce90": float(np.percentile(r, 90)) if len(r) else None, "t_shifts": t1 - t, "t_total": time.time() - t}))
"""


def _tree_rss_mb(pid: int) -> float:
    """Resident memory of ``pid`` and its descendants (MB), from /proc."""
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/status") as f:
                total += next(int(line.split()[1]) for line in f if line.startswith("VmRSS"))
            with open(f"/proc/{p}/task/{p}/children") as f:
                todo += [int(c) for c in f.read().split()]
        except (OSError, StopIteration, ValueError):
            pass
    return total / 1024


def _children_cpu_s() -> float:
    """User + system CPU time of this process's waited-for children (and theirs), s."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(python: str, code: str, kwargs: dict, threads: int, timeout: float | None = None) -> dict:
    """Run ``code`` in a fresh ``python`` with ``kwargs`` (JSON): result, wall time, CPU time (less
    sensitive than the wall time to other work on a loaded machine), peak memory."""
    env = {**os.environ, **{k: str(threads) for k in LIMITS}}
    cpu0, t0, peak = _children_cpu_s(), time.perf_counter(), 0.0
    proc = subprocess.Popen([python, "-c", code, json.dumps(kwargs)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env, start_new_session=True)
    timed_out = False
    while proc.poll() is None:
        peak = max(peak, _tree_rss_mb(proc.pid))
        if timeout is not None and time.perf_counter() - t0 > timeout:
            os.killpg(proc.pid, 9)
            timed_out = True
            break
        time.sleep(0.2)
    out, err = proc.communicate()
    wall = time.perf_counter() - t0
    res = next((json.loads(line[7:]) for line in out.splitlines() if line.startswith("RESULT ")), None)
    info = {"wall_s": round(wall, 1), "cpu_s": round(_children_cpu_s() - cpu0, 1), "peak_mb": round(peak),
            "timed_out": timed_out}
    if res is None and not timed_out:
        info["error"] = (err.strip().splitlines() or ["?"])[-1][:300]
    return {**info, "result": res}


def fotogeo(ref, tgt, out, grid, window, threads, **extra) -> dict:
    kw = {"reference": str(ref), "target": str(tgt), "output": str(out) if out else None, "grid_spacing": grid,
          "window": window, "threads": threads, "overwrite": True, **extra}
    return run(PY, FOTOGEO_RUN.format(threads=threads), kw, threads)


def arosics(python, ref, tgt, out, grid, window, threads, timeout=None, nodata=(None, None)) -> dict:
    kw = {"ref": str(ref), "tgt": str(tgt), "out": str(out) if out else None, "grid": grid, "window": window,
          "cpus": threads, "nodata": list(nodata)}
    return run(python, AROSICS_RUN, kw, threads, timeout)


def neutral(ref, corrected, grid, window, representation, **extra) -> dict:
    """Raw window shifts of ``corrected`` against ``ref`` (fotogeo's matcher, one pass, no field)."""
    from fotogeo.errors import MatchingError
    from fotogeo.tools.coreg.tool import coregister
    try:
        rep = coregister(ref, corrected, None, grid_spacing=grid, window=window, representation=representation,
                         iterations=1, smoothing=1e6, **extra)
    except MatchingError as e:
        return {"error": str(e)[:200]}
    return {"n": rep["windows"]["reliable"], **{k: round(rep["before"][k], 4) for k in ("median", "rms", "ce90")}}


def measure_outputs(ref, outputs: dict, grid, window, aro_py, threads, truth=None, aro_ref=None) -> dict:
    """Every neutral measure of every corrected output (see the module docstring)."""
    res = {}
    for name, path in outputs.items():
        if path is None or not Path(path).exists():
            continue
        m = {"fg-orient": neutral(ref, path, grid, window, "orientation"),
             "fg-intens": neutral(ref, path, grid, window, "intensity")}
        if aro_py:
            a = arosics(aro_py, aro_ref or ref, path, None, grid, window, threads)["result"] or {}
            m["aro"] = {"n": a.get("kept"), "median": a.get("median"), "rms": a.get("rms"), "ce90": a.get("ce90")}
        if truth is not None:
            m["truth"] = neutral(truth, path, grid, window, "intensity")
        res[name] = m
    return res


def landsat_case(tmp: Path):
    ref_a, tgt_a, E = cs.seasonal_landsat()
    ref = cs.write_geotiff(tmp / "ls_ref.tif", ref_a, dtype="uint8")
    tgt = cs.write_geotiff(tmp / "ls_tgt.tif", tgt_a, dtype="uint8")
    # the target's radiometry without the warp: what a perfect correction gives back
    _, plain, _ = cs.seasonal_landsat(E=lambda x, y: (0 * x, 0 * y))
    truth = cs.write_geotiff(tmp / "ls_truth.tif", plain, dtype="uint8")
    return ref, tgt, truth


def feature_registration(ref, tgt, tmp: Path) -> dict:
    from fotogeo.errors import FotogeoError
    from fotogeo.tools.register.tool import register
    out = {}
    for det in ("surf", "sift"):
        try:
            r = register(ref, tgt, tmp / f"reg_{det}.tif", detector=det, overwrite=True)
            out[det] = f"registered: check RMSE {r.report['check']['rmse_px']:.2f} px"
        except (FotogeoError, KeyError, TypeError) as e:
            out[det] = f"failed: {str(e)[:120]}"
    return out


def representations(name, ref, tgt, grid, window, tmp: Path, truth=None, nodata=(None, None)) -> dict:
    """fotogeo with each representation (in this process): windows kept, what the field leaves,
    and the output measured by the neutral measures (truth where there is one)."""
    from fotogeo.errors import MatchingError
    from fotogeo.tools.coreg.tool import coregister
    rows = {}
    for rep in ("orientation", "gradient", "rank", "intensity"):
        out = tmp / f"{name}_{rep}.tif"
        try:
            r = coregister(ref, tgt, out, grid_spacing=grid, window=window, representation=rep, overwrite=True,
                           reference_nodata=nodata[0], target_nodata=nodata[1])
        except MatchingError as e:
            rows[rep] = {"refused": str(e)[:160]}
            continue
        row = {"kept": r["windows"]["reliable"], "after_median": round(r["after"]["median"], 4),
               "fg-orient": neutral(ref, out, grid, window, "orientation")}
        if truth is not None:
            row["truth"] = neutral(truth, out, grid, window, "intensity")
        rows[rep] = row
    print("representation  kept  after-med  fg-orient (n med rms ce90)"
          + ("   truth (n med rms ce90)" if truth else ""))
    for rep, row in rows.items():
        if "refused" in row:
            print(f"{rep:14s} refused")
        else:
            print(f"{rep:14s} {row['kept']:5d} {row['after_median']:9.3f}  {_fmt(row['fg-orient'])}"
                  + (f"  {_fmt(row['truth'])}" if truth is not None else ""))
    return rows


def on_target_grid(ref, tgt, out: Path) -> Path:
    """``ref`` resampled (cubic) on ``tgt``'s grid: AROSICS 1.13 on GDAL 3.6 fails to reproject
    its own bool masks ("'bool' is not a GDAL-compatible input data type") for pairs of two
    pixel sizes, so it gets the reference on the target's grid (what fotogeo reads itself)."""
    import rasterio
    from rasterio.vrt import WarpedVRT
    with rasterio.open(ref) as r, rasterio.open(tgt) as t, WarpedVRT(
            r, crs=t.crs, transform=t.transform, width=t.width, height=t.height, resampling=3) as v:
        prof = dict(driver="GTiff", width=t.width, height=t.height, count=r.count, dtype=r.dtypes[0], crs=t.crs,
                    transform=t.transform, nodata=r.nodata)
        with rasterio.open(out, "w", **prof) as dst:
            dst.write(v.read())
    return out


def pair_case(name, ref, tgt, grid, window, args, tmp: Path, truth=None, nodata=(None, None), aro_ref=None) -> dict:
    print(f"\n== {name}: grid {grid} px, window {window} px, {args.threads} core(s)", flush=True)
    extra = {"reference_nodata": nodata[0], "target_nodata": nodata[1]}
    fg = fotogeo(ref, tgt, tmp / f"{name}_fotogeo.tif", grid, window, args.threads, **extra)
    aro = arosics(args.arosics, aro_ref or ref, tgt, tmp / f"{name}_arosics.tif", grid, window, args.threads,
                  nodata=nodata) if args.arosics else None
    outputs = {"original": tgt, "fotogeo": tmp / f"{name}_fotogeo.tif",
               "arosics": tmp / f"{name}_arosics.tif" if aro else None}
    meas = measure_outputs(ref, outputs, grid, window, args.arosics, args.threads, truth, aro_ref)
    reps = representations(name, ref, tgt, grid, window, tmp, truth, nodata) if args.representations else None
    rep = fg["result"] or {}
    row = {"representations": reps,
           "fotogeo": {"windows": rep.get("windows"), "after": rep.get("after"), "before": rep.get("before"),
                       "wall_s": fg["wall_s"], "peak_mb": fg["peak_mb"], "error": fg.get("error")},
           "arosics": {**(aro["result"] or {}), "wall_s": aro["wall_s"], "peak_mb": aro["peak_mb"],
                       "error": aro.get("error")} if aro else None,
           "measured": meas}
    _print_pair(name, row)
    return row


def _fmt(m: dict | None) -> str:
    if not m or "median" not in m or m.get("median") is None:
        return f"{'-':>22s}" if not m or "error" not in m else f"{'refused':>22s}"
    return f"{m['n']:4d} {m['median']:5.3f} {m['rms']:5.3f} {m['ce90']:5.3f}"


def _print_pair(name, row):
    f, a = row["fotogeo"], row["arosics"]
    w = f["windows"] or {}
    print(f"{'tool':8s} {'windows':>9s} {'valid':>6s} {'kept':>5s} {'time s':>7s} {'peak MB':>8s}")
    print(f"{'fotogeo':8s} {w.get('total', '-'):>9} {w.get('valid', '-'):>6} {w.get('reliable', '-'):>5} "
          f"{f['wall_s']:7.1f} {f['peak_mb']:8d}  {f.get('error') or ''}")
    if a:
        print(f"{'arosics':8s} {a.get('points', '-'):>9} {a.get('valid', '-'):>6} {a.get('kept', '-'):>5} "
              f"{a['wall_s']:7.1f} {a['peak_mb']:8d}  {a.get('error') or ''}")
    print("residual shift of each output (n, median, RMS, CE90 px) by each measure:")
    measures = sorted({k for m in row["measured"].values() for k in m})
    print(f"{'output':9s} " + " ".join(f"{k:>22s}" for k in measures))
    for out, m in row["measured"].items():
        print(f"{out:9s} " + " ".join(_fmt(m.get(k)) for k in measures))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="s2_pair,landsat,ngi")
    ap.add_argument("--representations", action="store_true", help="also compare the four representations")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--arosics", default=str(ROOT.parent / "arosics-venv" / "bin" / "python"))
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "coreg_bench.json"))
    args = ap.parse_args()
    if args.arosics and not Path(args.arosics).exists():
        print(f"AROSICS python {args.arosics} not found: fotogeo alone", file=sys.stderr)
        args.arosics = None
    results = {"threads": args.threads, "cases": {}}
    with tempfile.TemporaryDirectory(prefix="coreg_bench_", dir="/tmp") as t:
        tmp = Path(t)
        cases = [c for c in args.cases.split(",") if c]
        if "s2_pair" in cases:
            d = cs.S2_PAIR
            results["cases"]["s2_pair"] = pair_case("s2_pair", d / "ref_S2A_20160608T153121_T33UUU_sub.jp2",
                                                    d / "tgt_S2A_20160529T153631_T33UUU_sub.jp2", 100, 256, args, tmp,
                                                    nodata=(0, 0))
        if "landsat" in cases:
            ref, tgt, truth = landsat_case(tmp)
            row = pair_case("landsat", ref, tgt, 32, 128, args, tmp, truth=truth)
            row["feature_registration"] = feature_registration(ref, tgt, tmp)
            print("feature registration:", row["feature_registration"])
            results["cases"]["landsat"] = row
        if "ngi" in cases:
            aro_ref = on_target_grid(cs.S2_CROP, cs.NGI_ORTHO, tmp / "s2_on_ngi_grid.tif")
            results["cases"]["ngi"] = pair_case("ngi", cs.S2_CROP, cs.NGI_ORTHO, 64, 128, args, tmp, aro_ref=aro_ref)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(Path(args.out).read_text()) if Path(args.out).exists() else {}
    key = f"threads_{args.threads}"
    entry = old.setdefault(key, {})
    entry.setdefault("cases", {}).update(results.pop("cases"))  # a run of some cases keeps the others
    entry.update(results)
    Path(args.out).write_text(json.dumps(old, indent=1, default=str))
    print(f"\nwrote {args.out} [{key}]")


if __name__ == "__main__":
    main()
