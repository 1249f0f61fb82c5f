"""CARS (CNES, Apache-2.0) as the DSM peer: run it on one stereo pair into a folder, measure it.

CARS lives in its own venv (``../shared/peers/cars/cars_run.sh`` installs CARS 1.3.0 from PyPI into
``$PEER_ROOT/venv``); it is never a dependency of fotogeo. :func:`run_cars` writes a CARS configuration
(the settings of that script: one worker, full-resolution matching only, 0.5 m, heights above the WGS 84
ellipsoid, a constant initial-elevation DEM at the scene's height), runs ``cars`` under ``/usr/bin/time -v``
and returns the DSM path with wall time, CPU time (user + system of the whole process tree), peak memory
(the largest summed resident set of the process tree, sampled every 0.5 s, and the largest single process)
and the DSM's completeness (valid share of the raster and of the two images' footprint overlap).

Used by ``benchmarks/dsm_bench.py``::

    from peers_cars import run_cars
    r = run_cars("left.tif", "right.tif", "/scratch/cars_out", geom1="left.geom", geom2="right.geom",
                 margins=100)
    if "skipped" in r: print(r["skipped"])
    else: print(r["dsm"], r["cpu_s"], r["wall_s"], r["peak_rss_mib"], r["valid_fraction_in_overlap"])
    compare_dsms("fotogeo_dsm.tif", r["dsm"])   # dz median / NMAD / mean on CARS' grid

or from the shell (writes ``benchmarks/results/peers_cars.json`` unless ``--json``)::

    python benchmarks/peers_cars.py LEFT.tif RIGHT.tif OUT_DIR [--geom1 L.geom --geom2 R.geom] [--margins 100]

Finding CARS: ``$CARS_BIN`` (the ``cars`` executable), else ``cars`` on ``PATH``, else
``$PEER_ROOT/venv/bin/cars`` (``PEER_ROOT`` defaults to the install script's ``/tmp/peers/cars``); the python of
its venv (``$CARS_PYTHON``, else the ``python`` beside ``cars``) computes the initial height. When none exists
the result is ``{"skipped": <why and how to install>}`` and nothing runs.

The initial height: ``initial_height`` (metres above the ellipsoid) when given, else the median height of
ratio-tested SIFT matches intersected through the two RPC models (computed in the CARS venv with shareloc for
OSSIM ``.geom`` files, GDAL's RPC transformer for RPC tags). CARS reads its initial-elevation DEM as heights
above the EGM96 geoid, so the DEM holds ``h - N`` (``N`` from CARS' own ``egm96.grd``). Without any DEM CARS
assumes 0 m, which on a mountain pair puts its disparity search off.

``margins``: CARS widens the disparity interval found from its sparse matches by 500 m below and 1000 m above
(``sparse_matching.disparity_bounds_estimation``); ``margins=m`` sets both to ``m`` metres.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

INSTALL_HINT = ("install it with `bash ../shared/peers/cars/cars_run.sh records` (a venv under $PEER_ROOT, default "
                "/tmp/peers/cars) or set CARS_BIN to the cars executable")

# run in the CARS venv: initial height of the pair and the constant initial-elevation DEM (argv: JSON)
_HEIGHT_CODE = r'''
import json, os, sys, warnings
import numpy as np
warnings.simplefilter("ignore")
import cv2, rasterio
a = json.loads(sys.argv[1])

def u8(x):
    lo, hi = np.percentile(x, [1, 99])
    return np.clip((x - lo) / max(hi - lo, 1e-6) * 255, 0, 255).astype(np.uint8)

def locator(img, geom):
    with rasterio.open(img) as ds:
        im, tr, rpcs = u8(ds.read(1).astype(np.float32)), ds.transform, ds.rpcs
    if geom:  # OSSIM .geom through shareloc; the image's geotransform maps its pixels into the full product
        from shareloc.geomodels import GeoModel
        m = GeoModel(geom, "RPC")
        def loc(c, r, hs):
            x, y = tr * (c + 0.5, r + 0.5)
            p = np.array(m.direct_loc_h(np.full(hs.size, y), np.full(hs.size, x), hs))
            return p[:, 0], p[:, 1]
    else:
        from rasterio.transform import RPCTransformer
        t = RPCTransformer(rpcs)
        def loc(c, r, hs):
            x, y = t.xy([r + 0.5] * hs.size, [c + 0.5] * hs.size, zs=list(hs), offset="ul")
            return np.asarray(x), np.asarray(y)
    return im, loc

(i1, l1), (i2, l2) = locator(a["img1"], a["geom1"]), locator(a["img2"], a["geom2"])
sift = cv2.SIFT_create(4000)
k1, d1 = sift.detectAndCompute(i1, None)
k2, d2 = sift.detectAndCompute(i2, None)
good = [m for m, n in cv2.BFMatcher().knnMatch(d1, d2, k=2) if m.distance < 0.75 * n.distance]
hs = np.arange(-500.0, 5000.0, 5.0)
res = []
for g in good:
    (c1, r1), (c2, r2) = k1[g.queryIdx].pt, k2[g.trainIdx].pt
    x1, y1 = l1(c1, r1, hs)
    x2, y2 = l2(c2, r2, hs)
    d = np.hypot((x1 - x2) * np.cos(np.radians(y1)), y1 - y2) * 111320.0
    i = int(np.argmin(d))
    res.append((hs[i], d[i], x1[i], y1[i]))
b = np.array(res)
ok = b[:, 1] < 3.0
if ok.sum() < 20:
    ok[:] = True  # rays do not meet (a biased RPC): closest-approach heights of all matches
h = float(a["height"]) if a["height"] is not None else float(np.median(b[ok, 0]))
lon, lat = float(np.median(b[ok, 2])), float(np.median(b[ok, 3]))
import cars
from rasterio.transform import from_origin
with rasterio.open(os.path.join(os.path.dirname(cars.__file__), "conf", "geoid", "egm96.grd")) as g:
    n = float(next(g.sample([(lon if g.bounds.left <= lon <= g.bounds.right else lon + 360.0, lat)]))[0])
with rasterio.open(a["dem"], "w", driver="GTiff", width=200, height=200, count=1, dtype="float32",
                   crs="EPSG:4326", transform=from_origin(lon - 0.05, lat + 0.05, 0.0005, 0.0005)) as ds:
    ds.write(np.full((200, 200), h - n, np.float32), 1)
print(json.dumps({"n_matches": len(good), "n_rays_meeting_3m": int((b[:, 1] < 3.0).sum()),
                  "ray_miss_median_m": float(np.median(b[:, 1])), "height_m": h,
                  "height_given": a["height"] is not None, "geoid_undulation_m": n, "lon": lon, "lat": lat}))
'''


def find_cars() -> str | None:
    """Path of the ``cars`` executable (module docstring), or None."""
    env = os.environ.get("CARS_BIN")
    if env:
        return env if os.access(env, os.X_OK) else None
    exe = shutil.which("cars")
    if exe:
        return exe
    venv = Path(os.environ.get("PEER_ROOT", "/tmp/peers/cars")) / "venv" / "bin" / "cars"
    return str(venv) if os.access(venv, os.X_OK) else None


def _config(img1, img2, geom1, geom2, dem, out, margins, resolution):
    sensors = {}
    for key, img, geom in (("left", img1, geom1), ("right", img2, geom2)):
        sensors[key] = {"image": str(img)} | ({"geomodel": str(geom)} if geom else {})
    conf = {"input": {"sensors": sensors, "pairing": [["left", "right"]], "initial_elevation": {"dem": str(dem)}},
            "orchestrator": {"mode": "multiprocessing", "nb_workers": 1, "max_ram_per_worker": 3000},
            "output": {"directory": str(out), "resolution": resolution, "geoid": False, "product_level": ["dsm"]},
            # small crops: CARS' 1/16 and 1/4 levels find too few matches ("DSM generated at resolution 4 is empty")
            "subsampling": {"advanced": {"resolutions": [1]}}}
    if margins is not None:
        conf["tie_points"] = {"applications": {"all": {"sparse_matching": {"disparity_bounds_estimation": {
            "lower_margin": int(margins), "upper_margin": int(margins)}}}}}  # CARS checks for int
    return conf


def _tree_rss_mib(proc) -> int:
    import psutil
    try:
        procs = [proc] + proc.children(recursive=True)
    except psutil.Error:
        return 0
    tot = 0
    for p in procs:
        try:
            tot += p.memory_info().rss
        except psutil.Error:
            pass
    return tot // 2 ** 20


def _time_v(text: str, key: str):
    m = re.search(re.escape(key) + r":\s*([0-9.]+)", text)
    return float(m.group(1)) if m else None


def _completeness(out_dir: Path, dsm: Path) -> dict:
    """Valid share of the DSM raster and inside the two images' footprint overlap (CARS' envelopes)."""
    import numpy as np
    import rasterio
    import shapely
    import yaml
    from pyproj import CRS, Transformer
    from rasterio.features import geometry_mask
    from shapely.geometry import shape

    with rasterio.open(dsm) as ds:
        a = ds.read(1)
        valid = np.isfinite(a) & ((a != ds.nodata) if ds.nodata is not None else True)
        res = {"valid_fraction": float(valid.mean()), "width": ds.width, "height": ds.height,
               "crs": CRS.from_wkt(ds.crs.to_wkt()).name, "h_median_m": float(np.median(a[valid])) if valid.any() else None}
        try:
            meta = yaml.safe_load((out_dir / "metadata.yaml").read_text())

            def find(d, key):
                if isinstance(d, dict):
                    for k, v in d.items():
                        if k == key:
                            yield v
                        yield from find(v, key)
            env = [shape(list(find(meta, k))[-1]["features"][0]["geometry"]) for k in ("left_envelope",
                                                                                       "right_envelope")]
            tr = Transformer.from_crs("EPSG:4326", ds.crs, always_xy=True)
            poly = shapely.transform(env[0].intersection(env[1]),
                                     lambda xy: np.column_stack(tr.transform(xy[:, 0], xy[:, 1])))
            inside = ~geometry_mask([poly], a.shape, ds.transform)
            res["footprint_overlap_m2"] = float(poly.area)
            res["valid_fraction_in_overlap"] = float((valid & inside).sum() / max(inside.sum(), 1))
        except Exception as exc:  # noqa: BLE001 -- another CARS version's metadata layout
            res["overlap_error"] = repr(exc)
    return res


def cars_facts(out_dir) -> dict:
    """What CARS measured on the pair, from its ``metadata.yaml``: the epipolar error of its sparse matches before
    its grid correction (mean, std, max in px: the pair's relative pointing error across the epipolar lines), the
    matches kept, its disparity range (px) and the epipolar disparity-to-altitude ratio (m per px)."""
    import yaml

    try:
        meta = yaml.safe_load((Path(out_dir) / "metadata.yaml").read_text())
        apps = meta["surface_modeling"]["1"]["applications"]
        mf, dr = apps["match_filtering"]["left_right"], apps["disparity_range_computation"]["left_right"]
        return {"epipolar_error_before_correction_px": {k: mf.get(f"before_correction_epi_error_{k}")
                                                        for k in ("mean", "std", "max")},
                "matches_kept": mf.get("number_matches"), "matches_raw": mf.get("raw_number_matches"),
                "disparity_range_px": [dr.get("minimum_disparity"), dr.get("maximum_disparity")],
                "disp_to_alt_ratio_m_per_px": apps["grid_generation"]["left_right"].get("disp_to_alt_ratio")}
    except (OSError, KeyError, TypeError, yaml.YAMLError) as exc:  # another CARS version's layout
        return {"metadata_error": repr(exc)}


def compare_dsms(test, ref) -> dict:
    """``dz = test − ref`` where both DSMs are valid, ``test`` resampled (nearest) onto ``ref``'s grid: count,
    median, NMAD (1.4826 · median |dz − median|), mean, share with |dz| < 1 m, and the share of ``ref``'s valid
    cells where ``test`` has a value."""
    import numpy as np
    import rasterio
    from rasterio.warp import Resampling, reproject

    def read(path):
        with rasterio.open(path) as ds:
            a = ds.read(1).astype(np.float64)
            if ds.nodata is not None:
                a[a == ds.nodata] = np.nan
            return a, ds.transform, ds.crs
    a, ta, ca = read(test)
    b, tb, cb = read(ref)
    on_ref = np.full(b.shape, np.nan)
    reproject(a, on_ref, src_transform=ta, src_crs=ca, dst_transform=tb, dst_crs=cb, src_nodata=np.nan,
              dst_nodata=np.nan, resampling=Resampling.nearest)
    both = np.isfinite(on_ref) & np.isfinite(b)
    dz = (on_ref - b)[both]
    if not dz.size:
        return {"n": 0}
    med = float(np.median(dz))
    return {"n": int(both.sum()), "dz_median_m": med, "dz_nmad_m": float(1.4826 * np.median(np.abs(dz - med))),
            "dz_mean_m": float(dz.mean()), "share_abs_dz_below_1m": float(np.mean(np.abs(dz) < 1.0)),
            "share_of_ref_area": float(both.sum() / max(1, np.isfinite(b).sum()))}


def run_inputs(img1, img2, geom1=None, geom2=None) -> list:
    """What a run was made of: ``[size in bytes, SHA-256 of the first MiB]`` of each of its inputs (None for a geom
    not given), in :func:`run_cars`'s order. Kept in ``run.json``; a kept run is reused only for the same inputs
    (:func:`finished_run`): its folder's name alone let a run of other images (another ``--rpc-cases`` rendering,
    another geom) stand for this one."""
    import hashlib
    out = []
    for p in (img1, img2, geom1, geom2):
        if p is None:
            out.append(None)
            continue
        with open(p, "rb") as f:
            out.append([os.path.getsize(p), hashlib.sha256(f.read(1 << 20)).hexdigest()])
    return out


def run_cars(img1, img2, out_dir, *, geom1=None, geom2=None, initial_height=None, margins=None,
             resolution: float = 0.5, cars: str | None = None, nice: int = 10) -> dict:
    """Run CARS on the pair (``img1``, ``img2``; RPCs in their tags or in OSSIM ``geom1``/``geom2``) into
    ``out_dir`` (created; CARS' own output in ``out_dir/out``); see the module docstring.

    Returns ``{"dsm", "wall_s", "cpu_s", "user_s", "sys_s", "peak_rss_mib", "max_rss_single_mib",
    "exit_code", "initial_height", "valid_fraction", "valid_fraction_in_overlap", "config", "log"}``, or
    ``{"skipped": reason}`` when CARS is absent. A failed run has ``"error"`` and the log's tail.
    """
    import psutil

    exe = cars or find_cars()
    if not exe:
        return {"skipped": f"CARS not found; {INSTALL_HINT}"}
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    python = os.environ.get("CARS_PYTHON") or str(Path(exe).with_name("python"))
    if not os.access(python, os.X_OK):
        return {"skipped": f"no python beside {exe} (CARS' venv); set CARS_PYTHON to the python of CARS' venv"}
    args = {"img1": str(img1), "img2": str(img2), "geom1": str(geom1 or ""), "geom2": str(geom2 or ""),
            "height": initial_height, "dem": str(out_dir / "init_dem.tif")}
    h = subprocess.run(["nice", "-n", str(nice), python, "-c", _HEIGHT_CODE, json.dumps(args)],
                       capture_output=True, text=True)
    if h.returncode:
        return {"error": "initial height failed", "log_tail": h.stderr[-2000:]}
    height = json.loads(h.stdout.strip().splitlines()[-1])
    conf = _config(img1, img2, geom1, geom2, out_dir / "init_dem.tif", out_dir / "out", margins, resolution)
    (out_dir / "conf.json").write_text(json.dumps(conf, indent=1))
    log, timing = out_dir / "cars.log", out_dir / "time.txt"
    cmd = ["nice", "-n", str(nice), "/usr/bin/time", "-v", "-o", str(timing), exe, "--loglevel", "INFO",
           "--logtype", "plain", str(out_dir / "conf.json")]
    t0 = time.perf_counter()
    with open(log, "w") as fh:
        proc = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT)
        ps, peak = psutil.Process(proc.pid), 0
        while proc.poll() is None:
            peak = max(peak, _tree_rss_mib(ps))
            time.sleep(0.5)
    rec = {"exit_code": proc.returncode, "wall_s": round(time.perf_counter() - t0, 1), "peak_rss_mib": peak,
           "initial_height": height, "margins_m": margins, "config": conf, "cars": exe, "load_avg_end": os.getloadavg(),
           "inputs": run_inputs(img1, img2, geom1, geom2)}
    (out_dir / "run.json").write_text(json.dumps(rec, default=str))
    return finished_run(out_dir)


def finished_run(out_dir, inputs=None) -> dict | None:
    """A run of :func:`run_cars` kept in ``out_dir``: what its ``run.json`` holds (wall time, peak summed memory,
    exit code, as measured while it ran; absent when the folder was kept from a run that did not write it) with
    what its files give (user + system CPU and the largest single process from ``time.txt``, the DSM, its
    completeness, CARS's own measures, the log's notes); ``None`` when the folder holds no finished run, or, with
    ``inputs`` (:func:`run_inputs`), none whose ``run.json`` says it ran on those inputs.
    Lets a benchmark reuse a run (``dsm_bench.py --cars-dir``) instead of paying CARS again."""
    out_dir = Path(out_dir)
    timing, log, dsm = out_dir / "time.txt", out_dir / "cars.log", out_dir / "out" / "dsm" / "dsm.tif"
    tv = timing.read_text() if timing.exists() else ""
    if "Exit status" not in tv:
        return None
    rec = json.loads((out_dir / "run.json").read_text()) if (out_dir / "run.json").is_file() else {}
    if inputs is not None and rec.get("inputs") != json.loads(json.dumps(inputs)):
        return None
    if "config" not in rec and (out_dir / "conf.json").is_file():
        rec["config"] = json.loads((out_dir / "conf.json").read_text())
    user, sys_ = _time_v(tv, "User time (seconds)"), _time_v(tv, "System time (seconds)")
    single = _time_v(tv, "Maximum resident set size (kbytes)")
    rec.update({"user_s": user, "sys_s": sys_, "log": str(log),
                "cpu_s": round(user + sys_, 1) if user is not None and sys_ is not None else None,
                "max_rss_single_mib": round(single / 1024) if single else None})
    lines = log.read_text(errors="replace").splitlines() if log.exists() else []
    if rec.get("exit_code", int(_time_v(tv, "Exit status") or 0)) or not dsm.exists():
        return rec | {"error": "CARS failed or wrote no DSM", "log_tail": "\n".join(lines[-20:])}
    rec["dsm"] = str(dsm)
    rec.update(_completeness(out_dir / "out", dsm))
    rec["cars_measured"] = cars_facts(out_dir / "out")
    warn = [ln for ln in lines if re.search(r"WARNING|shift|disparity", ln)]
    rec["log_notes"] = warn[-30:]
    return rec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("img1")
    ap.add_argument("img2")
    ap.add_argument("out_dir")
    ap.add_argument("--geom1")
    ap.add_argument("--geom2")
    ap.add_argument("--initial-height", type=float)
    ap.add_argument("--margins", type=int, help="disparity margins in metres (CARS default: 500 below, 1000 above)")
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "peers_cars.json"))
    a = ap.parse_args(argv)
    r = run_cars(a.img1, a.img2, a.out_dir, geom1=a.geom1, geom2=a.geom2, initial_height=a.initial_height,
                 margins=a.margins)
    if "skipped" in r:
        print("CARS skipped:", r["skipped"])
        return 0
    keys = ("exit_code", "wall_s", "cpu_s", "peak_rss_mib", "max_rss_single_mib", "valid_fraction",
            "valid_fraction_in_overlap", "dsm", "error")
    for k in keys:
        if k in r:
            print(f"{k:<28}{r[k]}")
    Path(a.json).parent.mkdir(parents=True, exist_ok=True)
    runs = json.loads(Path(a.json).read_text()) if Path(a.json).exists() else {}
    runs[Path(a.out_dir).name] = r
    Path(a.json).write_text(json.dumps(runs, indent=1, default=str))
    return 0 if "error" not in r else 1


if __name__ == "__main__":
    sys.exit(main())
