"""The rays' intersection angle of ``fotogeo dsm``'s points, per pair, and what it does to the heights.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_angle_bench.py [--cases grid45-p4p-684-rtk] [--work DIR]

Renders a flight of ``dsm_dji_bench.py`` (:data:`dsm_dji_bench.CASES`), runs the DSM tool in this process on every
frame with the true orientation and records each pair's points as it matches them (before fusion). Per point the
intersection angle γ is the angle at the point between the directions to the two projection centres; a height's
standard deviation grows like σ_parallax / sin γ (Kraus 2007, the normal case's σ_Z = Z² σ_px / (B f)).

Per pair: γ's percentiles, the shares under 3°, 5° and 10°, and the points' errors against the true DEM (nearest
0.5 m cell at the point) by bins of γ: median, NMAD = 1.4826 · median |e − median e| (Höhle & Höhle 2009) and the
share beyond 1 m. Then the same points fused offline on the DSM's grid (:mod:`fotogeo.stereo.fusion`, each pair's
layer despeckled as the tool does, the fused heights despeckled again) under candidate rules: the plain median;
the points under a minimum angle dropped (``min_angle``); the median weighted per pair and cell by the mean sin γ
of its points (``weighted``); a pair set aside in a cell where its mean angle there is under the limit and another
pair's is not (``set_aside``: where no pair reaches the limit the narrow ones still give the height). Each against
the true DEM: RMSE, NMAD, within 1 m, completeness (cells with a height / cells the plain median gives). None of
these rules is in the tool (none that keeps the cells lowered the NMAD); the tool's report gives each frame pair's
``ray_angle_median_deg`` and ``ray_angle_under_5deg``, recorded here beside the figures of the points recorded.
Prints JSON lines and writes ``benchmarks/results/dsm_angle_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks"), str(ROOT / "tests")]
from dsm_dji_bench import CASES, RES, _dem_at, _truth_files  # noqa: E402
from rendered_converging import CRS  # noqa: E402
from rendered_dji_flight import dji_flight  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "dsm_angle_bench.json"
BINS = (0.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0, 90.0)
MIN_ANGLES = (2.0, 3.0, 4.0, 5.0, 7.0, 10.0)


def _errstats(e) -> dict:
    if not len(e):
        return {"n": 0}
    med = float(np.median(e))
    return {"n": int(len(e)), "median_m": round(med, 3),
            "nmad_m": round(float(1.4826 * np.median(np.abs(e - med))), 3),
            "beyond_1m": round(float(np.mean(np.abs(e) > 1.0)), 3)}


def _record(points: dict):
    """Wrap :meth:`fotogeo.tools.dsm.matching.PairMatch.dense` so that every pair's points land in ``points``."""
    from fotogeo.tools.dsm import matching
    orig = matching.PairMatch.dense

    def dense(self, box, colours=False):
        for P, rgb in orig(self, box, colours):
            points.setdefault(self.name, {"P": [], "c": tuple(self.rp.centres)})["P"].append(np.array(P))
            yield P, rgb
    matching.PairMatch.dense = dense
    return lambda: setattr(matching.PairMatch, "dense", orig)


def weighted_median(stack, weights) -> np.ndarray:
    """The weighted median over axis 0 of ``stack`` (K, rows, cols) with ``weights`` (NaN heights ignored): the
    smallest height whose cumulative weight reaches half the total (the two middle values' mean at a tie)."""
    w = np.where(np.isfinite(stack), weights, 0.0)
    order = np.argsort(np.where(np.isfinite(stack), stack, np.inf), axis=0)
    z, w = np.take_along_axis(stack, order, 0), np.take_along_axis(w, order, 0)
    cw = np.cumsum(w, 0)
    half = 0.5 * cw[-1]
    with np.errstate(invalid="ignore"):
        k = np.argmax(cw >= half[None] - 1e-12 * np.maximum(half[None], 1), axis=0)
        lo = np.take_along_axis(z, k[None], 0)[0]
        at = np.take_along_axis(cw, k[None], 0)[0]
        tie = np.isclose(at, half) & (k + 1 < len(z))
        hi = np.take_along_axis(z, np.minimum(k + 1, len(z) - 1)[None], 0)[0]
        out = np.where(tie & np.isfinite(hi), 0.5 * (lo + hi), lo)
    out[~(cw[-1] > 0)] = np.nan
    return out


def _fused(grid, pairs, rule, value=None) -> np.ndarray:
    """The heights of ``pairs`` ``[(P, γ)]`` fused on ``grid`` under ``rule`` (module docstring)."""
    from fotogeo.stereo.fusion import PairLayer, nan_median, remove_speckles, splat
    from fotogeo.tools.dsm.matching import _despeckled
    from fotogeo.tools.dsm.outputs import SPECKLE_CELLS, SPECKLE_STEP
    means, angles, weights = [], [], []
    shape = (grid.height, grid.width)
    for P, g in pairs:
        keep = g >= value if rule == "min_angle" else np.ones(len(g), bool)
        layer = PairLayer(grid)
        layer.add(P[keep])
        if not layer.n.any():
            continue
        layer = _despeckled(layer)
        means.append(layer.mean())
        mean_of = PairLayer(grid)  # the rasterised means of γ and sin γ, weighted as the heights are
        for v, out in ((g[keep], angles), (np.sin(np.radians(g[keep])), weights)):
            mean_of.n[:], mean_of.s[:] = 0, 0.0
            mean_of.add(np.column_stack([P[keep, :2], v]))
            with np.errstate(invalid="ignore", divide="ignore"):
                out.append(splat(mean_of.s.reshape(shape)) / splat(mean_of.n.reshape(shape)))
    stack = np.stack(means)
    if rule == "weighted":
        h = weighted_median(stack, np.stack(weights))
    else:
        if rule == "set_aside":
            narrow = ~(np.stack(angles) >= value) & np.isfinite(stack)
            stack[narrow & (np.isfinite(stack) & ~narrow).any(axis=0)[None]] = np.nan
        h = nan_median(stack)
    return remove_speckles(h.astype(np.float32), SPECKLE_CELLS, SPECKLE_STEP * grid.resolution)[0]


