"""Registration precision benchmark (issue 19): known warps of real images, and the time LSM costs.

Run:  .venv/bin/python benchmarks/register_precision_bench.py [--quick] [--repeat 2] [--cases a,b] [--no-real]

Part 1, known warps (tests/known_warps.py, shared with tests/test_register_precision.py). A real
image is the georeferenced reference; the target is the same image under an exact projective warp
``H`` (target pixel -> reference pixel, corner convention: rotation, scale and a perspective
term), sampled at full float64 precision with the Keys bicubic kernel of
:func:`fotogeo.matching.interpolation.sample` (not ``cv2.remap``, which quantises positions to
1/32 px), after a Gaussian pre-filter when the target is coarser than the reference (no
aliasing), then given another radiometry (gain 0.8, offset +20, Gaussian noise σ 1 grey level,
uint8, nodata 0 outside the reference). Images:

- ``ngi``: the NGI orthophoto tile ``ngi/ortho/ngi_rgb_byte_1.tif`` (5 m, 805x1421), target 600x600;
- ``s2``: a 600x600 crop of ``ngi/sentinel2_b432_byte.tif`` (10 m), target 500x500;
- ``landsat``: a 300x300 crop of ``landsat_rgb/RGB.byte.tif`` (Landsat-7, 300 m here), target 300x300.

Warps (rotation°, scale = target px in reference px, perspective (h31, h32) x size):
``r30_s0.85_p`` (30°, 0.85, (0.06, -0.04)), ``r200_s0.9_p`` (200°, 0.9, (0.05, 0.03)),
``r45_s1.2_p`` (45°, 1.2, (-0.04, 0.06)); ``--quick`` runs the first two.

Methods, all through :func:`fotogeo.register` with seed 0 and otherwise default options:
``surf`` (``refine="none"``), ``surf+lsm`` (``refine="lsm"``), ``sift`` (``detector="sift"``,
``refine="none"``), ``sift+lsm``. Reported: the dense error of the fitted model against the
exact warp — RMSE and maximum over a 20x20 grid of target pixels inside the reference, in
reference pixels — the check RMSE and CE90 (px), inliers, LSM converged / refined and its
median σ, total time (the report's ``timings_s.total``, minimum of ``--repeat`` runs).
Targets (issue 19): the default (``surf+lsm``) ≤ 0.05 px and ≤ ``sift`` on every case.

Part 2, time and accuracy on the real pairs (``--no-real`` skips it), ``refine="none"`` against
``"lsm"``: NGI frame 0182 → orthophoto tile 1 (dense RMSE against the camera + orientation +
DEM truth of tests/ngi_truth.py, with the best homography's beside), ``s2_pair`` (two dates,
nodata 0, affine) and the Landsat warp of tests/synthetic_pair.py (dense RMSE against its
exact warp). Target: LSM ≤ 1.3x the time of ``none``.

Writes benchmarks/results/register_precision_bench.json and prints tables.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "benchmarks" / "results" / "register_precision_bench.json"
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # truth helpers shared with the tests

METHODS = {
    "surf": dict(detector="surf", refine="none"),
    "surf+lsm": dict(detector="surf", refine="lsm"),
    "sift": dict(detector="sift", refine="none"),
    "sift+lsm": dict(detector="sift", refine="lsm"),
}
DEFAULT = "surf+lsm"
TARGET_PX = 0.05
TIME_RATIO = 1.3


from known_warps import IMAGES, WARPS, known_warp  # noqa: E402 - tests/known_warps.py, shared with the tests


# ------------------------------------------------------------------------------ runs
def run_register(reference, target, tmp: Path, options: dict, repeat: int):
    """``(registration, best total seconds, error)`` of ``repeat`` runs with ``options``."""
    from fotogeo.errors import FotogeoError
    from fotogeo.tools.register.tool import register
    best, r = None, None
    for k in range(repeat):
        out = tmp / f"out_{k}.tif"
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                c0 = time.process_time()
                r = register(reference, target, out, overwrite=True, seed=0, **options)
                cpu = time.process_time() - c0
        except FotogeoError as e:
            return None, None, f"{type(e).__name__}: {e}"
        t = (r.report["timings_s"]["total"], cpu)
        best = t if best is None else (min(best[0], t[0]), min(best[1], t[1]))
    return r, best, None


def describe(r, seconds, px: float, dense=None) -> dict:
    """The numbers of one run (reference pixels ``px`` in the output CRS units)."""
    rep = r.report
    chk = rep["check"]
    lsm = rep.get("lsm") or {}
    out = {"time_s": seconds[0], "cpu_s": seconds[1], "matches": rep["matches"], "inliers": rep["inliers"],
           "check_n": chk.get("n"), "check_rmse_px": chk.get("rmse_px"), "check_ce90_px": chk.get("ce90_px"),
           "lsm_converged": lsm.get("converged", lsm.get("refined")), "lsm_of": lsm.get("of"),
           "lsm_median_sigma_px": lsm.get("median_sigma_px"), "timings_s": rep["timings_s"],
           "bands_rematched": rep.get("bands_rematched")}
    if dense is not None:
        grid, truth = dense
        err = np.hypot(*(r.model.forward(grid) - truth).T) / px
        out.update(dense_rmse_px=float(np.sqrt(np.mean(err ** 2))), dense_max_px=float(err.max()),
                   dense_n=int(len(err)))
    return out


def known_warps(tmp: Path, images, warps, methods, repeat: int) -> list[dict]:
    import rasterio
    rows = []
    for name in images:
        for wname in warps:
            ref, tgt, grid, truth = known_warp(DATA, name, wname, tmp)
            with rasterio.open(ref) as ds:
                px = abs(ds.transform.a)
            for method in methods:
                r, seconds, err = run_register(ref, tgt, tmp, METHODS[method], repeat)
                row = {"image": name, "warp": wname, "method": method}
                row.update({"error": err} if r is None else describe(r, seconds, px, (grid, truth)))
                rows.append(row)
                print(_row_text(row), flush=True)
    return rows


def real_pairs(tmp: Path, repeat: int) -> list[dict]:
    """refine none vs lsm on the NGI frame 0182, s2_pair and the Landsat warp (module docstring)."""
    import rasterio
    from fotogeo.models import Projective
    from fotogeo.pixels import pixel_to_map
    from ngi_truth import truth_points
    from synthetic_pair import apply_h, make_landsat_pair
    ngi = DATA / "ngi"
    grid, xyz = truth_points(ngi, "3324c_2015_1004_05_0182", step=10, crs=32735)
    best = float(np.sqrt(np.mean(Projective.estimate(grid, xyz[:, :2]).residuals(grid, xyz[:, :2]) ** 2)))
    lref, ltgt, H = make_landsat_pair(DATA / "landsat_rgb" / "RGB.byte.tif", tmp)
    with rasterio.open(lref) as ds:
        t_l = ds.transform
    from fotogeo.pixels import pixel_centres
    x, y = pixel_centres(64, 60)
    lgrid = np.column_stack([x.ravel(), y.ravel()]) * 10
    s2 = DATA / "s2_pair"
    pairs = [
        ("ngi_0182", ngi / "ortho" / "ngi_rgb_byte_1.tif", ngi / "frames" / "3324c_2015_1004_05_0182_RGB.tif",
         dict(dst_crs="EPSG:32735"), 5.0, (grid, xyz[:, :2])),
        ("s2_pair", s2 / "ref_S2A_20160608T153121_T33UUU_sub.jp2", s2 / "tgt_S2A_20160529T153631_T33UUU_sub.jp2",
         dict(reference_nodata=0, target_nodata=0, model="affine"), 10.0, None),
        ("landsat_warp", lref, ltgt, {}, abs(t_l.a), (lgrid, pixel_to_map(t_l, apply_h(H, lgrid)))),
    ]
    rows = []
    for name, ref, tgt, opts, px, dense in pairs:
        for refine in ("none", "lsm"):
            r, seconds, err = run_register(ref, tgt, tmp, dict(opts, refine=refine), repeat)
            row = {"pair": name, "refine": refine}
            row.update({"error": err} if r is None else describe(r, seconds, px, dense))
            if name == "ngi_0182":
                row["best_homography_rmse_px"] = best / px
            rows.append(row)
            print(_real_text(row), flush=True)
    return rows


# ------------------------------------------------------------------------------ tables
def fmt(x, spec="{:.3f}"):
    return "-" if x is None else spec.format(x)


def _row_text(r) -> str:
    if "error" in r:
        return f"{r['image']:<8}{r['warp']:<13}{r['method']:<10}  failed: {r['error'][:90]}"
    return (f"{r['image']:<8}{r['warp']:<13}{r['method']:<10}{fmt(r['dense_rmse_px']):>8}{fmt(r['dense_max_px']):>8}"
            f"{fmt(r['check_rmse_px']):>8}{fmt(r.get('check_ce90_px')):>8}{r['inliers']:>6}"
            f"{fmt(r['lsm_converged'], '{}'):>6}{fmt(r['lsm_median_sigma_px']):>7}{fmt(r['time_s'], '{:.2f}'):>7}"
            f"{fmt(r['cpu_s'], '{:.2f}'):>7}")


HEADER = (f"{'image':<8}{'warp':<13}{'method':<10}{'dense':>8}{'max':>8}{'chk':>8}{'CE90':>8}{'inl':>6}"
          f"{'lsm':>6}{'σ lsm':>7}{'time':>7}{'cpu':>7}")


def _real_text(r) -> str:
    if "error" in r:
        return f"{r['pair']:<14}{r['refine']:<6}  failed: {r['error'][:90]}"
    return (f"{r['pair']:<14}{r['refine']:<6}{fmt(r['time_s'], '{:.2f}'):>7}{fmt(r['cpu_s'], '{:.2f}'):>7}"
            f"{fmt(r['check_rmse_px']):>8}"
            f"{fmt(r.get('check_ce90_px')):>8}{fmt(r.get('dense_rmse_px')):>8}"
            f"{fmt(r.get('best_homography_rmse_px')):>8}"
            f"{r['inliers']:>6}{fmt(r['lsm_converged'], '{}'):>6}{fmt(r['lsm_median_sigma_px']):>7}")


REAL_HEADER = (f"{'pair':<14}{'refine':<6}{'time':>7}{'cpu':>7}{'chk':>8}{'CE90':>8}{'dense':>8}{'best':>8}{'inl':>6}"
               f"{'lsm':>6}{'σ lsm':>7}")


def verdicts(rows, real) -> dict:
    """The issue's targets, case by case."""
    by = {(r["image"], r["warp"], r["method"]): r for r in rows if "error" not in r}
    cases = sorted({(r["image"], r["warp"]) for r in rows})
    out = {"precision": [], "time": []}
    for image, warp in cases:
        d, s = by.get((image, warp, DEFAULT)), by.get((image, warp, "sift"))
        if d is None:
            out["precision"].append({"case": f"{image}/{warp}", "ok": False, "why": "default failed"})
            continue
        ok = d["dense_rmse_px"] <= TARGET_PX and (s is None or d["dense_rmse_px"] <= s["dense_rmse_px"])
        out["precision"].append({"case": f"{image}/{warp}", "default_px": d["dense_rmse_px"],
                                 "sift_px": None if s is None else s["dense_rmse_px"], "ok": bool(ok)})
    for image, warp in cases:
        a, b = by.get((image, warp, "surf")), by.get((image, warp, "surf+lsm"))
        if a and b:
            out["time"].append({"case": f"{image}/{warp}", "ratio": b["time_s"] / a["time_s"],
                                "cpu_ratio": b["cpu_s"] / a["cpu_s"]})
    rb = {(r["pair"], r["refine"]): r for r in real if "error" not in r}
    for pair in sorted({r["pair"] for r in real}):
        a, b = rb.get((pair, "none")), rb.get((pair, "lsm"))
        if a and b:
            out["time"].append({"case": pair, "ratio": b["time_s"] / a["time_s"], "cpu_ratio": b["cpu_s"] / a["cpu_s"]})
    for t in out["time"]:
        t["ok"] = bool(t["ratio"] <= TIME_RATIO)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="two warps, no sift+lsm")
    ap.add_argument("--repeat", type=int, default=2, help="runs per case (the minimum time is kept)")
    ap.add_argument("--cases", default=",".join(IMAGES), help="images of part 1, comma-separated")
    ap.add_argument("--methods", default=None, help="methods of part 1, comma-separated")
    ap.add_argument("--no-real", action="store_true", help="skip part 2 (real pairs)")
    ap.add_argument("--output", default=str(OUT))
    a = ap.parse_args(argv)
    warps = list(WARPS)[:2] if a.quick else list(WARPS)
    methods = a.methods.split(",") if a.methods else [m for m in METHODS if not (a.quick and m == "sift+lsm")]
    import fotogeo
    with tempfile.TemporaryDirectory(prefix="precision_bench_") as tmp:
        tmp = Path(tmp)
        print(HEADER)
        rows = known_warps(tmp, a.cases.split(","), warps, methods, a.repeat)
        real = []
        if not a.no_real:
            print()
            print(REAL_HEADER)
            real = real_pairs(tmp, a.repeat)
    v = verdicts(rows, real)
    print()
    for p in v["precision"]:
        print(f"precision {p['case']:<22} default {fmt(p.get('default_px'))} px, sift {fmt(p.get('sift_px'))} px: "
              f"{'ok' if p['ok'] else 'NOT MET'}")
    for t in v["time"]:
        print(f"time      {t['case']:<22} lsm / none {t['ratio']:.2f} (cpu {t['cpu_ratio']:.2f}): "
              f"{'ok' if t['ok'] else 'NOT MET'}")
    result = {"benchmark": "register_precision_bench", "argv": sys.argv[1:], "date": time.strftime("%Y-%m-%d %H:%M"),
              "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                          "load_avg": os.getloadavg()}, "fotogeo": fotogeo.__version__,
              "units": "dense/check/CE90/σ in reference pixels; time in s (report timings_s.total, min of repeats)",
              "known_warps": rows, "real_pairs": real, "verdicts": v}
    Path(a.output).parent.mkdir(parents=True, exist_ok=True)
    Path(a.output).write_text(json.dumps(result, indent=1, default=float))
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
