"""Does the DEM's margin from few tie points hold the truth? ``dsm --rpc --dem`` on the rendered satellite pair.

The rendered pair of ``tests/rendered_rpc_pair.py`` (``--size`` px, its known surface) is set up once as
``fotogeo dsm --rpc --dem`` does (:func:`fotogeo.tools.dsm.rpc_tool._pair_setup`: pointing, tie points, the DEM's
fit); then, for each ``n`` of ``--ns``, ``--seeds`` random subsets of ``n`` of its tie points stand in for the
pair's (``rpc_pairs.pointing`` returns the subset) and the pair is set up again: the DEM's fit and margin, the pair's
range, and the range each window of ``TILE`` left pixels (a grid of them ``--step`` px apart) searches
(``rpc_dem.tile_range``). A window *holds the truth* when its range brackets all the true heights its pixels see
(25 x 25 lines of sight each, ``_first_hit``). The DEMs are ``dsm_dem_bench.DEMS`` made from the truth averaged to
20 m cells. Rows per DEM and ``n``: the share of (subset, window) holding the truth, the share of subsets whose every
window does, the share whose margin reaches the one all tie points give (the margin's stated confidence), the
margin's median and 5-95 % range, the mean height range a window searches (the matching's cost grows with it) and
the share of subsets whose DEM guides the pair. ``--tree`` measures another checkout (the before)::

    PYTHONPATH=. .venv/bin/python benchmarks/dsm_dem_margin_bench.py [--size 1024] [--dems true,srtm,smooth-20] \\
        [--ns 20,25,40,80,all] [--seeds 200] [--tree ../main]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


class _Stop(Exception):
    pass


def _setup_args(sc: dict, dem: str, out: Path) -> tuple:
    """The arguments ``rpc_dsm`` gives ``_pair_setup`` for the pair (the run stopped there) and the full
    pointing."""
    from fotogeo.tools.dsm import dsm, rpc_pairs, rpc_tool
    got = {}
    setup = rpc_tool._pair_setup

    def capture(*a):
        got["args"] = a
        raise _Stop
    rpc_tool._pair_setup = capture
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            dsm(sc["images"], out, rpc=True, resolution=0.7, dem=dem, dem_heights="ellipsoid")
    except _Stop:
        pass
    finally:
        rpc_tool._pair_setup = setup
    p, ims, sources, zlo, zhi, guide = got["args"]
    pt = rpc_pairs.pointing(ims[p.i].model, ims[p.j].model, (sources[p.i], sources[p.j]), zlo, zhi)
    return got["args"], pt


def _subset_setup(args: tuple, pt: dict, keep) -> dict:
    """``_pair_setup`` with the tie points ``keep`` (indices) of ``pt`` standing in for the pair's."""
    from fotogeo.tools.dsm import rpc_pairs, rpc_tool
    sub = {**pt, "z": pt["z"][keep], "p1": pt["p1"][keep], "n": int(len(keep))}
    pointing = rpc_pairs.pointing
    rpc_pairs.pointing = lambda *a, **k: sub
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return rpc_tool._pair_setup(*args)
    finally:
        rpc_pairs.pointing = pointing


def _windows(size: int, step: int, tile: int) -> list:
    starts = list(range(0, max(1, size - tile) + 1, step))
    return [(c, r, min(size, c + tile), min(size, r + tile)) for r in starts for c in starts]


def _truth(sc: dict, windows: list) -> list:
    from rendered_rpc_pair import _first_hit
    out = []
    for c0, r0, c1, r1 in windows:
        col, row = np.meshgrid(np.linspace(c0, c1, 25), np.linspace(r0, r1, 25))
        z = _first_hit(sc["cameras"][0], sc["truth"], sc["truth_transform"], col.ravel(), row.ravel())[2]
        out.append(np.asarray(z, float))
    return out


def _measure(args, pt, windows, truth, keep) -> dict:
    from fotogeo.tools.dsm import rpc_dem
    s = _subset_setup(args, pt, keep)
    m1 = args[1][args[0].i].model
    held, widths, out = [], [], []
    for w, z in zip(windows, truth):
        lo, hi = (rpc_dem.tile_range(m1, s["dem"], w, s["zlo"], s["zhi"]) if s["dem"] is not None
                  else (s["zlo"], s["zhi"]))
        held.append(lo <= z.min() and hi >= z.max())
        widths.append(hi - lo)
        out.append(float(np.mean((z < lo) | (z > hi))))
    return {"held": held, "width": float(np.mean(widths)), "outside": float(np.mean(out)),
            "margin": None if s["dem"] is None else float(s["dem"].margin),
            "above": None if s["dem"] is None else float(getattr(s["dem"], "above", s["dem"].margin))}


