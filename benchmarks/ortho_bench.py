"""Orthorectification (issue 21): ``fotogeo ortho`` beside orthority and ``gdalwarp -rpc`` on the same grids.

Run:  .venv/bin/python benchmarks/ortho_bench.py [--orthority-python VENV/bin/python] [--repeat 3]
      [--cases ngi,qb2,drone,drone_half] [--resolutions native,fine] [--drone-dir DIR] [--fotogeo-compress zstd]
      [--out JSON]

* ``ngi`` — the two NGI frames (camera ``interior_orientation.yaml``, ``exterior_orientation.txt``, the 24-m DEM)
  through fotogeo and orthority (``oty frame``, PyPI, AGPL: installed in its own venv, run as a program only),
  both ``--aligned-pixels`` grids of the same resolution (so their cells coincide), bilinear image and DEM
  interpolation, DEFLATE;
  With ``--orthority-compression both`` orthority also runs with fotogeo's creation options (``-co``: 256² tiles,
  DEFLATE level 1, horizontal predictor; row ``orthority_z1``): the same compression on both sides. Both build
  average overviews inside the file, while a level keeps 256 px on its short side (the same ladder). With
  ``--orthority-compression default`` orthority also runs at its own defaults, without ``-cm`` and ``-nwm``
  (row ``orthority_default``: JPEG in YCbCr with an internal mask for 8-bit images, lossy; DEFLATE level 6
  without a predictor otherwise; 512² tiles), with its files' MB (``orthority_default_mb``);
* ``qb2`` — the QuickBird Basic-1B image with its vendor RPC on the same DEM through fotogeo ``--rpc`` and
  ``gdalwarp -rpc -to RPC_DEM=…`` (``-tap``, bilinear, GDAL's default transformer error 0.125 px, and
  ``-et 0``; all CPUs). Both take the DEM's values as ellipsoidal heights (fotogeo ``--dem-heights
  ellipsoid``, GDAL ``RPC_DEM_APPLY_VDATUM_SHIFT=FALSE``): the DEM states EGM2008 heights, whose grid is not
  installed here, and the comparison needs the same heights on both sides.

* ``drone`` — held out from the code's tuning: the eBee frames IMG_2188 and IMG_2281 (4608 x 3456 JPEG, two strips)
  with the camera (Brown: k1, k2, p2 estimated) and exterior orientation that ``fotogeo triangulate`` adjusts from
  the six strip frames (``--self-calibration k1,k2,p1,p2``, run once into ``--drone-dir``, about 2 minutes), on a
  2 m surface gridded from its tie points (``gdal_grid`` inverse distance; the flight has no published DEM), through
  fotogeo and orthority (``-c EPSG:32654``; orthority's full remap, i.e. the distortion in every cell's position).

* ``drone_half`` — the same two frames at half size (4608 x 3456 -> 2304 x 1728, GDAL's average, written as
  uncompressed TIFFs beside the drone case's folder) with the camera scaled to them (``im_size``, ``focal_len``
  and ``sensor_size`` halved; the Brown terms and the principal point are normalised, unchanged): another image
  size and another format (a TIFF without overviews, read whole at full resolution).
* ``ngi_u16``, ``ngi_half``, ``ngi_dem_utm`` — held out from every stop's tuning: the NGI case with one thing changed
  (``ortho_bench_inputs.ngi_variant``): the frames as 3-band UInt16 (values x 257), the frames at half size with the
  camera scaled (twice the ground sample distance: ``native`` is 10 m), the DEM warped to UTM 35S + EGM2008 heights
  with the map CRS given to both tools as the frames' Lo25 (fotogeo ``--crs``, orthority ``-c``; fotogeo then
  imports pyproj to sample the DEM across CRSs).
* ``drone_other`` — held out from this and every earlier stop's tuning: the strips' four other frames (IMG_2186,
  IMG_2189, IMG_2280, IMG_2282: never orthorectified by the code's tuning), the same camera, orientation and
  surface as ``drone`` (their poses come from the same six-frame adjustment), at 10 and 20 cm.

With ``--fotogeo-compress zstd`` (comma-separated ``--compress`` values) each frame case's rounds also run fotogeo
with that compression (row ``fotogeo_zstd``, its ratios over orthority; ``compare_zstd``: per frame whether its
pixels equal the default DEFLATE output's, full resolution and every overview level, the three files' MB and
each fotogeo file's compression ratio to the grid's uncompressed size with overviews, the free-space check's).

With ``--pairs N --baseline-tree OLD`` the peers are not run: each frame case's ``fotogeo ortho`` runs N alternating
pairs (this checkout, OLD; the order swapped every pair), each process's CPU time read from ``RUSAGE_CHILDREN`` and its
exit's as that less its own CPU at the end of ``main`` (``FOTOGEO_EXIT_RUN``): medians, the median of the pairs'
differences and whether both trees' outputs have the same pixels, grid and CRS, and the same bytes
(``results/ortho_exit_pairs.json``).
``--resolutions`` also takes metres (``0.2``). ``--import-cost N`` times N fresh processes importing the
third-party modules of an ``ortho`` run of frames, alternating with N that import pyproj as well
(``results/ortho_import_cost.json``).

Resolutions: ``native`` (NGI 5 m, qb2 6 m, about the images' ground sample distances) and ``fine``
drone 3 cm, about the frames' 2.9-3.3 cm; ``fine``
(NGI 1 m, qb2 2 m, drone 2 cm: 25x and 9x more output cells, where the work rather than the start-up dominates);
``coarse`` and ``coarser`` (drone, drone_half and drone_other 10 and 20 cm: small outputs, where the start-up
weighs most).

Each command runs ``--repeat`` times in a fresh process under ``/usr/bin/time``: median wall time (the whole
command as a user runs it — ``fotogeo ortho`` and ``oty frame``, each through its click entry point —, interpreter
start and imports included; fotogeo's bytecode compiled beforehand, as an installed package's is), the frame cases
in alternating rounds (fotogeo, then orthority, ``--repeat`` times; also the median over the rounds of each round's
own CPU ratio, ``cpu_ratio_rounds``, steadier on a shared machine than the ratio of the medians), CPU time
(user + system: steadier than the wall time on a shared machine) and peak resident memory; the Python tools also
report their in-process time after the imports (``work``). Ratios are fotogeo's over the peer's (below 1: fotogeo
faster). Agreement: on the overlap of two outputs, 128 x 128 tiles fully valid in both are phase-correlated
(OpenCV, Hanning window) on band 1: the local shift of each tile in output pixels (median, 95th percentile and
largest length) and the mean absolute grey-level difference. Writes benchmarks/results/ortho_bench.json (or
``--out``; with the load average at the start and the end: the machine may be shared) and prints a table.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

# the --pairs harness, the inputs and the timing (beside this file: on sys.path)
from ortho_bench_inputs import (DATA, DRONE_FRAMES, DRONE_OTHER, drone_inputs, half_inputs, ngi_inputs,  # noqa: F401
                                ngi_variant)
from ortho_bench_timing import ratio_range, repeat, summary, tile_shifts, timed  # noqa: F401
from ortho_exit_pairs import exit_pairs

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "ortho_bench.json"
RES = {"ngi": {"native": 5.0, "fine": 1.0}, "ngi_u16": {"native": 5.0}, "ngi_half": {"native": 10.0},
       "ngi_dem_utm": {"native": 5.0}, "qb2": {"native": 6.0, "fine": 2.0},
       "drone": {"native": 0.03, "fine": 0.02, "coarse": 0.1, "coarser": 0.2},
       "drone_half": {"coarse": 0.1, "coarser": 0.2}, "drone_other": {"coarse": 0.1, "coarser": 0.2}}
#: fotogeo's GeoTIFF creation options (256² tiles, DEFLATE level 1, horizontal predictor) for orthority's ``-co``
FOTOGEO_CO = [a for o in ("TILED=YES", "BLOCKXSIZE=256", "BLOCKYSIZE=256", "COMPRESS=DEFLATE", "ZLEVEL=1",
                          "PREDICTOR=2") for a in ("-co", o)]
#: fotogeo's environment in the timed runs: this checkout, whose bytecode main() compiles once (``__pycache__``,
#: ignored by git) as pip compiles an installed package's (with PYTHONDONTWRITEBYTECODE set nothing else would, and
#: every run would compile ~200 modules)
FOTOGEO_ENV = {"PYTHONPATH": str(ROOT)}

#: ``python -c`` puts the working folder first on ``sys.path``: run from a checkout, its ``fotogeo`` would shadow the
#: one ``PYTHONPATH`` names (``--baseline-tree`` of ortho_threshold_bench.py timed this checkout twice), so it is dropped
FOTOGEO_RUN = """
import sys, time
if sys.path[0] == "":
    del sys.path[0]
