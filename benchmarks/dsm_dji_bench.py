"""``fotogeo dsm`` on rendered DJI flights as users bring them (issue 30: "held-out DJI oblique frames with a known
orientation: NMAD ≤ 0.5 m against a DSM made from the whole flight").

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_dji_bench.py [--cases NAME,NAME] [--work DIR] [--whole-only]

Per flight (``tests/rendered_dji_flight.py``: real DJI sensors resized after capture, XMP at full size, hills with
flat-roofed buildings — a DEM with steps; sensors, patterns and terrain unlike ``dsm_bench.py``'s sets):

* ``whole, true`` — ``fotogeo dsm`` of every frame with the TRUE orientation written as ``--camera`` (brown, the
  rendered lens) and ``--eo`` files: the whole-flight DSM, its grid (``--bounds``, ``--resolution``) kept for the
  rest; against the true DEM.
* ``held-out, true`` — a held-out subset (3–4 oblique frames of one side) with the true orientation: NMAD and median
  of its heights − the whole-flight DSM's and − the true DEM's on the cells both have, and ``share_of_whole``: the
  share of the whole-flight DSM's cells that have a height here.
* ``held-out, triangulated`` — the same subset with the orientation ``fotogeo triangulate`` computes from the
  files alone (every frame of the flight, RTK GPS): ``--orientation OUT/``.

The true DEM is sampled at each DSM cell's centre (nearest 0.5 m DEM cell: the DEM is the renderer's surface).
NMAD = 1.4826 · median |d − median d| (Höhle & Höhle 2009). Every command runs as a user runs it, under
``/usr/bin/time -v`` (:func:`dsm_heldout_bench.time_v`): user + system CPU per row. Prints a table and writes
``benchmarks/results/dsm_dji_bench.json``.
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
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT / "tests")]
from dsm_heldout_bench import PY, _command, time_v  # noqa: E402
from rendered_converging import CRS, DEWARP  # noqa: E402
from rendered_dji_flight import dji_flight  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "dsm_dji_bench.json"
RES = 0.5
#: name -> (dji_flight keywords, the held-out frames)
CASES = {
    "ring-mavic-800-rtk": ({"pattern": "ring", "sensor": "mavic", "file_size": (800, 600), "seed": 31,
                            "relief": 8.0, "buildings": 5},
                           ["DJI_0100", "DJI_0101", "DJI_0102"]),
    "grid45-p4p-684-rtk": ({"pattern": "double-grid", "sensor": "p4p", "file_size": (684, 456), "seed": 32,
                            "relief": 4.0, "buildings": 4},
                           ["DJI_1000", "DJI_1001", "DJI_1002"]),
    # held out from the pair rule's change (s23): other pitches, sensor, spacing, seeds
    "grid35-mavic-800-rtk": ({"pattern": "double-grid", "sensor": "mavic", "file_size": (800, 600), "seed": 34,
                              "relief": 6.0, "buildings": 4, "grid": (55.0, 25.0)},
                             ["DJI_1000", "DJI_1001", "DJI_1002"]),
    "grid55-p4p-684-rtk": ({"pattern": "double-grid", "sensor": "p4p", "file_size": (684, 456), "seed": 35,
                            "relief": 5.0, "buildings": 5, "grid": (35.0, 22.0)},
                           ["DJI_1000", "DJI_1001", "DJI_1002"]),
    "ring45-only-p4p-684-towers-rtk": ({"pattern": "ring", "sensor": "p4p", "file_size": (684, 456), "seed": 33,
                                        "off_nadir": 45.0, "nadir": False, "relief": 10.0, "buildings": 6,
                                        "storeys": (15.0, 25.0)},
                                       ["DJI_0100", "DJI_0101", "DJI_0102", "DJI_0103"]),
}


def _truth_files(folder: Path, block: dict) -> tuple:
    """The true camera (brown: the rendered lens, :data:`rendered_converging.DEWARP`) and orientations as files."""
    from fotogeo.io.block import write_exterior_orientation, write_interior_orientation
    k1, k2, p1, p2, k3 = DEWARP
    cam, eo = folder / "true_camera.yaml", folder / "true_eo.txt"
    write_interior_orientation(cam, "dji", block["camera"], {"k1": k1, "k2": k2, "p1": p1, "p2": p2, "k3": k3})
    write_exterior_orientation(eo, block["names"], [block["truth"][n] for n in block["names"]])
    return cam, eo


def _stats(d: np.ndarray) -> dict:
    if not d.size:
        return {"median_m": None, "nmad_m": None}
    med = float(np.median(d))
    return {"median_m": round(med, 3), "nmad_m": round(float(1.4826 * np.median(np.abs(d - med))), 3)}


def _grid(path, ref=None) -> tuple:
    """Heights (nan where none) of ``path`` on ``ref``'s grid (its own without), the grid's cell centres."""
    import rasterio
    from rasterio.warp import Resampling, reproject
    with rasterio.open(ref or path) as r:
        t, shape, crs = r.transform, r.shape, r.crs
    with rasterio.open(path) as s:
        z = np.full(shape, np.nan, np.float32)
        reproject(rasterio.band(s, 1), z, dst_transform=t, dst_crs=crs, src_nodata=s.nodata, dst_nodata=np.nan,
                  resampling=Resampling.nearest)
    rr, cc = np.indices(shape)
    return z, (t.c + (cc + 0.5) * t.a, t.f + (rr + 0.5) * t.e)


def _dem_at(dem, X, Y) -> np.ndarray:
    t = dem.transform
    c = np.floor((X - t.c) / t.a).astype(int)
    r = np.floor((Y - t.f) / t.e).astype(int)
    ok = (c >= 0) & (c < dem.data.shape[1]) & (r >= 0) & (r < dem.data.shape[0])
    out = np.full(X.shape, np.nan)
    out[ok] = dem.data[r[ok], c[ok]]
    return out


def compare(path, whole, dem) -> dict:
    """``path`` against the true DEM and (``whole`` given) the whole-flight DSM, on the whole-flight grid."""
    z, (X, Y) = _grid(path, whole)
    truth = _dem_at(dem, X, Y)
    has = np.isfinite(z)
    out = {"cells": int(has.sum()), "vs_dem": _stats((z - truth)[has & np.isfinite(truth)].astype(np.float64))}
    out["vs_dem"]["within_1m"] = round(float(np.mean(np.abs(z - truth)[has & np.isfinite(truth)] <= 1.0)), 3) \
        if has.any() else None
    if whole is not None and Path(path) != Path(whole):
        z0, _ = _grid(whole)
        both = has & np.isfinite(z0)
        out["vs_whole"] = _stats((z - z0)[both].astype(np.float64))
        out["share_of_whole"] = round(float(both.sum() / max(np.isfinite(z0).sum(), 1)), 3)
    return out


def _dsm(folder: Path, tag: str, frames: list, orientation: list, bounds=None) -> tuple:
    out = folder / f"dsm_{tag}.tif"
    cmd = PY + ["dsm", *frames, *orientation, "--crs", CRS, "--resolution", str(RES), "-o", out, "--overwrite",
                "--report", folder / f"report_{tag}.json"]
    if bounds:
        cmd += ["--bounds", ",".join(f"{v:.3f}" for v in bounds)]
    return out, cmd, time_v(cmd, folder)


def _pairs(cmd: list) -> dict:
    """The pairs the DSM kept (its ``--report``) and the report's completeness."""
    rep = json.loads(Path(cmd[cmd.index("--report") + 1]).read_text())
    return {"pairs_kept": [p["images"] for p in rep.get("pairs", []) if p.get("kept")],
            "report_completeness": rep.get("completeness")}


