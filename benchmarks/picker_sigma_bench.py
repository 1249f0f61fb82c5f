"""The picker's blunder flags against its Click σ: a 5 px blunder among 15 DLT GCPs at 0.8 px click noise, and
where a blunder test loses it.

    PYTHONPATH=. .venv/bin/python benchmarks/picker_sigma_bench.py [--trials 40] [--frame 0182] [--out FILE]

GCPs of an NGI frame (``--frame``; 0182 or 0184) from its true geometry (heights from the DEM), each trial
another 23 of 60 points and another noise draw (0.8 px per axis): 15 with one 5 px blunder in a random
direction, 8 clean. Each set is fitted with ``fit_gcps`` (what the dock calls) at the dock's Click σ of 1 px,
at the true 0.8 px and with σ estimated from the residuals: how often the blunder is flagged alone, flagged with
others, missed; how often the 8 clean GCPs get a flag; with σ 0.8, how often 5 px is at least the blunder
point's minimal detectable blunder (``mdb_px``).

Then, on the same 15-point sets, tests side by side (σ = 0.8 known unless said): the shipped test
(:func:`fotogeo.orientation.blunders.detect_blunders`, per point χ²(2) on the deletion statistic, iterated, at
α = 1 % and 5 % per fit), its first pass alone, a per-coordinate test of the normalised residuals
(``|v| / (σ √r)``, normal quantile, Bonferroni over 2n), the in-fit residual without its redundancy number
(``|v|² / σ²`` against χ²(2)), the Pope τ test orient used before, and ``power``: the mean over the sets of the
point test's power for the planted blunder (non-central χ²(2), σ known, α = 1 %) — the bound for any test of one
point at that α. Prints tables and writes ``benchmarks/results/picker_sigma_bench[_FRAME].json``.
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
NOISE, BLUNDER = 0.8, 5.0


def truth(frame="0182", n=60):
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.simulation import make_gcps
    dem = read_dem(DATA / "ngi" / "dem.tif")
    s = make_gcps(load_ngi_frame(DATA / "ngi", f"3324c_2015_1004_05_{frame}"), dem, n, 0, "homogeneous", noise=0.0,
                  seed=3)
    return [{"col": float(p[0]), "row": float(p[1]), "x": float(g[0]), "y": float(g[1]), "z_true": float(g[2])}
            for p, g in zip(s.gcp_pixel, s.gcp_ground)], dem.crs.to_wkt()


def draw(gcps, t):
    """Trial ``t``: 15 GCPs (the 4th moved 5 px) and 8 clean ones, as the dock's rows; the blunder's step."""
    rng = np.random.default_rng(1000 + t)
    pts = [{**gcps[i], "id": str(k + 1), "role": "control", "col": gcps[i]["col"] + rng.normal(0, NOISE),
            "row": gcps[i]["row"] + rng.normal(0, NOISE)}
           for k, i in enumerate(rng.choice(len(gcps), 23, replace=False))]
    noisy, clean = pts[:15], pts[15:]
    a = rng.uniform(0, 2 * np.pi)
    step = BLUNDER * np.array([np.cos(a), np.sin(a)])
    noisy[3] = {**noisy[3], "col": noisy[3]["col"] + step[0], "row": noisy[3]["row"] + step[1]}
    return noisy, clean, step


def flagged(fit) -> list:
    return sorted(p["id"] for p in fit["points"] if p.get("flag") and ("blunder" in p["flag"] or "suspect" in p["flag"]))


def picker_rows(gcps, crs, trials):
    from fotogeo.tools.gcp.fit import fit_gcps
    dem = str(DATA / "ngi" / "dem.tif")
    rows = []
    for sigma in (1.0, 0.8, None):
        alone = with_others = missed = clean_flagged = mdb_ok = 0
        for t in range(trials):
            noisy, clean, _ = draw(gcps, t)
            fit = fit_gcps(noisy, "dlt", crs=crs, dem=dem, image_sigma=sigma, grid=0)
            f = flagged(fit)
            alone += f == ["4"]
            with_others += "4" in f and f != ["4"]
            missed += "4" not in f
            mdb = next(p for p in fit["points"] if p["id"] == "4")["mdb_px"]
            mdb_ok += mdb is not None and mdb <= BLUNDER
            clean_flagged += bool(flagged(fit_gcps(clean, "dlt", crs=crs, dem=dem, image_sigma=sigma, grid=0)))
        rows.append({"click_sigma_px": sigma, "trials": trials, "flagged_alone": alone,
                     "flagged_with_others": with_others, "missed": missed, "clean_sets_with_a_flag": clean_flagged,
                     "blunder_at_least_its_mdb": mdb_ok})
    return rows


def variants(gcps, trials):
    """The tests side by side on the same sets (module docstring): flagged alone / another point flagged."""
    from scipy.stats import chi2, ncx2, norm

    from fotogeo.models import get_model
    from fotogeo.orientation.adjustment import critical_w, standardised_residuals
    from fotogeo.orientation.blunders import _Fit, detect_blunders
    cls, n, k = get_model("dlt"), 15, 3
    crit = chi2.isf(0.01 / n, 2)

    def top(stat, limit):  # one pass: the largest statistic, if above the limit
        stat = np.nan_to_num(stat, nan=-1.0)
        return (stat > limit) & (stat == stat.max())

    tests = {
        "shipped: per point chi2(2) deletion statistic, iterated":
            lambda s, p, f: np.isin(detect_blunders(cls, s, p, sigma=NOISE).flag, ("blunder", "suspect")),
        "shipped, alpha 5 % per fit (1 % above)":
            lambda s, p, f: np.isin(detect_blunders(cls, s, p, sigma=NOISE, alpha=0.05).flag, ("blunder", "suspect")),
        "shipped, sigma 1.0 given": lambda s, p, f: np.isin(detect_blunders(cls, s, p, sigma=1.0).flag,
                                                            ("blunder", "suspect")),
        "shipped, sigma estimated (F(2, f-2))": lambda s, p, f: np.isin(detect_blunders(cls, s, p).flag,
                                                                        ("blunder", "suspect")),
        "first pass only (same statistic, no iteration)": lambda s, p, f: top(f.T / NOISE ** 2, crit),
        "per coordinate |v|/(sigma sqrt r), normal, Bonferroni 2n":
            lambda s, p, f: top((np.abs(f.v) / (NOISE * np.sqrt(np.clip(np.stack([f.R[:, 0, 0], f.R[:, 1, 1]], 1),
                                                                           1e-3, None)))).max(1), norm.isf(0.01 / (4 * n))),
        "in-fit |v| without its redundancy, chi2(2)": lambda s, p, f: top(np.sum(f.v ** 2, 1) / NOISE ** 2, crit),
        "Pope tau per coordinate, sigma from the fit (before)":
            lambda s, p, f: top(standardised_residuals(cls, s, p, np.ones(n, bool))[1], critical_w(2 * n - cls.n_params)),
    }
    counts = {name: [0, 0] for name in tests}
    power = 0.0
    for t in range(trials):
        noisy, _, step = draw(gcps, t)
        src = np.array([[q["x"], q["y"], q["z_true"]] for q in noisy])
        pix = np.array([[q["col"], q["row"]] for q in noisy])
        fit = _Fit(cls, src, pix, np.ones(n, bool), None, {})
        for name, test in tests.items():
            hit = test(src, pix, fit)
            counts[name][0] += bool(hit[k] and hit.sum() == 1)
            counts[name][1] += bool(np.delete(hit, k).any())
        clean_pix = pix.copy()
        clean_pix[k] -= step
        R = _Fit(cls, src, clean_pix, np.ones(n, bool), None, {}).R[k]
        power += ncx2.sf(crit, 2, step @ R @ step / NOISE ** 2)
    return [{"test": name, "flagged_alone": c[0] / trials, "another_flagged": c[1] / trials}
            for name, c in counts.items()], power / trials


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--frame", default="0182", help="NGI frame: 0182 or 0184")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    gcps, crs = truth(args.frame)
    rows = picker_rows(gcps, crs, args.trials)
    print(f"NGI frame {args.frame}, {args.trials} trials: 15 DLT GCPs at {NOISE} px with one {BLUNDER:g} px blunder")
    print(f"{'Click σ':>10} {'alone':>6} {'+others':>8} {'missed':>7} {'8 clean: a flag':>16} {'5 px ≥ MDB':>11}")
    for r in rows:
        s = "estimated" if r["click_sigma_px"] is None else f"{r['click_sigma_px']:g} px"
        mdb = f"{r['blunder_at_least_its_mdb']:>11}" if r["click_sigma_px"] == NOISE else f"{'':>11}"
        print(f"{s:>10} {r['flagged_alone']:>6} {r['flagged_with_others']:>8} {r['missed']:>7} "
              f"{r['clean_sets_with_a_flag']:>16} {mdb}   (of {r['trials']})")
    table, power = variants(gcps, args.trials)
    print(f"\n{'test (σ = 0.8 px known unless said)':58s} {'alone':>6} {'other':>6}")
    for r in table:
        print(f"{r['test']:58s} {r['flagged_alone']:6.3f} {r['another_flagged']:6.3f}")
    print(f"{'power of the point test (α 1 %), mean over the sets':58s} {power:6.3f}")
    out = args.out or ROOT / "benchmarks" / "results" / (
        "picker_sigma_bench.json" if args.frame == "0182" else f"picker_sigma_bench_{args.frame}.json")
    out.write_text(json.dumps({"frame": args.frame, "rows": rows, "variants": table, "power": power,
                               "noise_px": NOISE, "blunder_px": BLUNDER, "gcps": 15, "clean_gcps": 8, "model": "dlt",
                               "command": " ".join(["python", "benchmarks/picker_sigma_bench.py", *sys.argv[1:]])},
                              indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
