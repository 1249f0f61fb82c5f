"""The DEFLATE step of ``fotogeo ortho``: CPU time and size of each level and predictor beside orthority's file.

Run:  .venv/bin/python benchmarks/ortho_deflate_bench.py --orthority-python VENV/bin/python [--cases ngi,ngi_u16]
      [--levels 1,2,3,6,9] [--repeat 3] [--out JSON]

Each case (``ortho_bench.py``'s: the two NGI frames, or with one thing changed, ``ortho_bench_inputs.ngi_variant``)
runs ``fotogeo ortho`` at its defaults and orthority's ``oty frame … -cm deflate -nwm`` once (the commands of
``ortho_bench.py``; 5 m). Each fotogeo orthophoto is then written again (beside it) as ``ortho`` writes
it — 256² tiles, average overviews inside the file (:func:`fotogeo.io.warp.add_overviews`) — at every DEFLATE level
of ``--levels`` with the horizontal predictor (2) and without (1), and once in orthority's layout (512² tiles,
level 6, no predictor). Per choice: the writing's CPU time (user + system of this process, GDAL on one thread: the
compressing work, not its spread over threads; the least of ``--repeat``), the file's MB and its size over
orthority's file of the same frame (below 1: smaller). Writes ``benchmarks/results/ortho_deflate.json`` (or
``--out``) with the load average and prints a table.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ortho_bench import FOTOGEO_ENV, FOTOGEO_RUN, ORTHORITY_RUN, ROOT
from ortho_bench_inputs import ngi_inputs, ngi_variant

OUT = ROOT / "benchmarks" / "results" / "ortho_deflate.json"


def run_both(work: Path, inp: dict, oty_py: str) -> tuple[Path, Path]:
    """fotogeo's and orthority's output folders of one run each on ``inp``'s frames (5 m, bilinear)."""
    fg, oty = work / "fotogeo", work / "orthority"
    fg.mkdir()
    oty.mkdir()
    subprocess.run([sys.executable, "-c", FOTOGEO_RUN, "ortho", *inp["frames"], "-o", str(fg), "--dem", inp["dem"],
                    "--camera", inp["camera"], "--eo", inp["eo"], "--resolution", "5", "--resampling", "bilinear",
                    "-q", *inp.get("fotogeo_args", [])], check=True, env={**os.environ, **FOTOGEO_ENV},
                   cwd=work, stdout=subprocess.DEVNULL)
    subprocess.run([oty_py, "-c", ORTHORITY_RUN, "frame", "-d", inp["dem"], "-ip", inp["camera"], "-ep", inp["ext"],
                    *inp["crs"], "-r", "5", "-ap", "-i", "bilinear", "-di", "bilinear", "-cm", "deflate", "-nwm",
                    "-od", str(oty), "-o", *inp["frames"]], check=True, cwd=work, stdout=subprocess.DEVNULL)
    return fg, oty


def rewrite(data, profile: dict, path: Path, repeat: int, **options) -> dict:
    """CPU seconds (least of ``repeat``) and MB of ``data`` written to ``path`` with ``profile`` updated by
    ``options``, average overviews inside."""
    import rasterio

    from fotogeo.io.warp import add_overviews
    best = float("inf")
    for _ in range(repeat):
        with rasterio.Env(GDAL_NUM_THREADS="1", GDAL_CACHEMAX=256 * 2 ** 20):
            t = time.process_time()
            with rasterio.open(path, "w", **{**profile, **options}) as dst:
                dst.write(data)
                add_overviews(dst, dst.width, dst.height, "bilinear")
            best = min(best, time.process_time() - t)
    size = path.stat().st_size
    path.unlink()
    return {"cpu_s": round(best, 4), "mb": round(size / 1e6, 4)}


def frame_rows(fotogeo_tif: Path, orthority_tif: Path, levels, repeat: int) -> dict:
    """The choices' CPU time, MB and size over orthority's file for one frame."""
    import rasterio
    with rasterio.open(fotogeo_tif) as ds:
        data, profile = ds.read(), {k: v for k, v in ds.profile.items() if k not in ("blockxsize", "blockysize")}
    oty_mb = orthority_tif.stat().st_size / 1e6
    profile.update(driver="GTiff", tiled=True, compress="DEFLATE", interleave="PIXEL")
    rows, path = {}, fotogeo_tif.with_name("rewritten.tif")
    for level in levels:
        for pred in (2, 1):
            r = rewrite(data, profile, path, repeat, zlevel=level, predictor=pred, blockxsize=256, blockysize=256)
            rows[f"zlevel {level}, predictor {pred}"] = {**r, "over_orthority": round(r["mb"] / oty_mb, 3)}
    r = rewrite(data, profile, path, repeat, zlevel=6, predictor=1, blockxsize=512, blockysize=512)
    rows["orthority's layout (512², zlevel 6, predictor 1)"] = {**r, "over_orthority": round(r["mb"] / oty_mb, 3)}
    return {"orthority_mb": round(oty_mb, 4), "dtype": profile["dtype"], "choices": rows}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--orthority-python", required=True, help="python of a venv with orthority 0.7.0")
    ap.add_argument("--cases", default="ngi,ngi_u16")
    ap.add_argument("--levels", default="1,2,3,6,9")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    load0, results = os.getloadavg(), {}
    for case in a.cases.split(","):
        with tempfile.TemporaryDirectory(prefix="ortho_deflate_") as tmp:
            work = Path(tmp)
            inp = ngi_inputs(work) if case == "ngi" else ngi_variant(work, case.removeprefix("ngi_"))
            fg, oty = run_both(work, inp, a.orthority_python)
            levels = [int(v) for v in a.levels.split(",")]
            results[case] = {Path(f).stem: frame_rows(fg / f"{Path(f).stem}_ortho.tif",
                                                      oty / f"{Path(f).stem}_ORTHO.tif", levels, a.repeat)
                             for f in inp["frames"]}
    out = {"cases": results, "load_average": {"start": [round(v, 2) for v in load0],
                                              "end": [round(v, 2) for v in os.getloadavg()]},
           "command": " ".join(sys.argv)}
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(out, indent=1))
    for case, frames in results.items():
        for frame, r in frames.items():
            print(f"{case} {frame} ({r['dtype']}; orthority {r['orthority_mb']:.2f} MB)")
            for name, c in r["choices"].items():
                print(f"  {name:<50} cpu {c['cpu_s']:.3f} s  {c['mb']:7.2f} MB  {c['over_orthority']:.3f}x orthority's")
    print(f"load average {out['load_average']}; wrote {a.out}")


if __name__ == "__main__":
    main()
