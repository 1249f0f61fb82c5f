"""Data snooping: closed-form redundancy numbers (now) vs leave-one-out refits (before), same flags.

    .venv/bin/python benchmarks/snooping_bench.py [--points 2400] [--models affine,projective]
                                                  [--refits affine] [--rev 5b57375]

A registration-sized GCP set (``--points``, default 2400, like the 2355 tie points of an NGI
registration) with 0.5 px noise and 10 planted blunders of 6–12 px is fitted with blunder
removal on. The "before" implementation is ``fotogeo/orientation/adjustment.py`` at ``--rev``
(the last commit with leave-one-out refits), loaded from git; it runs only for the models in
``--refits`` (the projective one took 697 s on 2400 points here). Prints a table and writes
``benchmarks/results/snooping_bench.json``: time per fit and the removed point ids, which must
agree.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import fotogeo.orientation.adjustment as current  # noqa: E402


def load_old(rev: str):
    """``fotogeo/orientation/adjustment.py`` at ``rev``, importable as a sibling of the current module."""
    text = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:fotogeo/orientation/adjustment.py"],
                          check=True, capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "old_adjustment.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("fotogeo.orientation.old_adjustment", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def gcps(n: int, seed: int = 3):
    rng = np.random.default_rng(seed)
    ground = np.column_stack([rng.uniform(5e5, 5.1e5, n), rng.uniform(4.42e6, 4.43e6, n), rng.uniform(700, 900, n)])
    px = np.column_stack([(ground[:, 0] - 5e5) / 3 + 0.02 * (ground[:, 2] - 800), (4.43e6 - ground[:, 1]) / 3.1])
    px += rng.normal(0, 0.5, px.shape)
    blunders = rng.choice(n, 10, replace=False)
    px[blunders] += rng.uniform(6, 12, (10, 2))
    return ground, px, np.array([f"P{i}" for i in range(n)]), sorted(f"P{i}" for i in blunders)


def run(mod, name, ground, px, ids):
    t0 = time.perf_counter()
    f = mod.fit_orientation(name, ground, px, np.full(len(px), "control"), ids, remove_blunders=True)
    return time.perf_counter() - t0, sorted(s["id"] for s in f.snooping if s["removed"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=2400)
    ap.add_argument("--models", default="affine,projective")
    ap.add_argument("--refits", default="affine", help="models also timed with the old leave-one-out refits")
    ap.add_argument("--rev", default="5b57375")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "snooping_bench.json")
    a = ap.parse_args()
    ground, px, ids, planted = gcps(a.points)
    old = load_old(a.rev) if a.refits else None
    rows = []
    print(f"{a.points} points, 10 planted blunders: {', '.join(planted)}")
    print(f"{'model':12s} {'method':12s} {'time s':>9s}  removed")
    for name in a.models.split(","):
        for label, mod in (("closed form", current), ("refits", old)):
            if label == "refits" and name not in a.refits.split(","):
                continue
            dt, removed = run(mod, name, ground, px, ids)
            rows.append({"model": name, "method": label, "time_s": dt, "removed": removed,
                         "planted_found": sorted(set(planted) & set(removed))})
            print(f"{name:12s} {label:12s} {dt:9.2f}  {len(removed)} ({len(set(planted) & set(removed))} of the "
                  f"10 planted)", flush=True)
    for name in {r["model"] for r in rows if r["method"] == "refits"}:
        new, ref = (next(r for r in rows if r["model"] == name and r["method"] == m) for m in ("closed form", "refits"))
        print(f"{name}: same removed points: {new['removed'] == ref['removed']}; "
              f"speed-up {ref['time_s'] / new['time_s']:.0f}x")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps({"points": a.points, "planted": planted, "rev_before": a.rev, "rows": rows,
                                 "command": " ".join(["python", "benchmarks/snooping_bench.py", *sys.argv[1:]])},
                                indent=2))
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
