"""``fotogeo dsm`` when pairs are refused after the pair choice (:mod:`fotogeo.tools.dsm.refill`).

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_refill_bench.py [--cases "NAME;NAME"] [--work DIR] [--tree OTHER]

Cases (:data:`CASES`):

* a rendered block of ``tests/dsm_scenes.py`` (``nadir``, ``held_out``) with the true orientation except one frame's
  κ turned by 1°: its pairs pass the pair choice (the footprints barely move) and are refused when set up (their
  sparse matches lie px off the epipolar lines), so their partners lose the slot the per-image cap gave those pairs;
  against the true surface at the DSM's cell centres;
* the whole ``dsm_dji_bench.py`` flight ``grid45-p4p-684-rtk`` (true orientation, ``--resolution 0.5``) with the
  automatic pair choice's view-angle limit at 65° (set in the child, ``dsm_bench_run.set_limits``): crossing-line
  pairs are admitted and some refused by the sparse check; against the true DEM (its 0.5 m cell at each DSM cell).

``fotogeo dsm`` runs as a user runs it (a child process under ``/usr/bin/time -v``: user + system CPU), no DEM. Per
case: pairs kept and refused when set up, the pairs chosen after a refusal (the report's ``replaces``), RMSE, NMAD
and median of DSM − truth at the valid cells, the valid cells, the report's completeness. ``--tree DIR``: the same
with another checkout's ``fotogeo`` (e.g. the base commit: ``git archive BASE | tar -x -C DIR``). Prints a row per
case and appends them to ``benchmarks/results/dsm_refill_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT / "tests"), str(ROOT)]
import dsm_heldout_bench  # noqa: E402
import numpy as np  # noqa: E402
from dsm_scenes import compare, make_scene, turned_eo  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "dsm_refill_bench.json"
#: name -> (scene, the frame whose κ is turned, by how many degrees), or (a ``dsm_dji_bench`` flight, the automatic
#: pair choice's limits: :func:`dsm_bench_run.set_limits`)
CASES = {"nadir, s1_02 κ +1°": ("nadir", "s1_02", 1.0),
         "held_out, s2_02 κ +1°": ("held_out", "s2_02", 1.0),
         "grid45-p4p-684-rtk, view-angle limit 65°": ("grid45-p4p-684-rtk", {"max_view_angle": 65.0})}


def _dji(folder: Path, flight: str, limits: dict) -> tuple:
    """The whole ``dsm_dji_bench`` flight with its true orientation and the pair choice's ``limits``: ``(command,
    DSM, its comparison with the true DEM (RMSE, NMAD, median))``."""
    import dsm_bench_run
    import dsm_dji_bench
    from rendered_dji_flight import dji_flight
    block = dji_flight(folder / "img", **dsm_dji_bench.CASES[flight][0])
    cam, eo = dsm_dji_bench._truth_files(folder, block)
    out = folder / "dsm.tif"
    cmd = [*dsm_bench_run.python(limits), "dsm", *map(str, block["frames"]), "--camera", str(cam), "--eo", str(eo),
           "--crs", dsm_dji_bench.CRS, "--resolution", str(dsm_dji_bench.RES), "-o", str(out)]

    def against(path):
        z, (X, Y) = dsm_dji_bench._grid(path)
        d = (z - dsm_dji_bench._dem_at(block["dem"], X, Y))
        d = d[np.isfinite(d)].astype(float)
        med = float(np.median(d))
        return {"n": int(d.size), "rmse": float(np.sqrt(np.mean(d ** 2))), "median": med,
                "nmad": float(1.4826 * np.median(np.abs(d - med)))}
    return cmd, out, against


def _scene(folder: Path, scene: str, name: str, dk: float) -> tuple:
    """The rendered ``scene`` with frame ``name``'s κ turned by ``dk`` degrees: ``(command, DSM, comparison)``."""
    sc = make_scene(scene, folder / "scene")
    eo = turned_eo(Path(sc["eo"]), name, dk, folder / "eo_turned.txt")
    out = folder / "dsm.tif"
    cmd = [*dsm_heldout_bench.PY, "dsm", *map(str, sc["images"]), "--camera", str(sc["camera"]), "--eo", str(eo),
           "--crs", sc["crs"], "-o", str(out)]
    return cmd, out, lambda path: compare(path, sc["surface"])


def run_case(label: str, work: Path) -> dict:
    folder = work / label.replace(" ", "_").replace(",", "").replace("°", "deg").replace("κ", "kappa")
    cmd, out, against = (_dji if len(CASES[label]) == 2 else _scene)(folder, *CASES[label])
    rep = folder / "report.json"
    cmd += ["--report", str(rep), "--overwrite"]
    t = dsm_heldout_bench.time_v(cmd, folder)
    row = {"case": label, **t, "tree": str(dsm_heldout_bench.TREE), "command": dsm_heldout_bench._command(cmd, folder)}
    if t["exit"]:
        return row
    r = json.loads(rep.read_text())
    c = against(out)
    row.update(pairs_kept=r["pairs_kept"],
               refused=["-".join(p["images"]) for p in r["pairs"] if not p["kept"] and "sparse_matches" in p],
               replacements={"-".join(p["images"]): p["replaces"] for p in r["pairs"] if "replaces" in p},
               rmse_m=round(c["rmse"], 3), nmad_m=round(c["nmad"], 3), median_m=round(c["median"], 3),
               valid_cells=c["n"], completeness=r["completeness"])
    return row


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", help="names of CASES separated by ';': " + "; ".join(CASES))
    ap.add_argument("--work", default="/tmp/dsm_refill_bench", help="renders and DSMs go here")
    ap.add_argument("--tree", default=str(ROOT), help="the fotogeo checkout measured (its rows carry its path)")
    a = ap.parse_args(argv)
    wrong = [c for c in (a.cases.split(";") if a.cases else []) if c not in CASES]
    if wrong:
        ap.error(f"--cases: no case {wrong[0]!r}; give names separated by ';' from: " + "; ".join(CASES))
    dsm_heldout_bench.TREE = Path(a.tree).resolve()
    import os
    rows = []
    for label in (a.cases.split(";") if a.cases else CASES):
        row = run_case(label, Path(a.work))
        rows.append(row)
        print(json.dumps({k: v for k, v in row.items() if k != "command"}), flush=True)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(OUT.read_text()) if OUT.exists() else []
    OUT.write_text(json.dumps(old + [{"time": time.strftime("%Y-%m-%d %H:%M"), "load": os.getloadavg(),
                                      "rows": rows}], indent=1, ensure_ascii=False) + "\n")


if __name__ == "__main__":
    main()
