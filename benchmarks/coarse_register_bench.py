"""Unreferenced, rotated and scaled two-date chips registered: Fourier–Mellin pre-alignment + area-based windows.

Run:  .venv/bin/python benchmarks/coarse_register_bench.py [--cases a,b] [--no-unrelated] [--s2-pair-offset]
      .venv/bin/python benchmarks/coarse_register_bench.py --users --no-unrelated --output R.json  (issue 32's sweep)

Cases (tests/rotated_pairs.py): a chip of a real scene (Landsat-7 RGB, the Sentinel-2 b432 scene, or the
second date of the s2_pair) rotated, scaled, re-banded (gamma, band mix, noise, clouds, inverted contrast),
without georeference, registered to the scene with :func:`fotogeo.register` (seed 0). ``TUNE`` cases chose
the method's constants; ``HELD_OUT`` cases did not. Methods: ``default`` (features first, the windows when
matching fails, keeps fewer than 12 inliers or its fit is imprecise — then started from
that fit) and ``windows`` (SURF switched off with
``hessian_threshold=1e9``, so that the Fourier–Mellin + windows path always runs). Reported: the RMSE and
maximum at check points (a 15x15 grid of chip pixels inside the scene and clear of clouds) against the
known warp, reference pixels; the path taken; the pre-alignment's confidence (peak ratio). Unrelated pairs
(a chip against another scene) must be refused. ``--users`` runs the ``USERS`` cases instead (a new user's
chips: rotations to ±170°, scales 0.7-1.4, 200-2000 px, and mirrored chips, which must be refused).
``--s2-pair-offset`` measures the two s2_pair dates' offset used as their truth (fotogeo coreg on the
unrotated pair).

Goal: every chip within 1 px; every unrelated pair refused. Writes benchmarks/results/coarse_register_bench.json.
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
OUT = ROOT / "benchmarks" / "results" / "coarse_register_bench.json"
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
from rotated_pairs import CASES, HELD_OUT, TESTS, USERS, apply, make_case  # noqa: E402

METHODS = {"default": {}, "windows": dict(hessian_threshold=1e9)}
UNRELATED = [("s2_r40_s0.9", "landsat_r25_s1.1"), ("landsat_r25_s1.1", "s2pair_r25_s1.1"),
             ("s2pair_r25_s1.1", "s2_r-70_s1.15_clouds"), ("landsat_r120_s1.25", "s2_r200_s0.85")]


def run(ref, tgt, out, options):
    from fotogeo.errors import FotogeoError
    from fotogeo.tools.register.tool import register
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return register(ref, tgt, out, overwrite=True, seed=0, **options), time.perf_counter() - t0, None
    except FotogeoError as e:
        return None, time.perf_counter() - t0, f"{type(e).__name__}: {e}"


def s2_pair_offset() -> dict:
    from fotogeo.tools.coreg.tool import coreg_options, run_coregistration
    d = DATA / "s2_pair"
    run_ = run_coregistration(d / "ref_S2A_20160608T153121_T33UUU_sub.jp2", d / "tgt_S2A_20160529T153631_T33UUU_sub.jp2",
                              coreg_options(grid_spacing=128, window=128), reference_nodata=0, target_nodata=0)
    ok = run_.result.reliable
    s = run_.result.windows.shift[ok]
    return {"windows": int(ok.sum()), "median_shift_px": np.median(s, axis=0).tolist(), "std_px": s.std(axis=0).tolist()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default=",".join(n for n in CASES if n not in USERS))
    ap.add_argument("--users", action="store_true", help="the USERS cases (issue 32's sweep) instead of --cases")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--no-unrelated", action="store_true")
    ap.add_argument("--s2-pair-offset", action="store_true")
    ap.add_argument("--output", default=str(OUT))
    a = ap.parse_args(argv)
    import rasterio
    import fotogeo
    from fotogeo.pixels import pixel_to_map
    rows, unrelated = [], []
    print(f"{'case':<28}{'set':<9}{'method':<9}{'rmse':>7}{'max':>7}{'path':>10}{'conf':>8}{'inl':>5}{'time':>6}")
    with tempfile.TemporaryDirectory(prefix="coarse_bench_") as tmp:
        tmp = Path(tmp)
        made = {}
        for name in (list(USERS) if a.users else a.cases.split(",")):
            ref, tgt, H, check = made[name] = make_case(DATA, name, tmp)
            with rasterio.open(ref) as ds:
                t = ds.transform
            for method in a.methods.split(","):
                r, sec, err = run(ref, tgt, tmp / "out.tif", METHODS[method])
                row = {"case": name, "set": ("users" if name in USERS else "held-out" if name in HELD_OUT else
                                             "tests" if name in TESTS else "tune"),
                       "method": method, "mirrored": CASES[name].mirror,
                       "time_s": round(sec, 2)}
                if r is None:
                    row["error"] = err
                    print(f"{name:<28}{row['set']:<9}{method:<9}  refused: {err[:100]}", flush=True)
                else:
                    e = np.hypot(*(r.model.forward(check) - pixel_to_map(t, apply(H, check))).T) / abs(t.a)
                    ab = r.report.get("area_based") or {}
                    pre = ab.get("pre_alignment") or {}
                    path = "windows" if ab and "refused" not in ab else "features"
                    row.update(rmse_px=float(np.sqrt(np.mean(e ** 2))), max_px=float(e.max()), n_check=int(len(e)),
                               path=path, why=ab.get("why"), confidence=pre.get("confidence_peak_ratio"),
                               pre_alignment=pre or None, inliers=r.report["inliers"])
                    print(f"{name:<28}{row['set']:<9}{method:<9}{row['rmse_px']:>7.3f}{row['max_px']:>7.3f}{path:>10}"
                          f"{row['confidence'] or 0:>8.1f}{row['inliers']:>5}{sec:>6.1f}", flush=True)
                rows.append(row)
        if not a.no_unrelated:
            for rname, tname in UNRELATED:
                for n in (rname, tname):
                    made.setdefault(n, make_case(DATA, n, tmp))
                r, sec, err = run(made[rname][0], made[tname][1], tmp / "out.tif", METHODS["windows"])
                u = {"reference_of": rname, "target_of": tname, "refused": r is None, "message": err}
                unrelated.append(u)
                print(f"unrelated {rname} <- {tname}: {'refused' if r is None else 'REGISTERED (wrong)'}"
                      f"{'' if r is None else ''}", flush=True)
    offset = s2_pair_offset() if a.s2_pair_offset else None
    ok = [r for r in rows if "error" not in r and not r["mirrored"]]
    plain = [r for r in rows if not r["mirrored"]]
    verdict = {"all_within_1px": bool(len(ok) == len(plain) and all(r["rmse_px"] <= 1.0 for r in ok)),
               "default_within_1px": [r["case"] for r in ok if r["method"] == "default" and r["rmse_px"] <= 1.0],
               "default_beyond_1px_or_refused": [r["case"] for r in plain if r["method"] == "default"
                                                 and r.get("rmse_px", 2.0) > 1.0],
               "mirrored_all_refused": all("error" in r for r in rows if r["mirrored"]),
               "worst_rmse_px": max((r["rmse_px"] for r in ok), default=None),
               "unrelated_all_refused": all(u["refused"] for u in unrelated)}
    print(verdict)
    result = {"benchmark": "coarse_register_bench", "argv": sys.argv[1:], "date": time.strftime("%Y-%m-%d %H:%M"),
              "machine": {"python": platform.python_version(), "cpus": os.cpu_count(), "load_avg": os.getloadavg()},
              "fotogeo": fotogeo.__version__, "units": "RMSE / max at check points, reference pixels",
              "rows": rows, "unrelated": unrelated, "s2_pair_offset": offset, "verdict": verdict}
    Path(a.output).parent.mkdir(parents=True, exist_ok=True)
    Path(a.output).write_text(json.dumps(result, indent=1, default=float))
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