from fotogeo.cli import main
t = time.perf_counter()
try:
    main.main(sys.argv[1:], standalone_mode=False)
finally:
    print("WORK", time.perf_counter() - t)
"""

ORTHORITY_RUN = """
import sys, time, glob
from orthority.cli import cli
t = time.perf_counter()
try:
    cli.main(sys.argv[1:], standalone_mode=False)
finally:
    print("WORK", time.perf_counter() - t)
"""


def frame_case(work: Path, res: float, oty_py, n: int, inp: dict, same="own", compress=()) -> dict:
    """fotogeo and orthority on the frames of ``inp`` (:func:`ngi_inputs`, :func:`drone_inputs`) at ``res``;
    ``same``: ``"both"``, orthority also with fotogeo's creation options (:data:`FOTOGEO_CO`), ``"default"``, also
    at its own defaults (module docstring); ``compress``: fotogeo also with
    each of these ``--compress`` values (rows ``fotogeo_<value>``, in the same rounds; :func:`compare_outputs`)."""
    frames = inp["frames"]
    fg_dir, oty_dir = work / "fotogeo", work / "orthority"
    args = ["ortho", *frames, "-o", str(fg_dir), "--dem", inp["dem"], "--camera", inp["camera"], "--eo", inp["eo"],
            "--resolution", str(res), "--resampling", "bilinear", "--overwrite", "-q", *inp.get("fotogeo_args", [])]
    fg_dir.mkdir(exist_ok=True)
    fg_cmd = [sys.executable, "-c", FOTOGEO_RUN, *args]
    fg_cmds = {"fotogeo": fg_cmd}
    for c in compress:
        (work / f"fotogeo_{c}").mkdir(exist_ok=True)
        fg_cmds[f"fotogeo_{c}"] = [str(work / f"fotogeo_{c}") if a == str(fg_dir) else a for a in fg_cmd] + [
            "--compress", c]
    if not oty_py:
        return {k: repeat(c, n, env=FOTOGEO_ENV) for k, c in fg_cmds.items()}
    cmd = [oty_py, "-c", ORTHORITY_RUN, "frame", "-d", inp["dem"], "-ip", inp["camera"], "-ep", inp["ext"],
           *inp["crs"], "-r", str(res), "-ap", "-i", "bilinear", "-di", "bilinear", "-cm", "deflate", "-nwm",
           "-od", str(oty_dir), "-o", *frames]
    oty_dir.mkdir(exist_ok=True)
    rounds = [({k: timed(c, FOTOGEO_ENV) for k, c in fg_cmds.items()}, timed(cmd))  # alternating: the same load
              for _ in range(n)]
    out = {"fotogeo": summary([r[0]["fotogeo"] for r in rounds]), "orthority": summary([r[1] for r in rounds]),
           "cpu_ratio_rounds": ratio_range([a["fotogeo"]["cpu_s"] / b["cpu_s"] for a, b in rounds])}
    for c in compress:
        out[f"fotogeo_{c}"] = summary([r[0][f"fotogeo_{c}"] for r in rounds])
        out[f"cpu_ratio_rounds_{c}"] = ratio_range([a[f"fotogeo_{c}"]["cpu_s"] / b["cpu_s"] for a, b in rounds])
        out[f"compare_{c}"] = compare_outputs(fg_dir, work / f"fotogeo_{c}", oty_dir, frames)
    at = cmd.index("-cm")
    if same == "both":
        out["orthority_z1"] = repeat(cmd[:at] + FOTOGEO_CO + cmd[at + 2:], n)
    if same == "default":
        (work / "orthority_default").mkdir(exist_ok=True)
        own = [str(work / "orthority_default") if a == str(oty_dir) else a for a in cmd[:at] + cmd[at + 3:]]
        out["orthority_default"] = repeat(own, n)  # without "-cm deflate" and "-nwm"
        out["orthority_default_mb"] = {Path(f).stem: (work / "orthority_default" / f"{Path(f).stem}_ORTHO.tif").stat(
        ).st_size / 1e6 for f in frames}
    out["agreement"] = {Path(f).stem: tile_shifts(fg_dir / f"{Path(f).stem}_ortho.tif",
                                                  oty_dir / f"{Path(f).stem}_ORTHO.tif") for f in frames}
    return out


def compare_outputs(deflate: Path, other: Path, oty_dir: Path, frames) -> dict:
    """Per frame: whether fotogeo's outputs in ``deflate`` and ``other`` (another ``--compress``) hold the same
    pixels, full resolution and every overview level, the file sizes (MB) of both and of orthority's, the grid's
    uncompressed size with overviews (MB, :func:`fotogeo.io.output_checks.grid_bytes`: what the free-space check
    divides by a compression ratio) and each fotogeo file's ratio to it."""
    import rasterio

    from fotogeo.io.output_checks import grid_bytes
    out = {}
    for f in frames:
        a, b = deflate / f"{Path(f).stem}_ortho.tif", other / f"{Path(f).stem}_ortho.tif"
        with rasterio.open(a) as da, rasterio.open(b) as db:
            same = da.overviews(1) == db.overviews(1) and np.array_equal(da.read(), db.read()) and all(
                np.array_equal(da.read(out_shape=(da.count, da.height // k, da.width // k)),
                               db.read(out_shape=(db.count, db.height // k, db.width // k))) for k in da.overviews(1))
            tags = db.tags(ns="IMAGE_STRUCTURE").get("COMPRESSION")
            raw = grid_bytes(db.width, db.height, db.count, db.dtypes[0]) / 1e6
        oty = oty_dir / f"{Path(f).stem}_ORTHO.tif"
        out[Path(f).stem] = {"same_pixels": bool(same), "compression": tags, "mb": {
            "fotogeo": a.stat().st_size / 1e6, "other": b.stat().st_size / 1e6,
            "orthority": oty.stat().st_size / 1e6 if oty.exists() else None, "uncompressed": raw},
            "ratio": {"fotogeo": raw * 1e6 / a.stat().st_size, "other": raw * 1e6 / b.stat().st_size}}
    return out


def qb2_case(work: Path, res: float, n: int) -> dict:
    img, dem = DATA / "qb2" / "qb2_basic1b.tif", DATA / "ngi" / "dem.tif"
    fg = work / "fotogeo_qb2.tif"
    args = ["ortho", str(img), "-o", str(fg), "--dem", str(dem), "--rpc", "--dem-heights", "ellipsoid",
            "--resolution", str(res), "--resampling", "bilinear", "--overwrite", "-q"]
    out = {"fotogeo": repeat([sys.executable, "-c", FOTOGEO_RUN, *args], n, env=FOTOGEO_ENV)}
    import rasterio
    with rasterio.open(dem) as d:
        from pyproj import CRS
        crs = CRS.from_user_input(d.crs.to_wkt()).sub_crs_list[0].to_wkt()
    (work / "crs.wkt").write_text(crs)
    for name, extra in (("gdalwarp", []), ("gdalwarp_et0", ["-et", "0"])):
        gw = work / f"{name}.tif"
        cmd = ["gdalwarp", "-q", "-overwrite", "-rpc", "-to", f"RPC_DEM={dem}", "-to",
               "RPC_DEM_APPLY_VDATUM_SHIFT=FALSE",
               "-t_srs", str(work / "crs.wkt"), "-tr", str(res), str(res), "-tap", "-r", "bilinear", *extra,
               "-multi", "-wo", "NUM_THREADS=ALL_CPUS", "-co", "TILED=YES", "-co", "COMPRESS=DEFLATE",
               "-dstnodata", "0", str(img), str(gw)]
        out[name] = repeat(cmd, n)
        out[f"agreement_{name}"] = tile_shifts(fg, gw)
    return out


#: the third-party modules an ``ortho`` run of frames imports (``python -X importtime``), pyproj apart
ORTHO_IMPORTS = "numpy, rasterio, cv2, yaml, click"


def import_cost(n: int) -> None:
    """``--import-cost N``: the CPU time (user + system) of N fresh processes importing :data:`ORTHO_IMPORTS`,
    alternating with N that also import pyproj; medians, ranges and the median of the pairs' differences."""
    runs = {"without": [], "with_pyproj": []}
    for _ in range(n):
        runs["without"].append(timed([sys.executable, "-c", f"import {ORTHO_IMPORTS}"])["cpu_s"])
        runs["with_pyproj"].append(timed([sys.executable, "-c", f"import {ORTHO_IMPORTS}, pyproj"])["cpu_s"])
    runs = {k: [round(t, 3) for t in v] for k, v in runs.items()}
    out = {k: {"median": round(statistics.median(v), 3), "min": min(v), "max": max(v), "each": v}
           for k, v in runs.items()}
    out["pyproj_cpu_s_median_of_pairs"] = round(statistics.median(
        b - a for a, b in zip(runs["without"], runs["with_pyproj"])), 3)
    out.update(processes=n, load_average=[round(v, 2) for v in os.getloadavg()], command=" ".join(sys.argv))
    print(json.dumps(out))
    OUT.with_name("ortho_import_cost.json").write_text(json.dumps(out, indent=1))


def table(results: dict) -> str:
    rows = ["case       res   tool          wall s  cpu s  work s  peak MB  wall ratio  cpu ratio  rounds' cpu ratio "
            "(median, range)  shift med/p95/max px"]
    for case, by_res in results["cases"].items():
        for res, r in by_res.items():
            fg = r["fotogeo"]
            for tool in [k for k in r if "cpu_s" in r[k]]:
                t = r[tool]
                extra = tool.startswith("fotogeo_") and "orthority" in r  # another --compress: over orthority
                num, den = (t, r["orthority"]) if extra else (fg, t)
                ag = r.get("agreement_" + tool) or (r.get("agreement") if tool == "orthority" else None)
                if ag and "tiles" not in ag:  # per frame
                    ag = max(ag.values(), key=lambda a: a["max_px"])
                shift = f"{np.hypot(ag['median_dx'], ag['median_dy']):.3f}/{ag['p95_px']:.3f}/{ag['max_px']:.3f}" \
                    if ag else ""
                rw = num["wall_s"] / den["wall_s"]
                rc = num["cpu_s"] / den["cpu_s"]
                rr = r.get("cpu_ratio_rounds") if tool == "orthority" else r.get("cpu_ratio_rounds_" + tool[8:])
                rounds = f"{rr['median']:.3f} ({rr['min']:.3f}-{rr['max']:.3f})" if rr else ""
                rows.append(f"{case:<10} {res:<5} {tool:<13} {t['wall_s']:>6.2f} {t['cpu_s']:>6.2f}  "
                            f"{(t['work_s'] or float('nan')):>6.2f}  {t['peak_mb']:>7.0f}  {rw:>10.2f}  {rc:>9.2f}  "
                            f"{rounds:<34} {shift}")
    return "\n".join(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--orthority-python", default=os.environ.get("ORTHORITY_PYTHON"),
                    help="python of a venv with orthority installed [$ORTHORITY_PYTHON; none: orthority skipped]")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cases", default="ngi,qb2,drone")
    ap.add_argument("--resolutions", default="native,fine",
                    help="comma-separated levels among native, fine, coarse and coarser (the last two: drone, "
                         "drone_half and drone_other only), or metres; CASE:LEVEL for one case only")
    ap.add_argument("--orthority-compression", choices=["own", "both", "default"], default="own",
                    help="orthority with its own -cm deflate (level 6, no predictor), or also with fotogeo's "
                         "creation options (row orthority_z1), or also at its own defaults (row orthority_default: "
                         "JPEG for 8-bit images)")
    ap.add_argument("--fotogeo-compress", default="",
                    help="comma-separated --compress values fotogeo also runs with (rows fotogeo_<value>, ratios over "
                         "orthority; pixels compared with the default's), e.g. zstd")
    ap.add_argument("--out", type=Path, default=OUT, help=f"the JSON written [{OUT.relative_to(ROOT)}]")
    ap.add_argument("--drone-dir", type=Path,
                    help="folder keeping the drone case's triangulation and surface between runs [a temporary one]")
    ap.add_argument("--pairs", type=int, help="instead of the peers: this many alternating pairs of fotogeo runs "
                    "(this checkout, --baseline-tree) per frame case, with each process's exit CPU; "
                    "writes results/ortho_exit_pairs.json")
    ap.add_argument("--baseline-tree", type=Path, help="--pairs: the other fotogeo checkout")
    ap.add_argument("--import-cost", type=int, metavar="N",
                    help="instead: N alternating processes importing the third-party modules of an ortho run with "
                         "and without pyproj (CPU s; results/ortho_import_cost.json)")
    a = ap.parse_args(argv)
    if a.import_cost:
        return import_cost(a.import_cost)
    if a.pairs and not a.baseline_tree:
        ap.error("--pairs needs --baseline-tree (the checkout to alternate with)")
    if not DATA.exists():
        sys.exit(f"real data not found at {DATA} (set FOTOGEO_DATA)")
    import rasterio
    results = {"gdal_cli": subprocess.run(["gdalinfo", "--version"], capture_output=True, text=True).stdout.strip(),
               "fotogeo_gdal": rasterio.__gdal_version__, "cpus": len(os.sched_getaffinity(0)),
               "load_average_start": [round(v, 2) for v in os.getloadavg()], "cases": {}}
    with tempfile.TemporaryDirectory(prefix="ortho_bench_") as tmp:
        for tree in (ROOT, a.baseline_tree) if a.pairs else (ROOT,):
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(tree / "fotogeo")], check=True,
                           env={**os.environ, "PYTHONDONTWRITEBYTECODE": ""})
        for case in a.cases.split(","):
            results["cases"][case] = {}
            for level in a.resolutions.split(","):
                only, _, level = level.rpartition(":")  # "case:level": that case only
                numeric = level.replace(".", "", 1).isdigit()
                if only not in ("", case) or level not in RES[case] and not numeric or a.pairs and case == "qb2":
                    continue
                res = RES[case].get(level) or float(level)
                work = Path(tmp) / f"{case}_{level}"
                work.mkdir()
                if case == "qb2":
                    r = qb2_case(work, res, a.repeat)
                else:
                    drone = a.drone_dir or Path(tmp) / "drone"
                    inp = ngi_inputs(work) if case == "ngi" else ngi_variant(work, case[4:]) if case.startswith(
                        "ngi_") else drone_inputs(drone, DRONE_OTHER if case == "drone_other" else DRONE_FRAMES)
                    inp = half_inputs(inp, drone / "half") if case == "drone_half" else inp
                    r = (exit_pairs(work, inp, res, a.pairs, a.baseline_tree.resolve()) if a.pairs else
                         frame_case(work, res, a.orthority_python, a.repeat, inp, a.orthority_compression,
                                    [c for c in a.fotogeo_compress.split(",") if c]))
                results["cases"][case][f"{res:g}"] = r
                print(json.dumps({case: {f"{res:g}": r}}), flush=True)
    results["load_average_end"] = [round(v, 2) for v in os.getloadavg()]
    if a.pairs:
        out = OUT.with_name("ortho_exit_pairs.json")  # one run per case and resolution: the latest kept
        runs = json.loads(out.read_text()) if out.is_file() else {}
        for case, by_res in results.pop("cases").items():
            for res, r in by_res.items():
                runs[f"{case} {res}"] = {**r, "command": " ".join(sys.argv), **results}
        out.write_text(json.dumps(runs, indent=1))
        print(f"wrote {out.relative_to(ROOT)}")
        return
    print(table(results))
    print(f"load average (1, 5, 15 min): start {results['load_average_start']}, end {results['load_average_end']}")
    a.out.write_text(json.dumps(results, indent=1))
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
