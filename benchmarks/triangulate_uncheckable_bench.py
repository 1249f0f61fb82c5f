"""The (f_max/2)² rule that names an uncheckable prior group, on blocks and priors it was not fitted on (issue 32).

:func:`fotogeo.orientation.bundle_result.uncheckable` keeps the given weights' solution (no variance-component
re-solve) when a prior group with redundancy below 1 has ``vᵀPv / r_g > (f_max / 2)²``. It was fitted on 2 × 4
blocks: attitude priors 0.3° off given 0.001° (seeds 10–12: named) and GCPs at centimetres under GNSS 3 m / 2 m off
(seeds 21, 26: not named). Here, on simulated blocks (:func:`~fotogeo.orientation.block_simulation.simulate_block`,
0.3 px image noise, no blunders) of other sizes, seeds and priors, every seed is adjusted twice: as shipped, and
with the rule's other answer forced: a named group not named (the re-solve forced), a blind group not named named
(the given weights' solution kept). The rule is *right* on a seed when the other answer moves the centres further
from the truth (RMS over frames and axes); per seed the table gives the blind group's ``vᵀPv / r_g`` over
``(f_max / 2)²`` (above 1: named), the centre errors as shipped / with the other answer and the centres' RMS of e/σ.

    PYTHONPATH=. .venv/bin/python benchmarks/triangulate_uncheckable_bench.py [--cases A ...] [--out JSON]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import warnings
from pathlib import Path

import numpy as np

from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation import bundle_result
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block

ROOT = Path(__file__).resolve().parents[1]
CAMERA = FrameCamera(6.0, (4.0, 6.0), (400, 600))

#: label: (simulate_block shape, the approximate EO's errors (m, °), eo_sigma given (m, °), control σ given or
#: None, seeds) — none of these seeds or shapes was run while the rule was fitted
CASES = {
    "fitted: 2 x 4, attitude 0.3° off given 0.001°, GNSS 0.05 m given 0.5 m": (
        {"n_control": 0}, (0.05, 0.3), (0.5, 0.001), None, (10, 11, 12)),
    "3 x 4, attitude 0.3° off given 0.001°, GNSS 0.05 m given 0.5 m": (
        {"strips": 3, "n_control": 0}, (0.05, 0.3), (0.5, 0.001), None, (40, 41, 42)),
    "2 x 5, attitude 0.1° off given 0.002°, GNSS 0.1 m given 0.3 m": (
        {"frames_per_strip": 5, "n_control": 0}, (0.1, 0.1), (0.3, 0.002), None, (43, 44, 45)),
    "2 x 4, attitude 1° off given 0.01°, GNSS 0.05 m given 0.5 m": (
        {"n_control": 0}, (0.05, 1.0), (0.5, 0.01), None, (46, 47, 48)),
    "3 x 3, 4 GCP 0.5 m given 3 cm, GNSS 3 m given 0.5 m": (
        {"strips": 3, "frames_per_strip": 3, "n_control": 4, "control_sigma": (0.5, 0.5)}, (3.0, 0.3), (0.5, 0.3),
        (0.02, 0.03), (50, 51, 52)),
    "2 x 5, 6 GCP 0.3 m given 2 cm, GNSS 2 m given 0.3 m": (
        {"frames_per_strip": 5, "n_control": 6, "control_sigma": (0.3, 0.3)}, (2.0, 0.2), (0.3, 0.2),
        (0.02, 0.02), (53, 54, 55)),
}


def _block(shape, eo_noise, control_given, seed):
    shape = {"strips": 2, "frames_per_strip": 4, "camera": CAMERA, "point_spacing": 80.0, **shape}
    sb = simulate_block(seed=seed, blunder_fraction=0.0, margin=5.0, eo_noise=eo_noise, **shape)
    if control_given is not None:
        b = sb.block
        sig = np.where((b.role == "control")[:, None], np.array(control_given)[[0, 0, 1]], b.point_sigma)
        sb = dataclasses.replace(sb, block=dataclasses.replace(b, point_sigma=sig))
    return sb


def _measures(sb, result) -> dict:
    e = np.array([[a.X - t.X, a.Y - t.Y, a.Z - t.Z] for a, t in zip(result.eo, sb.true_eo)])
    return {"centre_rms_m": float(np.sqrt(np.mean(e ** 2))),
            "centre_e_over_sigma": float(np.sqrt(np.mean((e / result.eo_sigma[:, :3]) ** 2)))}


def run_seed(shape, eo_noise, eo_sigma, control_given, seed) -> dict:
    """The seed adjusted as shipped and with :func:`uncheckable`'s other answer (module docstring)."""
    sb = _block(shape, eo_noise, control_given, seed)
    opts = BundleOptions(eo_sigma=eo_sigma)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kept = adjust_block(sb.block, opts)
        rule = bundle_result.uncheckable
        named = (kept.stats.get("reweighting") or {}).get("uncheckable") or []
        bundle_result.uncheckable = ((lambda *a, **k: []) if named else
                                     (lambda groups, f, base: [k for k in groups if k in f and k != "image"
                                                               and not np.isfinite(groups[k]["sigma0"])]))
        try:
            forced = adjust_block(sb.block, opts)
        finally:
            bundle_result.uncheckable = rule
    groups = kept.stats["variance_components"]
    f = bundle_result.group_factors({k: g for k, g in groups.items() if k in bundle_result._GROUPS}, kept.sigma0)
    blind = [k for k in ("control", "position_prior", "attitude_prior")
             if k in groups and not np.isfinite(groups[k]["sigma0"])]
    top = max((v for k, v in f.items() if k not in blind), default=np.nan)
    ratio = {k: groups[k]["vtpv"] / max(groups[k]["redundancy"], 1e-300) / (top / 2) ** 2 for k in blind}
    out = {"seed": seed, "named": named, "blind_ratio": ratio, "f_max": top,
           "groups": {k: {"sigma0": g["sigma0"], "redundancy": g["redundancy"]} for k, g in groups.items()},
           "kept": _measures(sb, kept), "forced": _measures(sb, forced)}
    out["right"] = out["forced"]["centre_rms_m"] > out["kept"]["centre_rms_m"] if ratio else None
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "triangulate_uncheckable_bench.json"))
    a = ap.parse_args(argv)
    table = {}
    for label in a.cases:
        t0 = sum(os.times()[:2])
        rows = [run_seed(*CASES[label][:4], seed) for seed in CASES[label][4]]
        table[label] = {"rows": rows, "cpu_s": sum(os.times()[:2]) - t0}
        print(label)
        for r in rows:
            ratio = ", ".join(f"{k} {v:.3g}" for k, v in r["blind_ratio"].items()) or "no blind group"
            print(f"  seed {r['seed']}: vtPv/r over (f_max/2)² {ratio}; named {r['named'] or '-'}; centres "
                  f"{r['kept']['centre_rms_m']:.3f} m / {r['forced']['centre_rms_m']:.3f} m the other answer, e/σ "
                  f"{r['kept']['centre_e_over_sigma']:.2f} / {r['forced']['centre_e_over_sigma']:.2f}; right "
                  f"{r['right']}")
        print(f"  cpu {table[label]['cpu_s']:.1f} s")
    Path(a.out).write_text(json.dumps(table, indent=1, default=float))


if __name__ == "__main__":
    main()
