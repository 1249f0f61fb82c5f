"""DJI flights unlike the four-frame converging sets the ground-plane matching was built on, triangulated from their
own files: real sensor sizes resized after capture, rings of obliques with a nadir grid, a double grid at −45°,
hills with buildings, GPS with and without RTK (``tests/rendered_dji_flight.py``; issues 30 and 32).

Per case ``fotogeo.triangulate FRAMES -o OUT`` (no camera, no orientation file, no DEM, no control): exit or the
refusal, frames oriented, the camera read from the XMP against the true one (focal and principal point in the
files' pixels), and per frame the centre error (m) and the angle error (°) against the truth — the worst
frame and the median. With GPS that is not RTK the block's datum follows the GPS (its common offset is not
observable from the images): the errors are then also given after a 7-parameter similarity (Helmert) fit of the
adjusted centres onto the true ones, its rotation applied to the attitudes — the relative error, stated as such.
CPU = user + sys of this process and its children over the run (rendering not counted).

Printed as a table and written to ``benchmarks/results/oblique_heldout_bench.json``.

    PYTHONPATH=. .venv/bin/python benchmarks/oblique_heldout_bench.py [--cases NAME,NAME] [--quick]
"""
from __future__ import annotations

import argparse
import json
import resource
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from rendered_dji_flight import dji_flight, errors  # noqa: E402

from fotogeo.errors import FotogeoError  # noqa: E402
from fotogeo.io.camera import read_exterior_orientation  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
NON_RTK = {"rtk": False, "gps_sigma": 3.0, "gps_offset": (1.5, -2.0, 4.0)}
#: name -> keyword arguments of :func:`rendered_dji_flight.dji_flight`
CASES = {
    "ring-p4p-1368-rtk": {"pattern": "ring", "file_size": (1368, 912)},
    "ring-p4p-912-rtk": {"pattern": "ring", "file_size": (912, 608), "seed": 1},
    "ring-p4p-912-gps": {"pattern": "ring", "file_size": (912, 608), "seed": 2, **NON_RTK},
    "ring-mavic-1000-rtk-yaw8": {"pattern": "ring", "sensor": "mavic", "file_size": (1000, 750), "seed": 3,
                                 "yaw_sigma": 8.0},
    "ring-p4p-912-ngi-rtk": {"pattern": "ring", "file_size": (912, 608), "seed": 4, "kind": "ngi", "relief": 8.0},
    "grid45-p4p-912-rtk": {"pattern": "double-grid", "file_size": (912, 608), "seed": 5},
    "grid45-mavic-1000-gps": {"pattern": "double-grid", "sensor": "mavic", "file_size": (1000, 750), "seed": 6,
                              **NON_RTK},
    "ring45-only-p4p-912-towers-rtk": {"pattern": "ring", "file_size": (912, 608), "seed": 7, "off_nadir": 45.0,
                                       "nadir": False, "relief": 10.0, "buildings": 6, "storeys": (15.0, 25.0)},
    "ring-p4p-912-gps5-z40": {"pattern": "ring", "file_size": (912, 608), "seed": 8, "rtk": False, "gps_sigma": 5.0,
                              "gps_offset": (2.0, -3.0, 40.0)},
    "ring45-4views-p4p-912-towers-gps": {"pattern": "ring", "file_size": (912, 608), "seed": 12, "off_nadir": 45.0,
                                         "nadir": False, "views": 4, "relief": 10.0, "buildings": 6,
                                         "storeys": (15.0, 25.0), **NON_RTK},
    "ring45-4views-p4p-456-towers-rtk": {"pattern": "ring", "file_size": (456, 304), "seed": 13, "off_nadir": 45.0,
                                         "nadir": False, "views": 4, "relief": 10.0, "buildings": 6,
                                         "storeys": (15.0, 25.0)},
    "ring-p4p-912-noxmp": {"pattern": "ring", "file_size": (912, 608), "seed": 9, "xmp": False, **NON_RTK},
}
QUICK = ("ring-p4p-912-rtk", "grid45-p4p-912-rtk")


def _cpu() -> float:
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def run_case(name: str, spec: dict, tmp: Path) -> dict:
    from fotogeo.tools.triangulate import triangulate
    block = dji_flight(tmp / name, **spec)
    out = tmp / f"out_{name}"
    row = {"case": name, "spec": {k: list(v) if isinstance(v, tuple) else v for k, v in spec.items()},
           "frames": len(block["frames"])}
    cpu = _cpu()
    try:
        rep = triangulate(block["frames"], None, None, None, out)
    except FotogeoError as e:
        row["exit"] = str(e)[:300]
    else:
        row["exit"] = "ok"
        row["sigma0"] = rep.get("sigma0")
    row["cpu_s"] = round(_cpu() - cpu, 1)
    report = out / "report.json"
    if report.exists():
        rep = json.loads(report.read_text())
        pairs = rep.get("matching", {}).get("pairs") or []
        cam = rep.get("camera") or {}
        if cam.get("focal_length"):  # the camera read from the XMP, scaled to the files' size, vs the true one
            true = block["camera"]
            row["focal_px"] = [cam["focal_length"], true.focal_length]
            row["principal_point_px"] = [cam["principal_point"], list(true.principal_point)]
        row["pairs"] = len(pairs)
        row["pairs_guided_used"] = sum(bool((p.get("guided") or {}).get("used")) for p in pairs)
    if row["exit"] == "ok":
        adj = read_exterior_orientation(out / "exterior_orientation.txt")
        row["oriented"] = len(adj)
        row["absolute"] = errors(adj, block["truth"], fit=False)
        if not spec.get("rtk", True):
            row["after_7_parameter_fit"] = errors(adj, block["truth"], fit=True)
    return row


def print_row(r: dict) -> None:
    if r["exit"] != "ok":
        print(f"{r['case']:26s} {r['frames']:2d} frames  REFUSED  {r['exit']}  cpu {r['cpu_s']} s", flush=True)
        return
    e = r.get("after_7_parameter_fit") or r["absolute"]
    kind = "7-par" if "after_7_parameter_fit" in r else "abs  "
    print(f"{r['case']:26s} {r['oriented']:2d}/{r['frames']:2d} oriented  {kind} centre max {e['centre_max_m']:.3f} "
          f"med {e['centre_median_m']:.3f} m  angle max {e['angle_max_deg']:.3f} med {e['angle_median_deg']:.3f}°  "
          f"(abs centre max {r['absolute']['centre_max_m']:.2f} m)  guided pairs {r.get('pairs_guided_used')}/"
          f"{r.get('pairs')}  cpu {r['cpu_s']} s", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", help="comma-separated names of " + ", ".join(CASES))
    ap.add_argument("--quick", action="store_true", help="only " + ", ".join(QUICK))
    ap.add_argument("--out", help="results JSON (default benchmarks/results/oblique_heldout_bench.json)")
    args = ap.parse_args(argv)
    names = args.cases.split(",") if args.cases else (QUICK if args.quick else list(CASES))
    rows = []
    out = Path(args.out) if args.out else RESULTS / "oblique_heldout_bench.json"
    out.parent.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            rows.append(run_case(name, CASES[name], Path(tmp)))
            print_row(rows[-1])
            out.write_text(json.dumps({"cases": rows}, indent=1))  # after each case: a long run keeps what it measured
    print(f"written {out}")


if __name__ == "__main__":
    main()
