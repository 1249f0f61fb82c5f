"""Sub-pixel registration across band sets: the default (SURF + LSM) against the SIFT-keypoint variant when the
reference and the target have different bands.

Run:  .venv/bin/python benchmarks/register_bands_bench.py [--cases ngi,s2,landsat] [--band-sets a,b] [--warps a,b]
      [--methods surf+lsm,sift,sift+lsm]

The known warps of benchmarks/register_precision_bench.py (tests/known_warps.py: a real image, an exact
projective warp, gain 0.8 + offset 20 + noise σ 1), with the reference and the target in other band sets
(``BAND_SETS`` of tests/known_warps.py): an 8-band reference against an RGB target (R, G, B + a NIR-like
band and four other combinations), a 4-band reference (RGB + NIR-like) against a one-band (panchromatic)
target, an RGB reference against a 2-band (NIR-like, G) target. Reported per case and method: the dense
RMSE of the model against the exact warp (reference pixels; 20x20 grid), its maximum, inliers, LSM
converged. Target: the default ≤ 0.05 px and ≤ the SIFT variants run (``sift``, ``sift+lsm``) on every case.

``--pca-only`` runs LSM on the PCA fusions as before the band combination (the 'before' table).

Writes benchmarks/results/register_bands_bench.json (or ``--output``) and prints a table.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from register_precision_bench import DATA, METHODS, describe, fmt, run_register  # noqa: E402

sys.path.insert(0, str(ROOT / "tests"))
from known_warps import BAND_SETS, IMAGES, WARPS, known_warp_bands  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "register_bands_bench.json"


def verdicts_of(rows: list) -> list:
    """Per case: the default's dense RMSE, each SIFT variant's run (``sift``, ``sift+lsm``) and whether the default
    is ≤ 0.05 px and ≤ every one of them (a refused SIFT variant counts as beaten)."""
    by = {(r["image"], r["band_set"], r["warp"], r["method"]): r for r in rows if "error" not in r}
    sifts = sorted({r["method"] for r in rows if r["method"].startswith("sift")})
    out = []
    for (name, bs, warp) in sorted({(r["image"], r["band_set"], r["warp"]) for r in rows}):
        d = by.get((name, bs, warp, "surf+lsm"))
        s = {m: by[(name, bs, warp, m)]["dense_rmse_px"] for m in sifts if (name, bs, warp, m) in by}
        ok = d is not None and d["dense_rmse_px"] <= 0.05 and all(d["dense_rmse_px"] <= v for v in s.values())
        out.append({"case": f"{name}/{bs}/{warp}", "default_px": d and d["dense_rmse_px"], "sift_px": s,
                    "ok": bool(ok)})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default=",".join(IMAGES))
    ap.add_argument("--band-sets", default=",".join(BAND_SETS))
    ap.add_argument("--warps", default=",".join(list(WARPS)[:2]))
    ap.add_argument("--methods", default="surf+lsm,sift")
    ap.add_argument("--pca-only", action="store_true",
                    help="LSM on the PCA fusions (the behaviour before the band combination: 'before' tables)")
    ap.add_argument("--output", default=str(OUT))
    a = ap.parse_args(argv)
    if a.pca_only:
        import fotogeo.tools.register.points as points
        points.matched_fusions = lambda infos, opts, fu_ref, fu_tgt, *_: (fu_ref, fu_tgt, {"lsm_on": "PCA fusions"})
    import rasterio
    import fotogeo
    rows = []
    print(f"{'image':<8}{'bands':<11}{'warp':<13}{'method':<10}{'dense':>8}{'max':>8}{'inl':>6}{'lsm':>6}")
    with tempfile.TemporaryDirectory(prefix="bands_bench_") as tmp:
        tmp = Path(tmp)
        for name in a.cases.split(","):
            for bs in a.band_sets.split(","):
                for warp in a.warps.split(","):
                    ref, tgt, grid, truth = known_warp_bands(DATA, name, warp, bs, tmp)
                    with rasterio.open(ref) as ds:
                        px = abs(ds.transform.a)
                    for method in a.methods.split(","):
                        r, seconds, err = run_register(ref, tgt, tmp, METHODS[method], 1)
                        row = {"image": name, "band_set": bs, "warp": warp, "method": method}
                        row.update({"error": err} if r is None else describe(r, seconds, px, (grid, truth)))
                        if r is not None:
                            row["lsm_bands"] = r.report.get("lsm", {}).get("bands")
                            row["lsm_texture_windows"] = r.report.get("lsm", {}).get("texture_windows")
                            row["lsm_texture_windows_used"] = r.report.get("lsm", {}).get("texture_windows_used")
                        rows.append(row)
                        print(f"{name:<8}{bs:<11}{warp:<13}{method:<10}" + (
                            f"  failed: {err[:80]}" if r is None else
                            f"{fmt(row['dense_rmse_px']):>8}{fmt(row['dense_max_px']):>8}{row['inliers']:>6}"
                            f"{fmt(row['lsm_converged'], '{}'):>6}"), flush=True)
    verdicts = verdicts_of(rows)
    for v in verdicts:
        print(f"{v['case']}: default {fmt(v['default_px'])} "
              + " ".join(f"{m} {fmt(px)}" for m, px in v["sift_px"].items()) + f" {'ok' if v['ok'] else 'NOT MET'}")
    result = {"benchmark": "register_bands_bench", "argv": sys.argv[1:], "date": time.strftime("%Y-%m-%d %H:%M"),
              "machine": {"python": platform.python_version(), "cpus": os.cpu_count(), "load_avg": os.getloadavg()},
              "fotogeo": fotogeo.__version__, "units": "dense RMSE / max in reference pixels",
              "rows": rows, "verdicts": verdicts}
    Path(a.output).parent.mkdir(parents=True, exist_ok=True)
    Path(a.output).write_text(json.dumps(result, indent=1, default=float))
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
