"""Rendered oblique blocks whose reference orthophoto is blanked under one frame: frames left level (issue 32).

A frame whose attitude is unknown and that does not register to the reference starts level; the triangulation
measures its attitude from its ties and gives its pairs a second, ground-plane matching pass
(:func:`fotogeo.tools.triangulate.guided.measured_attitudes`). Each case renders the oblique block of
``tests/rendered_oblique.py`` (4 strips flown N/E/S/W, gimbal −60°, ``--per-strip`` frames each; the images
without attitude tags), zeroes the reference orthophoto under the true footprint of the named frame (``A+B``: of
both frames; ``-``: the full reference) and runs ``fotogeo triangulate FRAMES --reference ORTHO --dem DEM -o OUT -q``
as a user runs it,
under ``/usr/bin/time -v``, with ``PYTHONPATH`` the tree measured (this checkout, and ``--baseline-tree`` in the
same run). ``--frames 12`` renders 3 frames per strip instead (``--per-strip``), ``--seeds 0-5`` a range of
seeds, ``--tags`` runs the copies with the gimbal angles in their XMP instead of those without. Per run: frames
oriented, the frames started level, the dropped frames, tie inliers, the worst angle (°) and centre (m) errors
against the rendered truth, CPU = user + system, and a hash of the orientation file (the same orientations in both
trees: the same hash). Printed as lines and merged into ``benchmarks/results/level_frame_bench.json`` (a row
measured again replaces the row of the same seed, frames, zeroed frame, tags and tree).

    PYTHONPATH=. .venv/bin/python benchmarks/level_frame_bench.py --seeds 0 --per-strip 5 --zero DJI_303,DJI_202 \\
        [--baseline-tree ../main] [--work DIR]
    PYTHONPATH=. .venv/bin/python benchmarks/level_frame_bench.py --frames 12 --seeds 0-5 --zero - [--tags]
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def _block(work: Path, seed: int, per: int, zero: str, block=None):
    """The rendered block (images, truth; ``block`` if given), the reference orthophoto (zeroed under ``zero``)
    and DEM."""
    import rasterio
    from rasterio.features import geometry_mask
    from rendered_oblique import GROUND, SIZE, oblique_block, write_reference
    from shapely.geometry import Polygon

    from fotogeo.geometry.camera import OrientedFrame
    root = work / f"s{seed}_p{per}"
    if block is None:
        block = oblique_block(root, seed=seed, per_strip=per)
        write_reference(block, root / "ref")
    ortho = root / "ref" / "ortho.tif"
    if zero != "-":
        w, h = SIZE
        corners = np.array([[0, 0], [w, 0], [w, h], [0, h]], float)
        gs = [OrientedFrame(block["camera"], block["truth"][z]).pixel_to_world_at(corners, GROUND)
              for z in zero.split("+")]
        with rasterio.open(ortho) as ds:
            img, prof = ds.read(), ds.profile
            m = geometry_mask([Polygon(g[:, :2]) for g in gs], out_shape=img.shape[1:], transform=ds.transform,
                              invert=True)
        img[:, m] = 0
        ortho = root / f"ref_zero_{zero}.tif"
        with rasterio.open(ortho, "w", **prof) as ds:
            ds.write(img)
    return block, ortho, root / "ref" / "dem.tif"


def _run(tree: Path, block, ortho: Path, dem: Path, out: Path, tags: bool = False) -> dict:
    from rendered_oblique import angle_error

    from fotogeo.io.camera import read_exterior_orientation
    shutil.rmtree(out, ignore_errors=True)
    frames = block["gimbal" if tags else "nadir"]
    cmd = ["/usr/bin/time", "-v", sys.executable, "-m", "fotogeo", "triangulate", *map(str, frames),
           "--reference", str(ortho), "--dem", str(dem), "-o", str(out), "-q"]
    p = subprocess.run(cmd, env=dict(os.environ, PYTHONPATH=str(tree)), capture_output=True, text=True,
                       cwd=out.parent)  # not a checkout: `python -m` puts the working folder first on the path
    cpu = sum(float(line.split(":")[1]) for line in p.stderr.splitlines()
              if "User time" in line or "System time" in line)
    res = {"tree": str(tree), "rc": p.returncode, "cpu_s": round(cpu, 1)}
    eo_file = out / "exterior_orientation.txt"
    if not eo_file.exists():
        own = [ln for ln in p.stderr.split("\tCommand being timed:")[0].strip().splitlines()
               if not ln.startswith("Command exited with non-zero status")]  # before /usr/bin/time's lines
        return {**res, "error": own[-1:]}
    eos = read_exterior_orientation(eo_file)
    ang = {n: angle_error(e, block["truth"][n]) for n, e in eos.items()}
    cen = {n: float(np.linalg.norm(e.centre - block["truth"][n].centre)) for n, e in eos.items()}
    rep = json.loads((out / "report.json").read_text())
    res["eo_sha256"] = hashlib.sha256(eo_file.read_bytes()).hexdigest()[:16]
    return {**res, "oriented": len(eos), "of": len(block["names"]), "max_angle_deg": round(max(ang.values()), 4),
            "max_centre_m": round(max(cen.values()), 4), "level": rep.get("start", {}).get("level_start_frames"),
            "dropped": [d["name"] for d in rep.get("dropped_frames") or []],
            "tie_inliers": sum(q.get("inliers", 0) for q in rep.get("matching", {}).get("pairs", []))}


def _seeds(text: str) -> list:
    """``"0,2"`` -> [0, 2]; ``"0-5"`` -> [0, 1, 2, 3, 4, 5]."""
    out = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def _key(r: dict) -> tuple:
    """The row's identity in the results file: seed, frames per strip, zeroed frame, tags, tree."""
    return r["seed"], r["per_strip"], r["zeroed_under"], r.get("tags", False), r["tree"]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0", help="',' separated; a-b: a range")
    ap.add_argument("--per-strip", type=int, default=5)
    ap.add_argument("--frames", type=int, help="frames per block (4 strips): sets --per-strip to FRAMES / 4")
    ap.add_argument("--tags", action="store_true", help="the frames with gimbal angles in their XMP")
    ap.add_argument("--zero", default="DJI_303,DJI_202",
                    help="frames to blank the reference under, ',' separated cases; '+' joins frames blanked in one "
                         "case (DJI_202+DJI_303); '-' the full reference")
    ap.add_argument("--baseline-tree", type=Path, help="a second checkout measured in the same run")
    ap.add_argument("--work", type=Path, help="scratch folder (default: a temporary one)")
    a = ap.parse_args(argv)
    if a.frames:
        if a.frames % 4:
            ap.error(f"--frames must be a multiple of 4 (4 strips); got {a.frames}")
        a.per_strip = a.frames // 4
    work = a.work or Path(tempfile.mkdtemp(prefix="level_frame_bench_"))
    trees = [t for t in (a.baseline_tree, ROOT) if t]
    blocks = {}
    for seed in _seeds(a.seeds):
        for zero in a.zero.split(","):
            block, ortho, dem = blocks.get(seed) or _block(work, seed, a.per_strip, "-")
            blocks[seed] = block, ortho, dem
            if zero != "-":
                ortho = _block(work, seed, a.per_strip, zero, block)[1]
            for i, tree in enumerate(trees):
                r = {"seed": seed, "per_strip": a.per_strip, "zeroed_under": zero, "tags": a.tags,
                     **_run(tree, block, ortho, dem, work / f"out_{seed}_{zero}_{i}", a.tags)}
                print(json.dumps(r), flush=True)
                _save(r, {"command": " ".join(sys.argv), "load_average": os.getloadavg()})


def _save(row: dict, run: dict) -> None:
    """``row`` merged into the results file as soon as it is measured (a run stopped early keeps its rows)."""
    dest = ROOT / "benchmarks" / "results" / "level_frame_bench.json"
    saved = json.loads(dest.read_text()) if dest.is_file() else {}
    rows = [r for r in saved.get("rows", []) if _key(r) != _key(row)] + [{**row, "run": run}]
    dest.write_text(json.dumps({"rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
