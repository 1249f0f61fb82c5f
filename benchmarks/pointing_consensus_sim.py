"""The relative pointing correction's consensus threshold on simulated tie points of a large satellite pair.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/pointing_consensus_sim.py --threshold T [--trim-floor F] [--label TEXT]

``dsm --rpc`` finds tie points on overviews averaged over k x k blocks (k = ⌈longer side / 1500⌉) and multiplies
them back, so their scatter is about 0.28·k px (ventoux: NMAD 0.28 px at k = 1). A 20 000 px scene (k = 14):
near-parallel epipolar segments (400 px long, fanning by ±2°), ``n_true`` tie points off by τ = (0, 5) px plus
σ-px noise (and a drift growing across the scene), ``n_false`` more off by up to ±300 px;
:func:`fotogeo.stereo.affine_epipolar.pointing_correction` with ``--threshold`` (``dsm --rpc``'s
:func:`~fotogeo.tools.dsm.rpc_pairs.agreement_px`: 42 px at k = 14; before s28-pointmend: 3 px) and
``--trim-floor`` its refit's floor (``TRIM_FLOOR_PX``). The table: the error of τ across the lines (median, max)
and the runs with fewer than 10 agreeing tie points (``dsm --rpc`` refuses those). The draws are those of the
review's simulation (seed 1, the cases in order). Writes benchmarks/results/pointing_consensus_sim.json (a row of
the same label and case is replaced).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import fotogeo.stereo.affine_epipolar as ae

OUT = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "pointing_consensus_sim.json"
#: (true ties, false ties, σ px, drift px, runs)
CASES = [(60, 30, 0.5, 0, 30), (60, 30, 8, 0, 30), (25, 10, 8, 0, 30), (15, 5, 8, 0, 30), (40, 0, 12, 0, 30),
         (200, 50, 1, 20, 30), (500, 200, 4, 0, 20), (500, 200, 8, 0, 20), (100, 100, 8, 0, 20), (30, 30, 4, 0, 20)]


def _run(rng, n_true, n_false, sigma, drift, threshold, tau_true=(0.0, 5.0)) -> tuple:
    n = n_true + n_false
    p1 = rng.uniform(0, 20000, (n, 2))
    ang = np.deg2rad(rng.uniform(-2, 2, n))
    d = np.column_stack([np.cos(ang), np.sin(ang)])
    q_lo, q_hi = p1 - 200 * d, p1 + 200 * d
    p2 = (p1 + np.asarray(tau_true) + rng.normal(0, sigma, (n, 2))
          + drift * (p1[:, :1] / 20000 - 0.5) * np.array([0, 1]))
    p2[n_true:] += rng.uniform(-300, 300, (n_false, 2))
    tau, inl, _ = ae.pointing_correction(p2, q_lo, q_hi, threshold=threshold)
    return abs(tau[1] - tau_true[1]), int(inl.sum())


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threshold", type=float, required=True)
    ap.add_argument("--trim-floor", type=float, default=None)
    ap.add_argument("--label", default="current")
    a = ap.parse_args(argv)
    if a.trim_floor is not None:
        ae.TRIM_FLOOR_PX = a.trim_floor
    rng = np.random.default_rng(1)
    rows = []
    print(f"{'true+false':>10} {'σ px':>5} {'drift':>5} {'median':>7} {'max':>6} {'refused':>8}")
    for n_true, n_false, sigma, drift, runs in CASES:
        v = np.array([_run(rng, n_true, n_false, sigma, drift, a.threshold) for _ in range(runs)])
        r = {"label": a.label, "case": f"{n_true}+{n_false} sigma {sigma} drift {drift}", "threshold": a.threshold,
             "trim_floor": ae.TRIM_FLOOR_PX, "err_median_px": round(float(np.median(v[:, 0])), 2),
             "err_max_px": round(float(v[:, 0].max()), 2), "refused": f"{int((v[:, 1] < 10).sum())}/{runs}"}
        rows.append(r)
        print(f"{n_true:>5}+{n_false:<4} {sigma:>5} {drift:>5} {r['err_median_px']:>7} {r['err_max_px']:>6} "
              f"{r['refused']:>8}")
    old = json.loads(OUT.read_text()) if OUT.exists() else []
    keep = [o for o in old if (o["label"], o["case"]) not in {(r["label"], r["case"]) for r in rows}]
    OUT.write_text(json.dumps(keep + rows, indent=1) + "\n")
    print(f"-> {OUT}")


if __name__ == "__main__":
    main()