def run_case(name: str, work: Path, whole_only: bool = False) -> list:
    import rasterio
    spec, held = CASES[name]
    folder = work / name
    block = dji_flight(folder / "img", **spec)
    cam, eo = _truth_files(folder, block)
    frames = {n: p for n, p in zip(block["names"], block["frames"])}
    rows = []

    def row(case, out, cmd, r, whole):
        rows.append({"flight": name, "case": case, "frames": sum(str(c).endswith(".JPG") for c in cmd), **r,
                     **(compare(out, whole, block["dem"]) | _pairs(cmd) if r["exit"] == 0 else {}),
                     "command": _command(cmd, folder)})
        print(json.dumps(rows[-1]), flush=True)

    whole, cmd, r = _dsm(folder, "whole_true", list(frames.values()), ["--camera", cam, "--eo", eo])
    row("whole flight, true orientation", whole, cmd, r, None)
    if r["exit"] or whole_only:
        return rows
    with rasterio.open(whole) as ds:
        bounds = tuple(ds.bounds)
    sub = [frames[n] for n in held]
    out, cmd, r = _dsm(folder, "heldout_true", sub, ["--camera", cam, "--eo", eo], bounds)
    row(f"held-out {len(held)} ({', '.join(held)}), true orientation", out, cmd, r, whole)
    ori = folder / "triangulated"
    tri = PY + ["triangulate", *frames.values(), "-o", ori, "--overwrite"]
    r = time_v(tri, folder)
    rows.append({"flight": name, "case": "triangulate the whole flight (files alone)", "frames": len(frames), **r,
                 "command": _command(tri, folder)})
    print(json.dumps(rows[-1]), flush=True)
    if r["exit"] == 0:
        out, cmd, r = _dsm(folder, "heldout_tri", sub, ["--orientation", ori], bounds)
        row(f"held-out {len(held)}, triangulated orientation", out, cmd, r, whole)
    return rows


def _save(rows: list, load0: float) -> None:
    old = json.loads(OUT.read_text()) if OUT.is_file() else {"rows": []}
    stamp = {"load_average": round(load0, 1), "date": time.strftime("%Y-%m-%d")}
    new = {(r["flight"], r["case"]) for r in rows}
    kept = [r for r in old["rows"] if (r["flight"], r["case"]) not in new]
    OUT.write_text(json.dumps({"rows": kept + [{**r, **stamp} for r in rows]}, indent=1, ensure_ascii=False))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", help="comma-separated names of " + ", ".join(CASES))
    ap.add_argument("--work", default="/tmp/dsm_dji_bench", help="renders and DSMs go here")
    ap.add_argument("--whole-only", action="store_true", help="the whole flight's DSM only (no held-out rows)")
    a = ap.parse_args(argv)
    load0, rows = os.getloadavg()[0], []
    for name in (a.cases.split(",") if a.cases else CASES):
        rows += run_case(name, Path(a.work).resolve(), a.whole_only)
        _save(rows, load0)
    head = ("flight", "case", "exit", "cpu_s", "pairs_kept")
    for r in rows:
        print(" | ".join(str(r.get(k, "")) for k in head), "| vs whole", r.get("vs_whole"), "| vs DEM",
              r.get("vs_dem"), "| share", r.get("share_of_whole"), r.get("message", ""))


if __name__ == "__main__":
    main()