def run_case(name: str, work: Path) -> list:
    import rasterio

    from fotogeo.stereo.fusion import GridSpec
    from fotogeo.stereo.rays import intersection_angles
    from fotogeo.tools.dsm.tool import dsm
    spec, _ = CASES[name]
    folder = work / name
    block = dji_flight(folder / "img", **spec)
    cam, eo = _truth_files(folder, block)
    points = {}
    undo = _record(points)
    t = time.process_time()
    try:
        out = folder / "dsm_angle.tif"
        rep = dsm(block["frames"], out, camera=cam, eo=eo, crs=CRS, resolution=RES, overwrite=True)
    finally:
        undo()
    rows = [{"flight": name, "what": "dsm run", "cpu_s": round(time.process_time() - t, 1)}]
    dem = block["dem"]
    reported = {"-".join(p["images"]): p for p in rep["pairs"] if p["kept"]}
    pairs = []
    for pname, rec in points.items():
        P = np.concatenate(rec["P"])
        g = intersection_angles(P, *rec["c"])
        e = P[:, 2] - _dem_at(dem, P[:, 0], P[:, 1])
        ok = np.isfinite(e)
        pairs.append((P, g))
        row = {"flight": name, "what": "pair", "pair": pname, "points": int(len(P)),
               "angle_deg_p5_p50_p95": [round(float(v), 2) for v in np.percentile(g, [5, 50, 95])],
               "angle_min_deg": round(float(g.min()), 2),
               "report": {k: reported.get(pname, {}).get(k) for k in ("ray_angle_median_deg", "ray_angle_under_5deg")},
               **{f"share_under_{a:g}deg": round(float(np.mean(g < a)), 3) for a in (3.0, 5.0, 10.0)},
               "error_by_angle": {f"{a:g}-{b:g}": _errstats(e[ok & (g >= a) & (g < b)])
                                  for a, b in zip(BINS[:-1], BINS[1:])}}
        rows.append(row)
        print(json.dumps(row), flush=True)
    allg = np.concatenate([g for _, g in pairs])
    alle = np.concatenate([P[:, 2] - _dem_at(dem, P[:, 0], P[:, 1]) for P, _ in pairs])
    rows.append({"flight": name, "what": "all pairs' points", "error_by_angle": {
        f"{a:g}-{b:g}": _errstats(alle[np.isfinite(alle) & (allg >= a) & (allg < b)])
        for a, b in zip(BINS[:-1], BINS[1:])}})
    print(json.dumps(rows[-1]), flush=True)
    with rasterio.open(out) as ds:
        t_ = ds.transform
        grid = GridSpec(t_.c, t_.f, t_.a, ds.width, ds.height)
    X, Y = grid.centres()
    truth = _dem_at(dem, *np.meshgrid(X, Y))
    base = None
    for rule, value in [("median", None), *(("min_angle", a) for a in MIN_ANGLES), ("weighted", None),
                        *(("set_aside", a) for a in MIN_ANGLES)]:
        h = _fused(grid, pairs, rule, value)
        has = np.isfinite(h) & np.isfinite(truth)
        base = has.sum() if base is None else base
        d = (h - truth)[has].astype(np.float64)
        rows.append({"flight": name, "what": "fused offline", "rule": rule, "angle_deg": value,
                     "rmse_m": round(float(np.sqrt(np.mean(d * d))), 3), **_errstats(d),
                     "within_1m": round(float(np.mean(np.abs(d) <= 1.0)), 3),
                     "completeness_vs_median": round(float(has.sum() / base), 4)})
        print(json.dumps(rows[-1]), flush=True)
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="grid45-p4p-684-rtk", help="comma-separated names of " + ", ".join(CASES))
    ap.add_argument("--work", default="/tmp/dsm_angle_bench", help="renders and DSMs go here")
    a = ap.parse_args(argv)
    load0, rows = os.getloadavg()[0], []
    for name in a.cases.split(","):
        rows += run_case(name, Path(a.work).resolve())
    old = json.loads(OUT.read_text()) if OUT.is_file() else {"rows": []}
    done = {r["flight"] for r in rows}
    stamp = {"load_average": round(load0, 1), "date": time.strftime("%Y-%m-%d")}
    OUT.write_text(json.dumps({"rows": [r for r in old["rows"] if r["flight"] not in done]
                               + [{**r, **stamp} for r in rows]}, indent=1, ensure_ascii=False))


if __name__ == "__main__":
    main()
