"""Matching time of a 20-frame oblique block (tests/rendered_oblique.py: 4 strips x 5 frames flown N/E/S/W, gimbal
-60°) with and without ground-plane matching (:mod:`fotogeo.tools.triangulate.guided`).

Per seed: the pairs the footprints give, the seconds (wall and CPU: the machine may be shared) of the plain matching
(every pair, each frame detected once) and of the plain matching followed by the ground-plane stage, the pairs it
tried / used / skipped, and per frame the epipolar inliers summed over its pairs (plain; with the ground plane).
Printed and written to ``benchmarks/results/oblique_block_matching.json``. ``--whole`` times the whole triangulate
run instead (any checkout: main's against this one).

    PYTHONPATH=. .venv/bin/python benchmarks/oblique_block_matching_bench.py [--seeds 0 1] [--per-strip 5]
    PYTHONPATH=<checkout> .venv/bin/python benchmarks/oblique_block_matching_bench.py --whole  # the whole run
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from rendered_oblique import oblique_block  # noqa: E402

from fotogeo.io.raster import open_raster  # noqa: E402
from fotogeo.options import RegisterOptions  # noqa: E402
from fotogeo.progress import as_progress  # noqa: E402
from fotogeo.tools.triangulate.match import _pair_matches, overlapping_pairs  # noqa: E402
from fotogeo.tools.triangulate.sources import block_start  # noqa: E402
from fotogeo.tools.triangulate.start import provisional_height  # noqa: E402

OUT = Path(__file__).resolve().parent / "results" / "oblique_block_matching.json"


def per_frame(names, per_pair):
    sums = {n: 0 for n in names}
    for row in per_pair:
        for f in row["pair"]:
            sums[names[f]] += row["inliers"]
    return sums


def one(seed: int, per_strip: int, tmp: Path) -> dict:
    block = oblique_block(tmp / f"b{seed}_{per_strip}", seed=seed, per_strip=per_strip)
    frames = block["gimbal"]
    st = block_start(frames, None, None, None, None, None, None, None, None, "auto")
    eos = tuple(st.eos[n] for n in st.names)
    h0 = provisional_height(eos, st.camera)
    pairs = overlapping_pairs(st.camera, eos, h0)
    infos = [open_raster(f, "frame") for f in frames]
    out = {"seed": seed, "frames": len(frames), "pairs": len(pairs)}
    for method, guide in (("plain", None), ("guided", (eos, h0))):
        t, cpu = time.perf_counter(), time.process_time()
        _, _, per_pair, _, measured = _pair_matches(infos, pairs, RegisterOptions(), 1, 1.0, as_progress(None),
                                                    st.camera, st.distortion, None, guide=guide)
        out[f"{method}_s"] = round(time.perf_counter() - t, 2)
        out[f"{method}_cpu_s"] = round(time.process_time() - cpu, 2)
        out[f"{method}_per_frame"] = per_frame(st.names, per_pair)
        if guide is not None:
            considered = [r for r in per_pair if "guided" in r]
            tried = [r for r in considered if "skipped" not in r["guided"]]
            out["tried"], out["skipped"] = len(tried), len(considered) - len(tried)
            out["used"] = sum(r["guided"]["used"] for r in tried)
            out["height_m"] = measured
    return out


def whole_run(seed: int, per_strip: int, tmp: Path) -> dict:
    """``fotogeo.triangulate`` on the block's files (gimbal angles in the XMP): wall and CPU seconds, the frames
    kept and the worst frame's angle error (°) once the block's one rotation is removed; runs on any checkout
    (``PYTHONPATH=<checkout>``), to compare one branch with another."""
    import numpy as np
    from fotogeo.errors import FotogeoError
    from fotogeo.io.camera import read_exterior_orientation
    from fotogeo.tools.triangulate import triangulate
    from test_triangulate_oblique import _inner_errors
    block = oblique_block(tmp / f"w{seed}_{per_strip}", seed=seed, per_strip=per_strip)
    t, cpu = time.perf_counter(), time.process_time()
    try:
        rep = triangulate(block["gimbal"], None, None, None, tmp / f"out{seed}_{per_strip}")
    except FotogeoError as e:
        return {"seed": seed, "exit": str(e)[:200]}
    out = {"seed": seed, "exit": "ok", "wall_s": round(time.perf_counter() - t, 1),
           "cpu_s": round(time.process_time() - cpu, 1)}
    adj = read_exterior_orientation(tmp / f"out{seed}_{per_strip}" / "exterior_orientation.txt")
    inner = _inner_errors(block, adj)
    out.update(frames=len(adj), worst_inner_deg=round(float(np.max(list(inner.values()))), 3),
               stages_s=rep.get("timings_s") if isinstance(rep, dict) else None)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--per-strip", type=int, default=5)
    ap.add_argument("--whole", action="store_true", help="time the whole triangulate run instead (any checkout)")
    args = ap.parse_args(argv)
    rows = []
    if args.whole:
        with tempfile.TemporaryDirectory() as tmp:
            for seed in args.seeds:
                print(whole_run(seed, args.per_strip, Path(tmp)), flush=True)
        return
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            r = one(seed, args.per_strip, Path(tmp))
            rows.append(r)
            low = min(r["guided_per_frame"].items(), key=lambda kv: kv[1])
            print(f"seed {seed}: {r['frames']} frames, {r['pairs']} pairs | plain {r['plain_s']:.1f} s "
                  f"(CPU {r['plain_cpu_s']:.1f} s) | plain + ground plane {r['guided_s']:.1f} s (CPU "
                  f"{r['guided_cpu_s']:.1f} s), {r['tried']} tried, {r['used']} used, {r['skipped']} skipped | "
                  f"weakest frame {low[0]} {low[1]} inliers (plain {r['plain_per_frame'][low[0]]})", flush=True)
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps({"runs": rows}, indent=1))
    print(f"written {OUT}")


if __name__ == "__main__":
    main()
