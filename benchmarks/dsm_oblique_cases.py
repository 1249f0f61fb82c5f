"""The oblique frame sets of ``benchmarks/dsm_bench.py --cases oblique_sets`` (``tests/dsm_oblique_sets.py``, issue
30): each set through ``fotogeo dsm`` as a user runs it, its rows against the truth (:func:`oblique_sets`), each
kept pair alone (``--pair-rows``), the first set's first two strips against the whole flight, and the view-angle
sweep (``--view-angle-sweep``, ``benchmarks/dsm_view_sweep.py``)."""
from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np

from dsm_bench_run import _stats, _time_v, limit_tag, python


def oblique_sets(tmp: Path, names=None, params=None, pair_rows: bool = False, sweep: bool = False,
                 extra=(), limits=None) -> list:
    """The oblique frame sets of ``tests/dsm_oblique_sets.py`` (never used while tuning), each through ``fotogeo dsm
    IMAGES --camera C --eo EO -o DSM.tif --report r.json`` as a user runs it (a child process under ``/usr/bin/time
    -v``, cwd outside the checkout): RMSE, NMAD, median of DSM − truth, the share within 1 GSD, completeness, CPU,
    the pairs kept and the reasons of the others; then the first set's first two strips alone against the whole
    flight's DSM (issue 30's measure: NMAD of subset − whole where both have a height). ``params``: more sets as
    parameter dicts (``make_set``'s, JSON; ``"all_pairs": true`` gives every pair with ``--pairs``), named by their
    JSON; ``pair_rows``: each kept pair also alone
    (``--pairs``, on the set's grid) against the truth, beside its convergence angle and B/H (which pairs' heights
    miss the target); ``sweep``: only the view-angle sweep of ``benchmarks/dsm_view_sweep.py``; ``extra``:
    more ``fotogeo dsm`` options for every set (``--oblique-dsm-options``, e.g. ``--refine``; the row names them);
    ``limits``: the automatic pair choice's limits (``--view-angle-limit``, ``--pair-limits``,
    :func:`dsm_bench_run.set_limits`; the row names them).
    Each row also says where its squared error lies (:func:`_by_pairs`)."""
    import re

    from dsm_oblique_sets import SETS, make_set
    from dsm_scenes import compare
    if sweep:
        from dsm_view_sweep import view_angle_sweep
        return view_angle_sweep(tmp, _time_v)
    rows, py, tag = [], [*python(limits), "dsm"], limit_tag(limits)
    sets = [(n, n) for n in (names if names is not None else [] if params else list(SETS))]
    sets += [(json.dumps(p), {**p, "strips": [tuple(x) for x in p["strips"]]}) for p in params or []]
    for name, spec in sets:
        given = spec.pop("all_pairs", False) if isinstance(spec, dict) else False
        sc = make_set(spec, tmp / f"set{len(rows)}")
        out, rep = tmp / f"{len(rows)}.tif", tmp / f"{len(rows)}.json"
        row = {"case": f"oblique_sets {name}" + "".join(f" {o}" for o in extra) + tag, "frames": len(sc["images"]),
               "gsd_m": sc["gsd"]}
        if given:  # every pair of frames given (--pairs): none left out for its views
            given = tmp / f"pairs{len(rows)}.txt"
            given.write_text("".join(f"{a} {b}\n" for a, b in itertools.combinations(sc["names"], 2)))
        try:
            row.update(_time_v([*py, *map(str, sc["images"]), "--camera", str(sc["camera"]), "--eo", str(sc["eo"]),
                                "--crs", sc["crs"], "-o", str(out), "--report", str(rep), "-q", *extra,
                                *(["--pairs", str(given)] if given else [])], cwd=tmp))
        except SystemExit as e:  # a refusal: its last line is the row
            rows.append({**row, "refused": str(e).strip().splitlines()[-1]})
            continue
        r, c = json.loads(rep.read_text()), compare(out, sc["surface"])
        left = {}
        for p in r["pairs"]:
            if not p["kept"]:
                key = re.sub(r"\d+(\.\d+)?", "N", p["reason"].split(" (")[0].split(":")[0])
                left[key] = left.get(key, 0) + 1
        rows.append({**row, "resolution_m": r["grid"]["resolution"], "pairs_kept": r["pairs_kept"], "pairs_left": left,
                     "rmse_m": c["rmse"], "rmse_gsd": c["rmse"] / sc["gsd"], "nmad_m": c["nmad"],
                     "median_m": c["median"],
                     "within_1gsd": float((c["abs"] <= sc["gsd"]).mean()), "completeness": r["completeness"],
                     "over_3gsd": float((c["abs"] > 3 * sc["gsd"]).mean()), "by_pairs": _by_pairs(out, c["abs"])})
        if pair_rows:
            rows += _pairs_alone(tmp, sc, name + tag, r, out, py)
        if name == next(iter(SETS)):  # the whole flight vs its first two strips
            rows.append(_subset_vs_whole(tmp, sc, out, py, tag))
    return rows


