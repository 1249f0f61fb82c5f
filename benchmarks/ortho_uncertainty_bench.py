"""The uncertainty raster of ``fotogeo ortho --uncertainty`` against the true errors of rendered blocks (issue 21).

Per seed, a 2 x 4 block of 400 x 600 px frames is rendered, matched, adjusted and written as triangulate writes it,
and orthorectified with ``--uncertainty`` onto its DEM plus a stationary height error of σ ``--dem-sigma``
(``tests/rendered_block_uncertainty.py``). Ground check points drawn uniformly over the block are put on the
ground through each adjusted frame (where the orthophoto shows them); printed and written to
``benchmarks/results/ortho_uncertainty_bench.json``: per seed and pooled, the observed planimetric RMS of their
errors, the predicted RMS (√mean σ², σ read from the raster) and their ratio (issue 21: within 0.7 … 1.4);
also the orientation alone (exact DEM, σ without the DEM term). No peer writes such a raster: the truth is the reference.

    .venv/bin/python benchmarks/ortho_uncertainty_bench.py [--seeds 8] [--dem-sigma 1.0]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fotogeo.orientation.ground_sigma import FrameCovariance, planimetric_sigma
from fotogeo.tools.ortho.tool import ortho
from fotogeo.orientation.adjusted_frame import AdjustedFrame

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from rendered_block_uncertainty import check_points, realisation, rms_ratio, sample_raster  # noqa: E402


def orientation_sigma(r, j, exact):
    res = r["result"]
    e = res.eo[j]
    m = AdjustedFrame(res.camera, e, res.distortion)
    h, gx, gy = r["dem"].heights_and_gradient(exact[:, :2])
    return planimetric_sigma(e.rotation_cv, e.centre, m.interior, m.scale, np.column_stack([exact[:, :2], h]),
                             np.column_stack([gx, gy]), FrameCovariance(res.eo_covariance[j]))


def one_seed(seed: int, dem_sigma: float, folder: Path) -> dict:
    t0 = time.perf_counter()
    r = realisation(folder, seed, dem_sigma)
    t1 = time.perf_counter()
    rep = ortho(r["images"], folder / "ortho", dem=r["dem_path"], camera=r["camera"], eo=r["eo"], uncertainty=True,
                dem_sigma=dem_sigma, resolution=3.0)
    t2 = time.perf_counter()
    err, sig, eo_err, eo_sig = [], [], [], []
    for j, (G, exact, noisy) in enumerate(check_points(r)):
        err.append(noisy[:, :2] - G[:, :2])
        sig.append(sample_raster(rep["images"][r["sb"].block.frames[j]]["sigma"]["path"], noisy[:, :2]))
        eo_err.append(exact[:, :2] - G[:, :2])
        eo_sig.append(orientation_sigma(r, j, exact))
    return {"seed": seed, "sigma0": r["result"].sigma0, "err": err, "sig": sig, "eo_err": eo_err, "eo_sig": eo_sig,
            "adjust_s": t1 - t0, "ortho_s": t2 - t1}


def summary(err, sig) -> dict:
    e, s = np.vstack(err), np.concatenate(sig)
    ok = np.isfinite(e).all(axis=1) & np.isfinite(s)
    return {"n": int(ok.sum()), "observed_rms_m": float(np.sqrt(np.mean(np.sum(e[ok] ** 2, axis=1)))),
            "predicted_rms_m": float(np.sqrt(np.mean(s[ok] ** 2))), "ratio": rms_ratio(err, sig)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--dem-sigma", type=float, default=1.0)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(1, args.seeds + 1):
            folder = Path(tmp) / f"s{seed}"
            folder.mkdir()
            rows.append(one_seed(seed, args.dem_sigma, folder))
    table = []
    print(f"{'seed':>6} {'sigma0':>7} {'n':>6} {'EO obs m':>9} {'EO pred m':>9} {'EO ratio':>8} "
          f"{'all obs m':>9} {'all pred m':>10} {'ratio':>6} {'ortho s':>7}")
    for r in rows + [None]:
        label = "pooled" if r is None else str(r["seed"])
        pick = rows if r is None else [r]
        eo = summary([e for p in pick for e in p["eo_err"]], [s for p in pick for s in p["eo_sig"]])
        al = summary([e for p in pick for e in p["err"]], [s for p in pick for s in p["sig"]])
        s0 = "" if r is None else f"{r['sigma0']:.3f}"
        ts = "" if r is None else f"{r['ortho_s']:.1f}"
        print(f"{label:>6} {s0:>7} {al['n']:>6} {eo['observed_rms_m']:9.3f} {eo['predicted_rms_m']:9.3f} "
              f"{eo['ratio']:8.2f} {al['observed_rms_m']:9.3f} {al['predicted_rms_m']:10.3f} {al['ratio']:6.2f} "
              f"{ts:>7}")
        table.append({"seed": label, "orientation_alone": eo, "with_dem_sigma": al,
                      **({} if r is None else {"sigma0": r["sigma0"], "adjust_s": r["adjust_s"],
                                               "ortho_s": r["ortho_s"]})})
    out = Path(__file__).resolve().parent / "results" / "ortho_uncertainty_bench.json"
    out.write_text(json.dumps({"dem_sigma_m": args.dem_sigma, "rows": table}, indent=2))
    print(f"written {out}")


if __name__ == "__main__":
    main()