def _rows(dem: str, args, pt, windows, truth, ns: list, seeds: int, tag: str) -> list:
    n_all = len(pt["z"])
    full = _measure(args, pt, windows, truth, np.arange(n_all))
    rows = []
    for n in ns:
        k = n_all if n == "all" else int(n)
        rng = np.random.default_rng(0)
        runs = [full] if k >= n_all else [_measure(args, pt, windows, truth, np.sort(rng.choice(n_all, k, False)))
                                          for _ in range(seeds)]
        margins = np.array([r["margin"] for r in runs if r["margin"] is not None])
        held = np.array([r["held"] for r in runs])
        row = {"case": f"margin {dem}, n={k}{tag}", "tie_points_all": n_all, "subsets": len(runs),
               "windows": len(windows), "held_windows": round(float(held.mean()), 4),
               "held_all_windows": round(float(held.all(axis=1).mean()), 4),
               "mean_window_range_m": round(float(np.mean([r["width"] for r in runs])), 2),
               "cells_outside": round(float(np.mean([r["outside"] for r in runs])), 5),
               "dem_guides": round(len(margins) / len(runs), 3)}
        if len(margins) and full["margin"] is not None:
            row.update(margin_all_m=round(full["margin"], 2), margin_median_m=round(float(np.median(margins)), 2),
                       margin_p5_p95_m=[round(float(v), 2) for v in np.percentile(margins, [5, 95])],
                       reaches_margin_all=round(float(np.mean(margins >= full["margin"] - 1e-9)), 3),
                       above_median_m=round(float(np.median([r["above"] for r in runs if r["above"] is not None])),
                                            2))
        rows.append(row)
    return rows


def main() -> None:
    import tempfile
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1024, help="the rendered pair's side (px)")
    ap.add_argument("--dems", default="true,srtm,smooth-20")
    ap.add_argument("--ns", default="20,25,40,80,all")
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--step", type=int, default=128, help="windows of TILE px this far apart")
    ap.add_argument("--tree", help="run this checkout's fotogeo (e.g. ../main: the before); rows name it")
    a = ap.parse_args()
    sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT / "tests")]
    from dsm_dem_bench import degraded, use_tree  # dsm_bench puts this checkout on sys.path: the tree goes first
    tag = use_tree(a.tree)
    from rendered_rpc_pair import render_rpc_pair

    import fotogeo

    from fotogeo.tools.dsm import rpc_pairs
    os.environ.setdefault("GDAL_PAM_ENABLED", "NO")
    load0, cpu0 = os.getloadavg(), time.process_time()
    run = {"command": " ".join(sys.argv), "fotogeo": str(Path(fotogeo.__file__).parent),
           "started": time.strftime("%Y-%m-%dT%H:%M:%S"), "rows": []}
    with tempfile.TemporaryDirectory(prefix="dsm_dem_margin_") as t:
        t = Path(t)
        sc = render_rpc_pair(t / "pair", a.size)
        ref = _ref20(sc, t / "ref20.tif")
        windows = _windows(a.size, a.step, rpc_pairs.TILE)
        truth = _truth(sc, windows)
        for dem in a.dems.split(","):
            args, pt = _setup_args(sc, degraded(ref, t / f"dem_{dem}.tif", dem, 20.0), t / f"dsm_{dem}.tif")
            for r in _rows(dem, args, pt, windows, truth, a.ns.split(","), a.seeds, tag):
                print(json.dumps(r), flush=True)
                run["rows"].append(r)
    run.update(load_average=[load0, os.getloadavg()], cpu_s=round(time.process_time() - cpu0, 1))
    out = ROOT / "benchmarks" / "results" / "dsm_dem_margin_bench.json"
    runs = json.loads(out.read_text()).get("runs", []) if out.is_file() else []
    out.write_text(json.dumps({"runs": runs + [run]}, indent=1) + "\n")
    print(f"cpu {run['cpu_s']} s, load {run['load_average']} -> {out}")


def _ref20(sc: dict, out: Path) -> str:
    """The truth averaged onto 20 m cells, a GeoTIFF ``out``."""
    import rasterio
    from rasterio.transform import Affine
    t = sc["truth_transform"]
    k = int(round(20.0 / t.a))
    z = sc["truth"]
    n = (z.shape[0] // k, z.shape[1] // k)
    z = z[:n[0] * k, :n[1] * k].reshape(n[0], k, n[1], k).mean(axis=(1, 3))
    with rasterio.open(out, "w", driver="GTiff", width=n[1], height=n[0], count=1, dtype="float32", crs=sc["crs"],
                       transform=t * Affine.scale(k), nodata=-9999.0) as ds:
        ds.write(z.astype(np.float32)[None])
    return str(out)


if __name__ == "__main__":
    main()
