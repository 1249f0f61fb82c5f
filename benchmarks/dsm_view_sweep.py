"""The view-angle sweep of ``dsm_bench.py --cases oblique_sets --view-angle-sweep``: how well one oblique pair
matches as the angle between its two views grows (the measure behind ``fotogeo.stereo.pairs.Limits.max_view_angle``).

Each case is a set of ``tests/dsm_oblique_sets.py`` with two frames converging on the area's centre
(``converge``), both at gimbal pitch ``p``, their headings ``Δψ`` apart: the angle between the optical axes is
``acos(sin² p + cos² p · cos Δψ)`` (pitch −55°: 20° at Δψ 35°, 70° at Δψ 180°). The pair is given with
``--pairs`` (the automatic limit does not decide) and ``fotogeo dsm`` runs as a user runs it (a child process
under ``/usr/bin/time -v``); the row has the pair's view angle, convergence angle and B/H from the report, its
completeness, RMSE and NMAD against the true surface and the share of cells within 1 GSD and beyond 3 GSD.
"""
from __future__ import annotations

import json
from pathlib import Path

#: (pitch °, heading difference °, seed) of the sweep's pairs
SWEEP = [(-55.0, d, 21) for d in (35, 50, 65, 90, 120, 150, 180)] + [(-45.0, d, 22) for d in (90, 120)] + \
        [(-70.0, d, 23) for d in (90, 180)]


def view_angle_sweep(tmp: Path, time_v, cases=SWEEP) -> list:
    """One row per case of ``cases`` (module docstring); ``time_v``: ``dsm_bench._time_v``."""
    import sys

    from dsm_oblique_sets import make_set
    from dsm_scenes import compare
    rows = []
    for k, (pitch, dh, seed) in enumerate(cases):
        sc = make_set({"strips": [(0.0, pitch, 1), (float(dh), pitch, 1)], "converge": True, "seed": seed},
                      tmp / f"sweep{k}")
        pairs, out, rep = tmp / f"sweep{k}.txt", tmp / f"sweep{k}.tif", tmp / f"sweep{k}.json"
        pairs.write_text(" ".join(sc["names"]) + "\n")
        row = {"case": f"oblique_sets view-angle sweep pitch {pitch:g}, headings {dh:g} apart, seed {seed}"}
        try:
            row.update(time_v([sys.executable, "-m", "fotogeo", "dsm", *map(str, sc["images"]), "--camera",
                               str(sc["camera"]), "--eo", str(sc["eo"]), "--crs", sc["crs"], "--pairs", str(pairs),
                               "-o", str(out), "--report", str(rep), "-q"], cwd=tmp))
        except SystemExit as e:  # a refusal: its last line is the row
            rows.append({**row, "refused": str(e).strip().splitlines()[-1]})
            continue
        r, c = json.loads(rep.read_text()), compare(out, sc["surface"])
        p = r["pairs"][0]
        rows.append({**row, "view_angle_deg": p["view_angle_deg"], "convergence_deg": p["convergence_deg"],
                     "base_to_height": p["base_to_height"], "completeness": r["completeness"],
                     "rmse_gsd": c["rmse"] / sc["gsd"], "nmad_m": c["nmad"], "median_m": c["median"],
                     "within_1gsd": float((c["abs"] <= sc["gsd"]).mean()),
                     "over_3gsd": float((c["abs"] > 3 * sc["gsd"]).mean()), "gsd_m": sc["gsd"]})
    return sorted(rows, key=lambda r: r.get("view_angle_deg", 999))
