"""An EXIF FocalLength edited inside the lens's zoom range: `fotogeo triangulate` on eBee copies with the tag rewritten.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/focal_edit_bench.py [--work /tmp/focal_edit_bench] [--tree T]
      [--scales 0.25] [--focals 0 5 6 8.6 12] [--frames all strip] [--free]

The 8 eBee frames of ``drone_snowpeak`` (Canon IXUS 125 HS at 4.3 mm; its maker note gives the lens's 4.3–21.5 mm
and no focal record, :mod:`fotogeo.io.exif_lens`) are copied at ``--scales`` (OpenCV INTER_AREA, both APP1 segments
kept: ``tests/jpeg_metadata.resized_copy``; 1 keeps the file) with EXIF ``FocalLength`` set to each of ``--focals``
mm (0: unedited; ``jpeg_metadata.set_exif_tags``), and triangulated from their files (``fotogeo triangulate *.JPG -o
out``): all 8 frames (the turn pair 2212/2213 is dropped as undetermined) or the strip IMG_2280–2282. Each row keeps
the exit code, the refusal's first 300 characters (and the estimate of f it names, from a second, untimed
run), the focal length used, the self-calibration's estimate of f and
its σ when the correlation rule held f fixed (report ``fixed_parameters``), and the largest distance of an adjusted
centre from its GPS position. ``--free`` also runs each set with ``--self-calibration f,k1,k2,p1,p2
--max-correlation 1`` (f kept free whatever its correlation). Rows go to ``benchmarks/results/focal_edit_bench.json``
(CPU s = user + sys of the run).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import dsm_heldout_bench as hb  # noqa: E402

OUT = hb.ROOT / "benchmarks" / "results" / "focal_edit_bench.json"
FRAMES = {"all": hb.EBEE, "strip": ["IMG_2280", "IMG_2281", "IMG_2282"]}
FREE = ["--self-calibration", "f,k1,k2,p1,p2", "--max-correlation", "1"]


def _copies(folder: Path, scale: float, focal: float) -> list:
    import shutil
    import jpeg_metadata as jm
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for n in hb.EBEE:
        src, dst = hb.DATA / "drone_snowpeak" / "img" / f"{n}.JPG", folder / f"{n}.JPG"
        if not dst.exists():
            (shutil.copy(src, dst) if scale == 1 else jm.resized_copy(src, dst, 1 / scale))
            if focal:
                jm.set_exif_tags(dst, {0x920A: focal})
        out.append(dst)
    return out


def _row(images: list, out: Path, extra: list) -> dict:
    cmd = hb.PY + ["triangulate", *images, "-o", out, "--overwrite", "-q", *extra]
    row = {**hb.time_v(cmd, out.parent), "command": hb._command(cmd, out.parent)}
    if row["exit"] != 0:
        err = subprocess.run(list(map(str, cmd)), capture_output=True, text=True, cwd=out.parent,
                             env=dict(os.environ, PYTHONPATH=str(hb.TREE))).stderr  # the refusal whole (untimed)
        said = re.search(r"free the adjustment puts it at ([\d.]+) ± ([\d.]+) px", err)
        if said:
            row["f_free_estimate_px"], row["f_free_sigma_px"] = float(said.group(1)), float(said.group(2))
        return row
    sys.path.insert(0, str(hb.TREE))
    from fotogeo.io.camera import read_exterior_orientation
    from fotogeo.io.exif_block import read_exif_block
    rep = json.loads((out / "report.json").read_text())
    row["focal_px"] = round(rep["camera"]["focal_length"], 2)
    row["focal_sigma_px"] = (rep["camera"].get("sigma") or {}).get("f")
    held = next((f for f in rep["fixed_parameters"] if f["parameter"] == "f"), None)
    if held:
        row["f_held_estimate_px"] = round(held.get("estimate", np.nan), 2)
        row["f_held_sigma_px"] = round(held["sigma"], 2)
    gps = read_exif_block(images).shots
    eo = read_exterior_orientation(out / "exterior_orientation.txt")
    row["max_centre_from_gps_m"] = round(max(float(np.linalg.norm(np.array([e.X, e.Y, e.Z]) - gps[n].position))
                                             for n, e in eo.items()), 2)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="/tmp/focal_edit_bench", help="copies and runs go here (reused)")
    ap.add_argument("--tree", default=str(hb.ROOT), help="the fotogeo checkout measured")
    ap.add_argument("--scales", nargs="+", type=float, default=[0.25])
    ap.add_argument("--focals", nargs="+", type=float, default=[0, 5.0, 6.0, 8.6, 12.0])
    ap.add_argument("--frames", nargs="+", choices=list(FRAMES), default=list(FRAMES))
    ap.add_argument("--free", action="store_true", help="also run with f kept free")
    ap.add_argument("--out", default=str(OUT))
    a = ap.parse_args()
    hb.TREE = Path(a.tree).resolve()
    rows = []
    for scale in a.scales:
        for focal in a.focals:
            folder = Path(a.work).resolve() / f"s{scale:g}_f{focal:g}"
            images = _copies(folder, scale, focal)
            for group in a.frames:
                used = [p for p in images if p.stem in FRAMES[group]]
                for mode, extra in [("default", [])] + ([("f free", FREE)] if a.free else []):
                    row = {"scale": scale, "focal_mm": focal or 4.3, "edited": bool(focal), "frames": group,
                           "mode": mode, **_row(used, folder / f"out_{group}_{mode.replace(' ', '_')}", extra)}
                    rows.append(row)
                    print(row, flush=True)
    stamp = {"load_average": round(os.getloadavg()[0], 1), **({} if hb.TREE == hb.ROOT else {"tree": str(hb.TREE)})}
    Path(a.out).write_text(json.dumps({"rows": [{**r, **stamp} for r in rows]}, indent=1, ensure_ascii=False))


if __name__ == "__main__":
    main()
