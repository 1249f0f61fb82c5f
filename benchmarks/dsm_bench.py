"""Surface models (``fotogeo dsm``) against truths and a peer.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_bench.py
      [--cases rendered,refine,ngi,ventoux,rendered_rpc,ebee,witness] [--cars] [--ebee-resolutions 0.2,0.1]
      [--baseline-tree OLD] [--rounds 3] [--ebee-dir DIR] [--cars-dir DIR]

* ``rendered`` — the three rendered blocks of ``tests/dsm_scenes.py`` (``nadir``: 2 x 4 frames 1000 m above
  ±40 m; ``oblique``: the DJI-like block, 30° off nadir, Brown distortion; ``held_out``: 3 x 3 frames with
  distortion, never used while tuning), no DEM given: RMSE, NMAD, median of DSM − truth at the cell centres,
  the share of valid cells within 1 and 2 GSD of the frames, the completeness the report states (cells with a
  height in the pairs' overlap), CPU and wall time of the call;
* ``refine`` — ``nadir`` and ``held_out`` again with ``--refine`` (least-squares refinement of the disparities;
  the oblique block left out for its run time);
* ``ngi`` — frames 0182/0184 with their EO, without and with the 24 m DEM (``--dem`` bounds the search): DSM −
  DEM (bilinear, at the DSM cells) median and NMAD, completeness;
* ``ventoux`` — the Pleiades pair with its RPCs (``--rpc``; OSSIM ``.geom`` beside the images), at 0.5 m, with
  ``right_image.geom`` (also with ``--refine``) and with ``right_image_bias.geom`` (RPC about 60 px off): completeness of the footprints'
  overlap, median height, the relative pointing correction measured, whether the warning came, CPU and wall.
  With ``--cars``, CARS on the same pair through ``benchmarks/peers_cars.py`` (its own venv; skipped with the
  reason when it is not installed): its completeness, CPU, wall and memory, and fotogeo − CARS (median, NMAD,
  the share of CARS's valid cells where fotogeo has a height; each fotogeo run, ``--refine`` too), as for the
  recorded runs below; ``--cars-dir DIR`` keeps CARS's runs in DIR and reuses the finished ones found there.
* ``rendered_rpc`` — the rendered satellite pairs of ``tests/rendered_rpc_pair.py`` (pushbroom views from 700 km,
  0.7 m GSD, uint16 12-bit, RPCs fitted to the exact geometry, hills, roughness and buildings; never used while
  tuning): ``fotogeo dsm A B --rpc -o DSM.tif --report r.json --resolution 0.5`` run as a user runs it (a child
  process under ``/usr/bin/time -v``: its user + system CPU and peak memory) on 1024² pairs with B/H 0.4 and 0.15,
  each also with a 3 px relative pointing error in the second RPC, the RPCs in DIMAP XML and ``.RPB`` files
  beside the images, and a 2048² pair: RMSE, NMAD, median of DSM − truth (with the pointing error: the median
  the error must give, and the NMAD again after the horizontal shift it gives), the share within 1 m, the share
  of the cells both images see that have a height. ``--rpc-cases`` picks some of them (names of ``RPC_CASES``
  separated by ``;``). With ``--cars``, CARS runs on the ``B/H 0.4`` pair (GeoTIFF RPC tags, margins ±100 m as on
  ventoux) in the same run: the same statistics against the truth on its own grid, its CPU and peak memory,
  fotogeo − CARS, and fotogeo's CPU, memory, NMAD and completeness as ratios of CARS's (``--cars-dir DIR``: CARS's
  run kept in ``DIR/rendered_BH_0.4``, a finished one reused).

* ``ebee`` — the eBee pair IMG_2280/IMG_2281 of ``drone_snowpeak`` (oriented by ``fotogeo triangulate`` of the
  pair) at ``--ebee-resolutions`` (default 0.2 m), ``fotogeo dsm`` as a user runs it (a child process under
  ``/usr/bin/time -v``): CPU, peak memory, completeness, disparities searched per pixel, coarse-to-fine strips,
  the DSM's hash; with ``--baseline-tree OLD`` the same command on that checkout, the two alternated
  ``--rounds`` times (median CPU), and the largest height difference between the two DSMs.
* ``witness`` — ``pyramid.witnessed`` and ``pyramid.witness_envelope`` on a synthetic 480 x 2200 strip: median CPU
  ms per call, this tree's and ``--baseline-tree``'s (each in a child process), and a hash of their outputs.

* ``oblique_sets`` — the oblique frame sets of ``tests/dsm_oblique_sets.py`` (``benchmarks/dsm_oblique_cases.py``;
  ``--oblique-sets``, ``--oblique-params``, ``--pair-rows``, ``--view-angle-sweep``, ``--oblique-dsm-options``),
  written to ``results/dsm_oblique_bench.json``. ``rendered`` and ``oblique_sets`` take ``--view-angle-limit DEG``
  and ``--pair-limits NAME=VALUE,...`` (other fields of ``fotogeo.stereo.pairs.Limits`` for the automatic pair
  choice, set in the ``fotogeo`` process: ``benchmarks/dsm_bench_run.py``; the rows' names carry them).

Without ``--cars``, CARS's runs recorded on this machine by ``benchmarks/peers_cars.py``
(``results/peers_cars.json``, margins ±100 m) are read and fotogeo's DSMs compared with their DSMs.

Prints a table and writes benchmarks/results/dsm_bench.json: per case group its latest run (command, the
machine's load average at the start and the end, rows). A row run now replaces the row of the same name; the
group's other rows stay, each with the command and load average of the run that measured it (``run``).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "benchmarks")]
from dsm_bench_run import _stats, _time_v, _timed, limits_of, set_limits  # noqa: E402  (re-exported: _stats)
from dsm_oblique_cases import oblique_sets  # noqa: E402
from dsm_bench_cars import _cars, _cars_recorded, _cars_rendered  # noqa: E402  (re-exported: _cars_rendered)
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
#: case -> the prefix of its rows' names (one JSON holds the latest run of each case)
PREFIX = {"rendered": "rendered", "refine": "refined", "ngi": "NGI", "ventoux": "ventoux",
          "rendered_rpc": "rendered_rpc", "ebee": "eBee", "witness": "witness", "oblique_sets": "oblique_sets"}
#: rendered_rpc cases: name -> (image size, base-to-height ratio, pointing error (col, row) px, RPC format)
RPC_CASES = {"B/H 0.4": (1024, 0.4, (0, 0), "gdal"), "B/H 0.4, 3 px pointing": (1024, 0.4, (1.8, 2.4), "gdal"),
             "B/H 0.15": (1024, 0.15, (0, 0), "gdal"), "B/H 0.15, 3 px pointing": (1024, 0.15, (1.8, 2.4), "gdal"),
             "B/H 0.4, DIMAP XML": (1024, 0.4, (0, 0), "dimap"), "B/H 0.4, .RPB": (1024, 0.4, (0, 0), "rpb"),
             "B/H 0.4, 2048²": (2048, 0.4, (0, 0), "gdal")}
NGI_CRS = "+proj=tmerc +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84"


def rendered(tmp: Path, refine: bool = False, limits=None) -> list:
    from dsm_scenes import compare, make_scene

    from fotogeo.tools.dsm import dsm
    tag, rows = set_limits(limits), []
    for kind in ("nadir", "held_out") if refine else ("nadir", "oblique", "held_out"):
        sc = make_scene(kind, tmp / kind)
        rep, cpu, wall, _ = _timed(dsm, sc["images"], tmp / f"{kind}.tif", camera=sc["camera"], eo=sc["eo"],
                                   crs=sc["crs"], refine=refine)
        c, g = compare(tmp / f"{kind}.tif", sc["surface"]), sc["gsd"]
        rows.append({"case": (f"refined {kind} (--refine)" if refine else f"rendered {kind}") + tag, "gsd_m": g,
                     "resolution_m": rep["grid"]["resolution"],
                     "pairs": rep["pairs_kept"], "rmse_m": c["rmse"], "rmse_gsd": c["rmse"] / g, "nmad_m": c["nmad"],
                     "median_m": c["median"], "within_1gsd": float((c["abs"] <= g).mean()),
                     "within_2gsd": float((c["abs"] <= 2 * g).mean()), "completeness": rep["completeness"],
                     "cpu_s": cpu, "wall_s": wall})
    return rows


def ebee(tmp: Path, resolutions: list, rounds: int = 1, baseline=None, keep=None) -> list:
    """The eBee pair IMG_2280/IMG_2281 (copied): ``fotogeo triangulate`` of the pair once (this tree), then
    ``fotogeo dsm A B --orientation strip --crs EPSG:32654 --resolution R --report r.json`` per resolution, each a
    child process under ``/usr/bin/time -v`` run from ``tmp`` (outside any checkout); with ``baseline`` (a tree)
    the same command with that tree first on ``PYTHONPATH``, alternated with this tree's ``rounds`` times: median
    CPU of each, completeness, disparities per pixel, coarse-to-fine strips and whether the DSMs are the same
    bytes (max |difference| where both have a height). ``keep``: a folder keeping the images and the orientation
    between runs (triangulated when it holds none)."""
    import hashlib

    import rasterio
    imgs, strip = _ebee_oriented(tmp, keep)
    py = [sys.executable, "-m", "fotogeo"]
    trees = [("this tree", ROOT)] + ([("baseline", Path(baseline).resolve())] if baseline else [])
    rows = []
    for res in resolutions:
        runs = {label: [] for label, _ in trees}
        for k in range(rounds):
            for label, tree in trees if k % 2 == 0 else trees[::-1]:
                out, rep = tmp / f"{label[0]}_{res}.tif", tmp / f"{label[0]}_{res}.json"
                t = _time_v([*py, "dsm", *map(str, imgs), "--orientation", str(strip), "--crs", "EPSG:32654", "-o",
                             str(out), "--report", str(rep), "--resolution", str(res), "--overwrite"],
                            cwd=tmp, tree=tree)
                runs[label].append({**t, "report": json.loads(rep.read_text()), "out": out})
        for label, got in runs.items():
            r, p = got[-1]["report"], got[-1]["report"]["pairs"][0]
            row = {"case": f"eBee {res} m, {label}", "rounds": rounds,
                   "cpu_s": float(np.median([g["cpu_s"] for g in got])), "cpu_s_each": [g["cpu_s"] for g in got],
                   "peak_rss_mib": max(g["peak_rss_mib"] for g in got), "completeness": r["completeness"],
                   "disparities_searched": p.get("disparities_searched"),
                   "coarse_to_fine_strips": p.get("coarse_to_fine_strips"),
                   "dsm_sha256": hashlib.sha256(got[-1]["out"].read_bytes()).hexdigest()[:16]}
            if label == "baseline":
                with rasterio.open(runs["this tree"][-1]["out"]) as a, rasterio.open(got[-1]["out"]) as b:
                    ha, hb = a.read(1, masked=True), b.read(1, masked=True)
                    row["same_grid"] = a.transform == b.transform
                if ha.shape != hb.shape or not row["same_grid"]:  # another grid: no cell-by-cell difference
                    row["same_grid"], row["grids_rows_cols"] = False, [list(ha.shape), list(hb.shape)]
                    rows.append(row)
                    continue
                both = ~(ha.mask | hb.mask)
                row["same_valid_cells"] = bool((ha.mask == hb.mask).all())
                row["max_abs_diff_m"] = float(np.abs(ha.data[both] - hb.data[both]).max()) if both.any() else None
            rows.append(row)
    return rows


def _ebee_oriented(tmp: Path, keep=None) -> tuple:
    """``(images, orientation folder)`` of the eBee pair in ``keep`` (else ``tmp``), triangulated when absent."""
    keep = Path(keep) if keep else tmp
    keep.mkdir(parents=True, exist_ok=True)
    imgs, strip = [keep / f"{n}.JPG" for n in ("IMG_2280", "IMG_2281")], keep / "strip"
    if not (strip / "exterior_orientation.txt").is_file():
        for p in imgs:
            shutil.copy(DATA / "drone_snowpeak" / "img" / p.name, p)
        _time_v([sys.executable, "-m", "fotogeo", "triangulate", *map(str, imgs), "-o", str(strip), "--overwrite"],
                cwd=tmp)
    return imgs, strip


#: the witness timed in a child (cwd outside any checkout; ``PYTHONPATH`` the tree): a synthetic 480 x 2200 strip,
#: 30 % of its disparities missing, 20 % of the coarse right ones, 5 % of the pixels near a border
WITNESS_RUN = """
import hashlib, json, sys, time
import numpy as np
from fotogeo.stereo import pyramid as pyr
rng = np.random.default_rng(0)
h, w = 480, 2200
d = (40 + rng.normal(0, 2, (h, w))).astype(np.float32)
d[rng.random((h, w)) < 0.3] = np.nan
dcr = (10 + rng.normal(0, 0.5, (h // 4, w // 4))).astype(np.float32)
dcr[rng.random(dcr.shape) < 0.2] = np.nan
near = rng.random((h, w)) < 0.05
def ms(f, n=int(sys.argv[1])):
    t = []
    for _ in range(n):
        c = time.process_time(); f(); t.append(time.process_time() - c)
    return 1000 * float(np.median(t))
out = pyr.witnessed(d, dcr, near_border=near).tobytes() + pyr.witnessed(d, dcr).tobytes()
print(json.dumps({"witnessed_ms": ms(lambda: pyr.witnessed(d, dcr, near_border=near)),
                  "envelope_ms": ms(lambda: pyr.witness_envelope(dcr)),
                  "output_sha256": hashlib.sha256(out).hexdigest()[:16]}))
"""


def witness(tmp: Path, rounds: int, baseline=None) -> list:
    """``pyramid.witnessed`` and its ``witness_envelope`` on :data:`WITNESS_RUN`'s strip: median CPU ms of
    ``20 x rounds`` calls per tree (this, ``baseline``), and a hash of the outputs (the same: the same bytes)."""
    import subprocess
    rows = []
    for label, tree in [("this tree", ROOT)] + ([("baseline", Path(baseline).resolve())] if baseline else []):
        r = subprocess.run([sys.executable, "-c", WITNESS_RUN, str(20 * rounds)], capture_output=True, text=True,
                           cwd=tmp, env=dict(os.environ, PYTHONPATH=str(tree)), check=True)
        rows.append({"case": f"witness 480 x 2200 strip, {label}", **json.loads(r.stdout)})
    return rows


def rendered_rpc(tmp: Path, names=None, cars: bool = False, keep=None) -> list:
    from rendered_rpc_pair import compare, pointing_height_bias, render_rpc_pair, with_pointing
    rows, scenes = [], {}
    unknown = set(names or ()) - set(RPC_CASES)
    if unknown:
        raise SystemExit(f"--rpc-cases: unknown {sorted(unknown)}; choose among {list(RPC_CASES)}")
    for name, (size, bh, pointing, fmt) in RPC_CASES.items():
        if names and name not in names:
            continue
        folder = tmp / name.replace("/", "").replace(" ", "_").replace(",", "")
        if fmt == "gdal" and (size, bh) in scenes:  # the same images, the second RPC off by ``pointing``
            sc = with_pointing(scenes[size, bh], folder / "in", pointing)
        else:
            sc = render_rpc_pair(folder / "in", size, base_height=bh, pointing=pointing, rpc_format=fmt)
            scenes.setdefault((size, bh), sc) if fmt == "gdal" else None
        out, rep = folder / "DSM.tif", folder / "r.json"
        cmd = [sys.executable, "-m", "fotogeo", "dsm", *sc["images"], "--rpc", "-o", str(out), "--report", str(rep),
               "--resolution", "0.5", "-q"]
        t = _time_v(cmd)
        r, bias = json.loads(rep.read_text()), pointing_height_bias(sc)
        c = compare(out, sc, bias, shift=any(pointing))
        raw = compare(out, sc, bias) if any(pointing) else c
        p = r["pairs"][0]
        rows.append({"case": f"rendered_rpc {size}², {name}", "command": "fotogeo " + " ".join(cmd[3:]),
                     "rpc_check_px": sc["rpc_check_px"], "rmse_m": raw["rmse_m"], "nmad_m": raw["nmad_m"],
                     "median_m": c["median_m"], "expected_median_m": bias, "shift_m": c.get("shift_m"),
                     "nmad_after_shift_m": c["nmad_m"] if any(pointing) else None, "within_1m": c["within_1m"],
                     "completeness": c["completeness"], "report_completeness": r["completeness"],
                     "pointing_px": p.get("relative_pointing_px"), "base_to_height": p.get("base_to_height"), **t})
        if cars and name == "B/H 0.4":
            rows.append(_cars_rendered(folder, sc, out, rows[-1], keep))
    return rows


def _against(dsm_path, ref_path) -> np.ndarray:
    import rasterio
    from rasterio.warp import Resampling, reproject
    with rasterio.open(dsm_path) as a, rasterio.open(ref_path) as b:
        h = a.read(1)
        ref = np.full(h.shape, np.nan, np.float32)
        reproject(rasterio.band(b, 1), ref, dst_transform=a.transform, dst_crs=a.crs, resampling=Resampling.bilinear,
                  dst_nodata=np.nan)
        v = (h != a.nodata) & np.isfinite(ref)
    return (h[v] - ref[v]).astype(float)


def ngi(tmp: Path) -> list:
    from fotogeo.tools.dsm import dsm
    d = DATA / "ngi"
    frames = [d / "frames" / f"3324c_2015_1004_05_{n}_RGB.tif" for n in ("0182", "0184")]
    rows = []
    for label, kw in (("no DEM", {}), ("--dem (search range)", {"dem": d / "dem.tif"})):
        out = tmp / f"ngi_{len(kw)}.tif"
        rep, cpu, wall, _ = _timed(dsm, frames, out, camera=d / "interior_orientation.yaml",
                                   eo=d / "exterior_orientation.txt", crs=NGI_CRS, **kw)
        s = _stats(_against(out, d / "dem.tif"))
        rows.append({"case": f"NGI 0182/0184, {label}", "resolution_m": rep["grid"]["resolution"],
                     "vs_dem_median_m": s["median"], "vs_dem_nmad_m": s["nmad"], "completeness": rep["completeness"],
                     "cpu_s": cpu, "wall_s": wall})
    return rows


def ventoux(tmp: Path, cars: bool, keep=None) -> list:
    from fotogeo.tools.dsm import dsm
    v = DATA / "rpc" / "ventoux"
    rows, outs = [], {}
    for right, refine in (("right_image.geom", False), ("right_image_bias.geom", False), ("right_image.geom", True)):
        folder = tmp / (right.split(".")[0] + ("_refine" if refine else ""))
        folder.mkdir()
        for name, src in (("left.tif", "left_image.tif"), ("left.geom", "left_image.geom"),
                          ("right.tif", "right_image.tif"), ("right.geom", right)):
            shutil.copy(v / src, folder / name)
        out = folder / "dsm.tif"
        rep, cpu, wall, said = _timed(dsm, [folder / "left.tif", folder / "right.tif"], out, rpc=True, resolution=0.5,
                                      refine=refine)
        p = rep["pairs"][0]
        right = right + (", --refine" if refine else "")
        outs[right] = out
        rows.append({"case": f"ventoux fotogeo ({right})", "resolution_m": 0.5, "completeness": rep["completeness"],
                     "median_height_m": rep["heights"]["median"], "pointing_px": p.get("relative_pointing_px"),
                     "warned_large_pointing": any("relative pointing error" in m for m in said),
                     "cpu_s": cpu, "wall_s": wall})
    rows += _cars(tmp, v, outs, keep) if cars else _cars_recorded(outs)
    return rows


def _merge(runs: list, group: str, new: list, run: dict) -> list:
    """``runs`` with ``group``'s rows of the same names replaced by ``new`` (each with ``run``: command, load);
    its other rows stay in their order with the run that measured them."""
    old = next((r for r in runs if r["case_group"] == group), {"rows": []})
    names = {r["case"] for r in new}
    kept = [{**r, "run": r.get("run", {k: old[k] for k in ("command", "load_average")})}
            for r in old["rows"] if r["case"] not in names]
    order = {r["case"]: i for i, r in enumerate(old["rows"])}
    rows = sorted(kept + [{**r, "run": run} for r in new], key=lambda r: order.get(r["case"], len(order)))
    return [r for r in runs if r["case_group"] != group] + [{"case_group": group, **run, "rows": rows}]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="rendered,ngi,ventoux")
    ap.add_argument("--cars", action="store_true",
                    help="also run CARS on ventoux and the rendered B/H 0.4 pair (benchmarks/peers_cars.py)")
    ap.add_argument("--cars-dir", help="--cars: keep CARS's runs in this folder, reuse the finished ones there")
    ap.add_argument("--rpc-cases", help="rendered_rpc: only these RPC_CASES names, separated by ';'")
    ap.add_argument("--ebee-resolutions", default="0.2", help="ebee: DSM resolutions (m), separated by ','")
    ap.add_argument("--baseline-tree", help="ebee: also run the dsm commands with this checkout, alternated")
    ap.add_argument("--rounds", type=int, default=1, help="ebee: runs of each tree per resolution (median CPU)")
    ap.add_argument("--ebee-dir", help="ebee: a folder keeping the images and their orientation between runs")
    ap.add_argument("--oblique-sets", help="oblique_sets: only these SETS names, separated by ';'")
    ap.add_argument("--oblique-params", help="oblique_sets: more sets as make_set's parameter dicts, a JSON list "
                    "(with --oblique-params only: only these)")
    ap.add_argument("--pair-rows", action="store_true", help="oblique_sets: each kept pair also alone vs the truth")
    ap.add_argument("--view-angle-sweep", action="store_true",
                    help="oblique_sets: only pairs with views 20-70 degrees apart (benchmarks/dsm_view_sweep.py)")
    ap.add_argument("--oblique-dsm-options", default="", help="oblique_sets: more fotogeo dsm options for every set, "
                    "e.g. --oblique-dsm-options=--refine (the rows' names carry them)")
    ap.add_argument("--view-angle-limit", type=float, help="rendered, oblique_sets: the automatic pair choice's "
                    "view-angle limit (degrees) instead of fotogeo.stereo.pairs.Limits' (the rows' names carry it)")
    ap.add_argument("--pair-limits", help="rendered, oblique_sets: more fields of fotogeo.stereo.pairs.Limits for the "
                    "automatic choice, NAME=VALUE separated by ',' (e.g. rank_view_angle=45,per_image_wide=1; the "
                    "rows' names carry them)")
    args = ap.parse_args()
    limits = limits_of(args.view_angle_limit, args.pair_limits)
    rpc_names = [n.strip() for n in args.rpc_cases.split(";")] if args.rpc_cases else None
    os.environ.setdefault("GDAL_PAM_ENABLED", "NO")
    rows, load0 = [], os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="dsm_bench_") as t:
        tmp = Path(t)
        for case in args.cases.split(","):
            if case not in ("rendered", "refine", "rendered_rpc", "witness", "oblique_sets") and not DATA.is_dir():
                rows.append({"case": case, "skipped": f"no data at {DATA}"})
                continue
            (tmp / case).mkdir()
            rows += {"rendered": lambda: rendered(tmp / case, limits=limits),
                     "refine": lambda: rendered(tmp / case, True),
                     "ngi": lambda: ngi(tmp / case),
                     "ventoux": lambda: ventoux(tmp / case, args.cars, args.cars_dir),
                     "rendered_rpc": lambda: rendered_rpc(tmp / case, rpc_names, args.cars, args.cars_dir),
                     "ebee": lambda: ebee(tmp / case, [float(r) for r in args.ebee_resolutions.split(",")],
                                          args.rounds, args.baseline_tree, args.ebee_dir),
                     "witness": lambda: witness(tmp / case, args.rounds, args.baseline_tree),
                     "oblique_sets": lambda: oblique_sets(tmp / case, _names(args.oblique_sets),
                                                          _params(args.oblique_params), args.pair_rows,
                                                           args.view_angle_sweep,
                                                           args.oblique_dsm_options.split(),
                                                           limits)}[case]()
    for r in rows:
        print(" | ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items()))
    run = {"command": " ".join(sys.argv), "load_average": [load0, os.getloadavg()]}
    for name in ("dsm_bench", "dsm_oblique_bench"):  # oblique_sets: a file of its own
        cases = [c for c in args.cases.split(",") if (c == "oblique_sets") == (name == "dsm_oblique_bench")]
        if cases:
            _write(ROOT / "benchmarks" / "results" / f"{name}.json", cases, rows, run)


def _params(text):
    return json.loads(text) if text else None


def _names(text):
    return [n.strip() for n in text.split(";")] if text else None


def _write(out: Path, cases: list, rows: list, run: dict) -> None:
    runs = json.loads(out.read_text()).get("runs", []) if out.is_file() else []
    for c in cases:
        runs = _merge(runs, PREFIX[c], [r for r in rows if r["case"].startswith(PREFIX[c] + " ")], run)
    out.write_text(json.dumps({"runs": runs}, indent=1, default=str) + "\n")
    print(f"-> {out}")


if __name__ == "__main__":
    main()