def _by_pairs(dsm_path, err) -> dict:
    """Where the squared error lies: per number of pairs that gave a cell (the DSM's count band, band 2; "3+"
    for three or more), the share of the valid cells and of the sum of squared errors, and their RMSE (m);
    ``err`` the cells' errors in :func:`dsm_scenes.compare`'s order (its valid cells, row by row)."""
    import rasterio
    with rasterio.open(dsm_path) as ds:
        h, n, nod = ds.read(1), ds.read(2), ds.nodata
    n, e2 = n[h != nod], np.asarray(err, float) ** 2
    out = {}
    for key, sel in (("1", n == 1), ("2", n == 2), ("3+", n >= 3)):
        out[key] = {"cells": round(float(sel.mean()), 4), "sq_err": round(float(e2[sel].sum() / e2.sum()), 4),
                    "rmse_m": round(float(np.sqrt(e2[sel].mean())), 4) if sel.any() else None}
    return out


def _pairs_alone(tmp: Path, sc: dict, name: str, report: dict, whole: Path, py: list) -> list:
    """Each kept pair of a set matched alone (``--pairs``) on the set's grid: RMSE, NMAD, share of cells > 3 GSD off,
    its convergence angle and B/H from the report."""
    from dsm_scenes import compare
    rows = []
    for p in (q for q in report["pairs"] if q["kept"]):
        a, b = p["images"]
        pairs, out = tmp / f"pair_{a}_{b}.txt", tmp / f"pair_{a}_{b}.tif"
        pairs.write_text(f"{a} {b}\n")
        row = {"case": f"oblique_sets {name} pair {a}-{b} alone", "convergence_deg": p["convergence_deg"],
               "base_to_height": p["base_to_height"], "view_angle_deg": p["view_angle_deg"]}
        row.update(_time_v([*py, *map(str, sc["images"]), "--camera", str(sc["camera"]), "--eo", str(sc["eo"]),
                            "--crs", sc["crs"], "--pairs", str(pairs), "-o", str(out), "-q", *_grid_of(whole)],
                           cwd=tmp))
        c = compare(out, sc["surface"])
        rows.append({**row, "rmse_gsd": c["rmse"] / sc["gsd"], "nmad_m": c["nmad"], "median_m": c["median"],
                     "over_3gsd": float((c["abs"] > 3 * sc["gsd"]).mean()), "cells": c["n"]})
    return rows


def _subset_vs_whole(tmp: Path, sc: dict, whole: Path, py: list, tag: str = "") -> dict:
    sub = [p for p in sc["images"] if p.stem.startswith(("S1_", "S2_"))]
    out = tmp / "subset.tif"
    row = {"case": "oblique_sets first two strips vs the whole flight" + tag, "frames": len(sub)}
    row.update(_time_v([*py, *map(str, sub), "--camera", str(sc["camera"]), "--eo", str(sc["eo"]), "--crs", sc["crs"],
                        "-o", str(out), "-q", *_grid_of(whole)], cwd=tmp))
    import rasterio

    from dsm_scenes import compare
    from rasterio.windows import from_bounds
    with rasterio.open(out) as a, rasterio.open(whole) as b:  # the subset's cells on the whole's (aligned) grid
        win = from_bounds(*b.bounds, a.transform).round_offsets().round_lengths()
        x = a.read(1, window=win, boundless=True, fill_value=a.nodata, out_shape=b.shape).astype(float)
        y = b.read(1).astype(float)
        ok = (x != a.nodata) & (y != b.nodata)
    c = compare(out, sc["surface"])
    return {**row, **{f"{k}_vs_whole_m": v for k, v in _stats(x[ok] - y[ok]).items()}, "common_cells": int(ok.sum()),
            "share_of_whole_cells": float(ok.sum() / max(1, (y != b.nodata).sum())), "rmse_m": c["rmse"],
            "nmad_m": c["nmad"], "median_m": c["median"]}


def _grid_of(path) -> list:
    """``--bounds`` and ``--resolution`` of a DSM: another run on its grid."""
    import rasterio
    with rasterio.open(path) as ds:
        return ["--bounds", ",".join(f"{v:.6f}" for v in ds.bounds), "--resolution", f"{ds.res[0]:.9g}"]
