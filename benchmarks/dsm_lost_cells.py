"""Which cells a change to dense matching removed or added on the rendered satellite pairs, and whether they were right.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_lost_cells.py --before WORK_A --after WORK_B [--cases NAMES]
      [--label TEXT]

``WORK_A`` and ``WORK_B`` are the ``--work`` folders of two ``dsm_heldout_bench.py --groups rpc`` runs (e.g. one
with ``--tree`` a checkout before the change, one after): their DSMs without a DEM (``rpc/<case>/dsm.tif``) are
compared cell by cell on their common grid against the truth of the scene (rendered again with the case's
keywords into ``--scratch``). Cells are split into

* ``lost``: a height before, none after — their ``|DSM − truth|`` *before*;
* ``kept``: a height in both — ``|DSM − truth|`` before and after;
* ``gained``: none before, a height after — their ``|DSM − truth|`` after;

each with the count, the median, 90th and 99th percentile of ``|error|``, the shares above 1 m and 3 m, and the
share of the cells both views see unoccluded (:func:`dsm_heldout_bench.unoccluded`): a lost cell where a view
sees a wall instead is a height that was never measurable. Writes benchmarks/results/dsm_lost_cells.json (a row
run now replaces the row of the same case and label).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "benchmarks")]
OUT = ROOT / "benchmarks" / "results" / "dsm_lost_cells.json"


def _heights(path: Path):
    import rasterio
    with rasterio.open(path) as ds:
        h = ds.read(1).astype(np.float64)
        h[h == ds.nodata] = np.nan
        return h, ds.transform


def _stats(err: np.ndarray, seen: np.ndarray) -> dict:
    a = np.abs(err)
    if not a.size:
        return {"cells": 0}
    p50, p90, p99 = np.percentile(a, (50, 90, 99))
    return {"cells": int(a.size), "abs_median_m": round(float(p50), 3), "abs_p90_m": round(float(p90), 3),
            "abs_p99_m": round(float(p99), 3), "over_1m": round(float(np.mean(a > 1.0)), 3),
            "over_3m": round(float(np.mean(a > 3.0)), 3), "unoccluded": round(float(np.mean(seen)), 3)}


def lost_cells(before: Path, after: Path, sc: dict) -> dict:
    """The ``lost``, ``kept`` and ``gained`` cells (module docstring) of DSM ``before`` → ``after`` on scene ``sc``."""
    from dsm_heldout_bench import unoccluded
    from rendered_rpc_pair import _sample
    h0, t0 = _heights(before)
    h1, t1 = _heights(after)
    if h0.shape != h1.shape or not t0.almost_equals(t1):
        raise SystemExit(f"{before} and {after} are on different grids: compare DSMs made with the same --bounds")
    rr, cc = np.mgrid[0:h0.shape[0], 0:h0.shape[1]]
    x, y = (np.asarray(v) for v in t0 * (cc + 0.5, rr + 0.5))
    truth = _sample(sc["truth"], sc["truth_transform"], x, y).astype(np.float64)
    v0, v1 = np.isfinite(h0), np.isfinite(h1)
    sets = {"lost": v0 & ~v1, "kept": v0 & v1, "gained": ~v0 & v1}
    out = {}
    for name, m in sets.items():
        seen = unoccluded(x[m], y[m], sc)
        if name != "gained":
            out[name + ("_before" if name == "kept" else "")] = _stats((h0 - truth)[m], seen)
        if name != "lost":
            out[name + ("_after" if name == "kept" else "")] = _stats((h1 - truth)[m], seen)
    out["cells_before"], out["cells_after"] = int(v0.sum()), int(v1.sum())
    out["lost_share_of_before"] = round(out["lost"]["cells"] / max(out["cells_before"], 1), 4)
    return out


def main() -> None:
    from dsm_heldout_bench import RPC
    from rendered_rpc_pair import render_rpc_pair
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="--work folder of the run before the change")
    ap.add_argument("--after", required=True, help="--work folder of the run after the change")
    ap.add_argument("--cases", default=None, help="rpc case names separated by ';' [every case with both DSMs]")
    ap.add_argument("--label", default="before -> after", help="names the comparison in the results")
    ap.add_argument("--scratch", default="/tmp/dsm_lost_cells", help="the scenes are rendered again here")
    a = ap.parse_args()
    names = set(a.cases.split(";")) if a.cases else None
    load0, rows = os.getloadavg()[0], []
    for name, kw in RPC.items():
        slug = re.sub(r"[^\w]+", "_", name)
        paths = [Path(w) / "rpc" / slug / "dsm.tif" for w in (a.before, a.after)]
        if (names and name not in names) or not all(p.is_file() for p in paths):
            continue
        kw = {k: v for k, v in kw.items() if k != "uint8"}
        sc = render_rpc_pair(Path(a.scratch) / slug, **kw)
        rows.append({"case": name, "label": a.label, **lost_cells(*paths, sc), "before": str(paths[0]),
                     "after": str(paths[1]), "load_average": round(load0, 1), "date": time.strftime("%Y-%m-%d")})
        print(json.dumps(rows[-1]), flush=True)
    old = json.loads(OUT.read_text())["rows"] if OUT.is_file() else []
    new = {(r["case"], r["label"]) for r in rows}
    OUT.write_text(json.dumps({"rows": [r for r in old if (r["case"], r["label"]) not in new] + rows}, indent=1,
                              ensure_ascii=False))
    print("case | lost cells (share) | lost |err| before: median / p90, >1 m, unoccluded | kept |err| before -> "
          "after: median / p90, >1 m, unoccluded | gained: cells, median, >1 m")
    for r in rows:
        lo, k0, k1, g = r["lost"], r["kept_before"], r["kept_after"], r["gained"]
        print(f"{r['case']} | {lo['cells']} ({r['lost_share_of_before']:.2%}) | {lo.get('abs_median_m')} / "
              f"{lo.get('abs_p90_m')}, {lo.get('over_1m')}, {lo.get('unoccluded')} | {k0['abs_median_m']} / "
              f"{k0['abs_p90_m']} -> {k1['abs_median_m']} / {k1['abs_p90_m']}, {k0['over_1m']} -> {k1['over_1m']}, "
              f"{k0['unoccluded']} | {g['cells']}, {g.get('abs_median_m')}, {g.get('over_1m')}")


if __name__ == "__main__":
    main()
