"""Registration benchmark (issue 2): fotogeo SURF vs OpenCV SIFT vs Orfeo ToolBox SURF tie points.

Run:  .venv/bin/python benchmarks/register_bench.py [--quick] [--no-otb] [--no-big] [--cases C,..] [--methods M,..]
      [--output JSON] [--merge]   (--merge: this run's rows replace the same case and method in --output, the
      others are kept; each row names the run that measured it)

Every method goes through the SAME RANSAC, robust fit, check-point hold-out, geo step,
resampling and outputs of :func:`fotogeo.tools.register.tool.register` (seed 0, default options unless
the case says otherwise):

- ``surf`` — fotogeo's default pipeline (``register(ref, tgt, out)``);
- ``sift`` — the same with OpenCV SIFT keypoints (``detector="sift"``);
- ``otb``  — ``otbcli_HomologousPointsExtraction -algorithm surf -mode full`` on the very
  single-band images fotogeo matches (the decimated read + PCA fusion + ``adaptive`` contrast
  of ``register``'s own matching step, rounded to uint8, written WITHOUT georeference), with
  ``-threshold`` = fotogeo's ratio (0.8) and ``-backmatching`` = fotogeo's ``mutual`` (on). Its
  pairs are scaled back to full-resolution pixels and given to
  ``register(..., tie_points=(target_xy, reference_xy))``. Why no georeference: with a
  georeferenced input OTB writes map ("physical") coordinates instead of pixels and even
  detects a different set of keypoints (the raw NGI frames carry an approximate, rotated
  georeference). Without one it writes GDAL corner-convention pixel coordinates (checked
  here: a 180-degree self-match gives x1 + x2 = W exactly). OTB gets no validity mask
  (nodata pixels are 0); fotogeo and SIFT get the mask.

Pairs: NGI frames 0182 / 0184 -> orthophoto tiles 1 / 2 (truth = camera + exterior orientation
+ DEM, ``truth_points`` of tests/ngi_truth.py); Sentinel-2 (10 m) -> NGI orthophoto 1
(5 m); s2_pair (two dates, nodata 0, affine); Landsat RGB under the known synthetic warp of
tests/test_register.py (exact truth); the synthetic demo scene (``fotogeo.tools.demo.tool``).

Reported per pair and method: keypoints (reference/target), descriptor matches, inliers,
check-point RMSE (m and reference px), for cases with truth the dense-grid RMSE of the fitted
model against the truth, the best homography's RMSE on the same grid and their ratio (target
of issue 2: <= 1.3x), the share of raw matches within 3 reference pixels of the truth
("correct"), time per stage (``timings_s`` of the report, plus fusion and the OTB call for
OTB), and the peak memory (max RSS) of the process that ran the case: each case runs in its
own fresh Python subprocess; OTB's own peak is reported separately (its process is a child).

Big image: a 20000x20000 3-band uint8 tiled DEFLATE GeoTIFF (the central 640x640 of NGI frame
0182 upsampled 31.25x by ``gdal_translate``, which streams, so the generator stays small) is
registered to orthophoto tile 1 in a subprocess; peak RSS and the peak reached by each stage
(VmHWM read from /proc at every progress message) are reported. Requirement: well under 2 GB.

Writes benchmarks/results/register_bench.json (``--output``) and prints tables.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "benchmarks" / "results" / "register_bench.json"
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # truth helpers shared with the tests
SNAPSHOT_ENV = "FOTOGEO_BENCH_SNAPSHOT"  # a frozen copy of fotogeo/ (and tests/) the whole run imports
if os.environ.get(SNAPSHOT_ENV):
    sys.path[:0] = [os.environ[SNAPSHOT_ENV], str(Path(os.environ[SNAPSHOT_ENV]) / "tests")]

METHODS = ("surf", "sift", "otb", "otb180")
OTB_EXE = "otbcli_HomologousPointsExtraction"
NGI_FRAMES = {"ngi_0182": ("3324c_2015_1004_05_0182", "ngi_rgb_byte_1.tif"),
              "ngi_0184": ("3324c_2015_1004_05_0184", "ngi_rgb_byte_2.tif")}
BIG_SIZE = 20000
CAPPED_CACHE_MB = 256
CORRECT_TOL_PX = 3.0  # reference pixels, = register's RANSAC threshold


# ------------------------------------------------------------------------------ memory
def _status_mb(key: str) -> float:
    """VmHWM / VmRSS of this process from /proc (MB)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _maxrss_mb(who=resource.RUSAGE_SELF) -> float:
    return resource.getrusage(who).ru_maxrss / 1024.0  # Linux: kilobytes


# ------------------------------------------------------------------------------ inputs
def make_landsat_pair(folder: Path):
    """Landsat RGB under the known warp of tests/synthetic_pair.py; returns (reference, target, H)
    with H: target px -> reference px."""
    from synthetic_pair import make_landsat_pair as make
    return make(DATA / "landsat_rgb" / "RGB.byte.tif", folder)


def build_cases(tmp: Path, quick: bool):
    from fotogeo.tools.demo.tool import make_scene
    ngi = DATA / "ngi"
    cases = []
    for key, (name, ortho) in NGI_FRAMES.items():
        cases.append(dict(name=key, reference=str(ngi / "ortho" / ortho),
                          target=str(ngi / "frames" / f"{name}_RGB.tif"), options={},
                          truth={"kind": "ngi", "frame": name}, otb180=True))
    if not quick:
        cases.append(dict(name="s2_to_ngi", reference=str(ngi / "ortho" / "ngi_rgb_byte_1.tif"),
                          target=str(ngi / "sentinel2_b432_byte.tif"), options={},
                          truth={"kind": "georef", "crs": "EPSG:32735"}))
        s2 = DATA / "s2_pair"
        cases.append(dict(name="s2_pair", reference=str(s2 / "ref_S2A_20160608T153121_T33UUU_sub.jp2"),
                          target=str(s2 / "tgt_S2A_20160529T153631_T33UUU_sub.jp2"),
                          options=dict(reference_nodata=0, target_nodata=0, model="affine"),
                          truth={"kind": "georef", "crs": "EPSG:32633"}))
        ref, tgt, H = make_landsat_pair(tmp)
        cases.append(dict(name="landsat_warp", reference=str(ref), target=str(tgt), options={},
                          truth={"kind": "homography", "H": H.tolist()}))
    scene = make_scene(tmp / "demo", seed=7)
    cases.append(dict(name="demo", reference=str(scene.reference), target=str(scene.target), options={},
                      truth={"kind": "demo", "seed": 7}))
    return cases


# ------------------------------------------------------------------------------ truth
class Truth:
    """target pixel (corner convention) -> true map XY in the output CRS, and a dense grid."""

    def __init__(self, case, tmp: Path):
        self.kind = case["truth"]["kind"]
        t = case["truth"]
        if self.kind == "georef":  # approximate: the target's own georeference (orthoimages)
            from pyproj import CRS
            from fotogeo.pixels import pixel_centres
            from fotogeo.io.raster import open_raster
            info = open_raster(case["target"])
            self.t_tgt, self.tgt_crs, self.crs = info.transform, info.crs, t["crs"]
            self.out_crs = CRS.from_user_input(self.crs)
            x, y = pixel_centres(info.width // 50, info.height // 50)
            self.grid = np.column_stack([x.ravel(), y.ravel()]) * 50
            self.truth = self(self.grid)
        elif self.kind == "ngi":
            from pyproj import CRS
            from fotogeo.io.camera import load_ngi_frame
            from fotogeo.io.raster import read_dem
            from ngi_truth import truth_points  # tests/ngi_truth.py, shared with the tests
            ngi = DATA / "ngi"
            self.dem = read_dem(ngi / "dem.tif")
            self.frame = load_ngi_frame(ngi, t["frame"])
            self.src_crs, self.dst_crs = CRS.from_wkt(self.dem.crs.to_wkt()), CRS.from_epsg(32735)
            self.crs = "EPSG:32735"
            self.grid, xyz = truth_points(ngi, t["frame"], step=10, crs=32735)
            self.truth = xyz[:, :2]
            # a target made from a crop of the frame, scaled: frame px = offset + target px * scale
            self.offset, self.scale = np.asarray(t.get("offset", (0.0, 0.0)), float), float(t.get("scale", 1.0))
            if "scale" in t:
                g = (self.grid - self.offset) / self.scale
                ok = ((g >= 0) & (g <= t["size"])).all(axis=1)
                self.grid, self.truth = g[ok], self.truth[ok]
        elif self.kind == "homography":
            import rasterio
            from fotogeo.pixels import pixel_centres
            self.H = np.array(t["H"])
            with rasterio.open(case["reference"]) as ds:
                self.t_ref, self.crs = ds.transform, ds.crs.to_string()
            x, y = pixel_centres(64, 60)  # as tests/test_register.py
            self.grid = np.column_stack([x.ravel(), y.ravel()]) * 10
            self.truth = self(self.grid)
        elif self.kind == "demo":
            from fotogeo.tools.demo.tool import make_scene
            from fotogeo.pixels import pixel_centres
            self.scene = make_scene(tmp / "demo_truth", seed=t["seed"])
            self.crs = "EPSG:32635"
            x, y = pixel_centres(90, 70)  # as fotogeo.tools.demo.tool.truth_comparison (step 10)
            grid = np.column_stack([x.ravel(), y.ravel()]) * 10
            truth = self(grid)
            ok = np.isfinite(truth).all(axis=1)
            self.grid, self.truth = grid[ok], truth[ok]

    def __call__(self, xy):
        xy = np.asarray(xy, float).reshape(-1, 2)
        if self.kind == "georef":
            from fotogeo.crs import transform_points
            from fotogeo.pixels import pixel_to_map
            return transform_points(self.tgt_crs, self.out_crs, pixel_to_map(self.t_tgt, xy))
        if self.kind == "ngi":
            from fotogeo.crs import transform_points
            g = self.frame.pixel_to_world(self.offset + xy * self.scale, self.dem)[:, :2]
            out = np.full_like(g, np.nan)
            ok = np.isfinite(g).all(axis=1)
            if ok.any():
                out[ok] = transform_points(self.src_crs, self.dst_crs, g[ok])
            return out
        if self.kind == "homography":
            from synthetic_pair import apply_h as _apply
            from fotogeo.pixels import pixel_to_map
            return pixel_to_map(self.t_ref, _apply(self.H, xy))
        return self.scene.frame.pixel_to_world(xy, self.scene.dem)[:, :2]

    def in_crs(self, crs: str) -> "Truth":
        """This truth with its dense grid's true positions in ``crs`` (register writes in the reference's CRS, e.g.
        the NGI orthophotos' transverse Mercator, not the UTM zone the truth is made in); raw matches are still
        judged in :attr:`crs` (:meth:`correct_share`)."""
        import copy
        from pyproj import CRS
        from fotogeo.crs import transform_points
        if CRS.from_user_input(crs) == CRS.from_user_input(self.crs):
            return self
        out = copy.copy(self)
        out.truth = transform_points(CRS.from_user_input(self.crs), CRS.from_user_input(crs), self.truth)
        return out

    def evaluate(self, model, reference, raw=None) -> dict:
        from fotogeo.models import Projective
        rms = lambda e: float(np.sqrt(np.mean(np.asarray(e) ** 2)))  # noqa: E731
        dense = rms(model.residuals(self.grid, self.truth))
        if self.kind == "georef":  # not a truth: only the distance from the target's own georeference
            out = {"georef_rmse_m": dense}
        else:
            best = rms(Projective.estimate(self.grid, self.truth).residuals(self.grid, self.truth))
            out = {"n_grid": int(len(self.grid)), "dense_rmse_m": dense, "best_homography_rmse_m": best}
            if best > 1e-6 * max(1.0, dense):
                out["dense_over_best"] = dense / best
        if raw is not None and len(raw["target_xy"]):
            out.update(self.correct_share(raw, reference))
        return out

    def correct_share(self, raw, reference) -> dict:
        """Raw matches whose reference position lies within CORRECT_TOL_PX of the true position."""
        from pyproj import CRS
        from fotogeo.crs import pixel_size_in, transform_points
        from fotogeo.pixels import pixel_to_map
        from fotogeo.io.raster import open_raster
        ref = open_raster(reference)
        crs = CRS.from_user_input(self.crs)
        px = pixel_size_in(ref.transform, ref.crs, crs, ref.width / 2, ref.height / 2)
        got = transform_points(ref.crs, crs, pixel_to_map(ref.transform, raw["reference_xy"]))
        err = np.hypot(*(self(raw["target_xy"]) - got).T)
        err = np.where(np.isfinite(err), err, np.inf)
        return {"raw_matches": int(len(err)), "raw_correct": int(np.sum(err <= CORRECT_TOL_PX * px)),
                "raw_correct_share": float(np.mean(err <= CORRECT_TOL_PX * px)),
                "raw_correct_against": "target georeference (approximate)" if self.kind == "georef" else "truth"}


# ------------------------------------------------------------------------------ worker
def matching_image(info, role, opts):
    """The single-band image and validity mask register's matching step hands to the detector,
    and the decimation factor: fotogeo's own ``_features`` runs with ``detect`` intercepted (so the
    benchmark follows any change of the read / fusion / contrast steps)."""
    import fotogeo.tools.register.match as fr
    from fotogeo.progress import as_progress
    from fotogeo.features.detect import Keypoints
    seen = {}

    def intercept(image, mask, *args, **kwargs):
        seen["image"], seen["mask"] = image, mask
        return Keypoints(np.zeros((0, 2)), np.zeros((0, 64), np.float32), None)

    original = fr.detect
    fr.detect = intercept
    try:
        _, factor, _ = fr._features(info, role, opts, as_progress(None))
    finally:
        fr.detect = original
    mask = seen["mask"] if seen["mask"] is not None else np.ones(seen["image"].shape, bool)
    return seen["image"], np.asarray(mask, bool), np.asarray(factor, float)


def otb_tie_points(reference, target, opts, work: Path, timings: dict, prerotate: bool = False):
    """OTB SURF pairs on the images fotogeo matches; (target_xy, reference_xy, info) in
    full-resolution corner-convention pixels."""
    import rasterio
    from fotogeo.io.raster import open_raster
    exe = shutil.which(OTB_EXE)
    if exe is None:
        raise RuntimeError(f"{OTB_EXE} not found (Debian package otb-bin)")
    paths, factors = {}, {}
    for role, path in (("reference", reference), ("target", target)):
        t0 = time.perf_counter()
        image, valid, factor = matching_image(open_raster(path, role), role, opts)
        img = np.clip(np.round(image), 0, 255).astype(np.uint8)
        img[~valid] = 0
        if role == "target" and prerotate:  # diagnostic only: undo a known ~180 degree rotation
            img = np.ascontiguousarray(img[::-1, ::-1])
            sizes = np.array([img.shape[1], img.shape[0]], float)
        p = work / f"otb_{role}.tif"
        with rasterio.open(p, "w", driver="GTiff", width=img.shape[1], height=img.shape[0], count=1,
                           dtype="uint8") as ds:  # no CRS / transform on purpose: pixel output
            ds.write(img, 1)
        paths[role], factors[role] = p, np.asarray(factor, float)
        timings[f"read_fuse_{role}"] = time.perf_counter() - t0
        del image, valid, img
    pairs_txt = work / "otb_pairs.txt"
    cmd = [exe, "-in1", str(paths["target"]), "-in2", str(paths["reference"]), "-out", str(pairs_txt),
           "-algorithm", "surf", "-mode", "full", "-threshold", str(opts.ratio),
           "-backmatching", "1" if opts.mutual else "0"]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    timings["otb"] = time.perf_counter() - t0
    log = p.stdout + p.stderr
    found = [int(line.split("Found ")[1].split()[0]) for line in log.splitlines() if "surf points in image" in line]
    info = {"command": " ".join(["otbcli_HomologousPointsExtraction"] + cmd[1:]), "returncode": p.returncode,
            "keypoints_target": found[0] if len(found) > 0 else None,
            "keypoints_reference": found[1] if len(found) > 1 else None,
            "otb_peak_mb": _maxrss_mb(resource.RUSAGE_CHILDREN)}
    if p.returncode != 0:
        info["log_tail"] = log.strip().splitlines()[-5:]
        raise RuntimeError(f"OTB exited with code {p.returncode}: {' | '.join(info['log_tail'])}")
    pairs = np.loadtxt(pairs_txt, ndmin=2) if pairs_txt.exists() and pairs_txt.stat().st_size else np.zeros((0, 4))
    pairs = pairs.reshape(-1, 4)
    info["pairs"] = int(len(pairs))
    if prerotate:  # corner convention: a 180 degree rotation maps x to W - x
        pairs[:, :2] = sizes - pairs[:, :2]
    return pairs[:, :2] * factors["target"], pairs[:, 2:] * factors["reference"], info


def worker(spec_path: str):
    """One case x method in this (fresh) process; writes a JSON result next to the spec."""
    spec = json.loads(Path(spec_path).read_text())
    import warnings
    warnings.simplefilter("ignore")
    import cv2  # noqa: F401 - imports first, so that the baseline memory includes them
    import rasterio  # noqa: F401
    from fotogeo.errors import FotogeoError
    from fotogeo.tools.register.tool import RegisterOptions, register
    from fotogeo.tools.register.match import find_tie_points
    from fotogeo.io.raster import open_raster
    work = Path(spec["work"])
    method = spec["method"]
    base_mb = _status_mb("VmRSS")
    stages, last = [], ["imports"]  # (stage, peak RSS reached by the END of that stage)

    def mark(key):
        if key != last[0]:
            stages.append((last[0], round(_status_mb("VmHWM"), 1)))
            last[0] = key

    def progress(fraction, message):
        mark(message.split(" window")[0])
        return True

    import fotogeo
    res = {"case": spec["name"], "method": method, "ok": False, "base_rss_mb": base_mb,
           "fotogeo_imported_from": str(Path(fotogeo.__file__).parent)}
    opts = dict(seed=0, **spec["options"])
    if method in ("surf", "sift"):
        opts["detector"] = method
    out = work / "out.tif"
    timings, t0 = {}, time.perf_counter()
    try:
        if method.startswith("otb"):
            mark("fusion + OTB")
            tgt_xy, ref_xy, info = otb_tie_points(spec["reference"], spec["target"], RegisterOptions(**opts),
                                                  work, timings, prerotate=method == "otb180")
            res["otb"] = info
            res["raw"] = {"target_xy": tgt_xy.tolist(), "reference_xy": ref_xy.tolist()}
            mark("register(tie_points)")
            r = register(spec["reference"], spec["target"], out, tie_points=(tgt_xy, ref_xy), progress=progress,
                         **opts)
        else:
            r = register(spec["reference"], spec["target"], out, progress=progress, **opts)
        wall = time.perf_counter() - t0
        res["peak_rss_mb"] = _maxrss_mb()
        mark("end")
        rep = r.report
        timings.update(rep["timings_s"])
        res.update(ok=True, wall_s=wall, report={k: rep.get(k) for k in (
            "keypoints", "matches", "inliers", "ransac", "check", "control", "model", "output_crs",
            "output_grid", "reference_pixel_size", "robust_sigma_m", "corner_standard_error_px", "area_based",
            "windows_check", "refine")})
        if method.startswith("otb"):
            res["report"]["keypoints"] = {"reference": res["otb"]["keypoints_reference"],
                                          "target": res["otb"]["keypoints_target"]}
        if spec.get("raw_matches") and not method.startswith("otb"):  # after the measurement: same opts -> same matches
            tx, rx, _ = find_tie_points(open_raster(spec["reference"]), open_raster(spec["target"]),
                                        RegisterOptions(**opts))
            res["raw"] = {"target_xy": tx.tolist(), "reference_xy": rx.tolist()}
    except (FotogeoError, RuntimeError, subprocess.TimeoutExpired) as e:
        res["error"] = f"{type(e).__name__}: {e}"
        res["peak_rss_mb"] = _maxrss_mb()
        res["wall_s"] = time.perf_counter() - t0
    res["timings_s"] = timings
    res["stage_peak_mb"] = stages
    if method.startswith("otb") and "otb" in res:
        res["otb"]["otb_peak_mb"] = _maxrss_mb(resource.RUSAGE_CHILDREN)
    Path(spec["result"]).write_text(json.dumps(res))


def run_case(case, method, tmp: Path, env=None, raw_matches=False):
    work = Path(tempfile.mkdtemp(prefix=f"{case['name']}_{method}_", dir=tmp))
    spec = dict(case, method=method, work=str(work), result=str(work / "result.json"), raw_matches=raw_matches)
    (work / "spec.json").write_text(json.dumps(spec))
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--worker", str(work / "spec.json")],
                       capture_output=True, text=True, env=env)
    dt = time.perf_counter() - t0
    if p.returncode != 0 or not (work / "result.json").exists():
        res = {"case": case["name"], "method": method, "ok": False,
               "error": f"worker crashed (exit {p.returncode}): {p.stderr.strip()[-600:]}"}
    else:
        res = json.loads((work / "result.json").read_text())
    res["process_s"] = dt
    shutil.rmtree(work, ignore_errors=True)
    return res


# ------------------------------------------------------------------------------ summary
def summarise(res, truth, case):
    """Flat numbers for the table (and the JSON) from a worker result."""
    t = res.get("timings_s", {})
    s = {"ok": res["ok"], "peak_rss_mb": res.get("peak_rss_mb"), "base_rss_mb": res.get("base_rss_mb"),
         "error": res.get("error")}
    if res["method"].startswith("otb"):
        o = res.get("otb", {})
        s.update(otb_peak_mb=o.get("otb_peak_mb"), otb_pairs=o.get("pairs"),
                 keypoints=[o.get("keypoints_reference"), o.get("keypoints_target")])
        features = t.get("read_fuse_reference", 0) + t.get("read_fuse_target", 0) + t.get("otb", 0)
        s["time_s"] = {"features_and_matching": features, "otb_call": t.get("otb"), "fit": t.get("fit"),
                       "resample": t.get("resample"),
                       "total": features + t.get("total", 0) if "total" in t else None}
    else:
        features = sum(t.get(k, 0) for k in ("read_fuse_reference", "detect_reference", "read_fuse_target",
                                             "detect_target", "match"))
        s["time_s"] = {"features_and_matching": features if t else None,
                       "read_fuse": t.get("read_fuse_reference", 0) + t.get("read_fuse_target", 0) if t else None,
                       "detect": t.get("detect_reference", 0) + t.get("detect_target", 0) if t else None,
                       "match": t.get("match"), "fit": t.get("fit"), "resample": t.get("resample"),
                       "total": t.get("total")}
    if res["ok"]:
        rep = res["report"]
        kp = rep["keypoints"]
        s.update(keypoints=[kp.get("reference"), kp.get("target")], matches=rep["matches"], inliers=rep["inliers"],
                 check_n=rep["check"].get("n"), check_rmse_m=rep["check"].get("rmse_m"),
                 check_rmse_px=rep["check"].get("rmse_px"), weak_fit=weak_fit(rep))
        if truth is not None:
            from fotogeo.models import model_from_dict
            s.update(truth.in_crs(rep["output_crs"]).evaluate(model_from_dict(rep["model"]), case["reference"],
                                                               res.get("raw")))
    elif truth is not None and res.get("raw"):
        s.update(truth.correct_share(res["raw"], case["reference"]))
    return s


def weak_fit(rep) -> dict | None:
    """What register's weak-fit check did (``None``: the feature fit was strong, the windows never ran)."""
    se = rep.get("corner_standard_error_px")
    if rep.get("windows_check"):
        return {"corner_se_px": se, "kept": "feature fit", **{k: rep["windows_check"].get(k) for k in (
            "feature_fit_rmse_px", "windows_fit_rmse_px", "at")}}
    area = rep.get("area_based")
    if area:
        c = area.get("compared") or {}
        return {"why": area.get("why"), "corner_se_px": c.get("feature_fit_corner_se_px"), "kept": "windows",
                "feature_fit_rmse_px": c.get("feature_fit_rmse_px"),
                "windows_fit_rmse_px": c.get("windows_fit_rmse_px"), "at": c.get("at"),
                "window_tie_points": rep.get("matches")}
    return None


def merge_rows(output: Path, rows: list, run: dict) -> tuple[list, list]:
    """The rows of ``output`` (an earlier run's JSON) with this run's rows in place of the same (case, method)
    and the others kept, each tagged with the run that measured it (``measured``); and the runs merged."""
    old = json.loads(output.read_text())
    first = {k: old.get(k) for k in ("command", "date", "source")}
    runs = old.get("runs") or [first]
    for r in rows:
        r["measured"] = run
    new = {(r["case"], r["method"]): r for r in rows}
    kept = [{**r, "measured": r.get("measured", first)} for r in old["rows"] if (r["case"], r["method"]) not in new]
    order = [(r["case"], r["method"]) for r in old["rows"]]
    merged = sorted(kept + rows, key=lambda r: order.index((r["case"], r["method"]))
                    if (r["case"], r["method"]) in order else len(order))
    return merged, runs + [run]


def fmt(x, spec="{:.2f}", none="-"):
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return none
    return spec.format(x)


def print_table(rows):
    hdr = (f"{'case':<13}{'method':<6}{'kp ref/tgt':>14}{'match':>7}{'inl':>6}{'chk':>5}{'chk m':>8}{'chk px':>8}"
           f"{'dense m':>9}{'best m':>8}{'d/best':>7}{'corr%':>7}{'t feat':>8}{'t fit':>7}{'t res':>7}"
           f"{'t tot':>8}{'peak MB':>9}")
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        s = r["summary"]
        kp = s.get("keypoints") or [None, None]
        kps = f"{fmt(kp[0], '{:d}')}/{fmt(kp[1], '{:d}')}"
        t = s["time_s"]
        peak = fmt(s["peak_rss_mb"], "{:.0f}")
        if r["method"].startswith("otb") and s.get("otb_peak_mb") is not None:
            peak += f"+{s['otb_peak_mb']:.0f}"
        corr = fmt(100 * s["raw_correct_share"], "{:.0f}") if "raw_correct_share" in s else "-"
        if s.get("raw_correct_against", "truth") != "truth":
            corr = "~" + corr  # against the target's own georeference, not a truth
        print(f"{r['case']:<13}{r['method']:<6}{kps:>14}{fmt(s.get('matches', s.get('otb_pairs')), '{:d}'):>7}"
              f"{fmt(s.get('inliers'), '{:d}'):>6}{fmt(s.get('check_n'), '{:d}'):>5}{fmt(s.get('check_rmse_m')):>8}"
              f"{fmt(s.get('check_rmse_px')):>8}{fmt(s.get('dense_rmse_m')):>9}{fmt(s.get('best_homography_rmse_m')):>8}"
              f"{fmt(s.get('dense_over_best')):>7}{corr:>7}{fmt(t.get('features_and_matching')):>8}"
              f"{fmt(t.get('fit')):>7}{fmt(t.get('resample')):>7}{fmt(t.get('total')):>8}{peak:>9}")
        if not s["ok"]:
            print(f"{'':<19}FAILED: {s['error'][:240]}")


def ratios(rows):
    """fotogeo SURF / peer for total time, check RMSE, dense RMSE, peak memory."""
    by = {(r["case"], r["method"]): r["summary"] for r in rows}
    out = []
    for case in dict.fromkeys(r["case"] for r in rows):
        ours = by.get((case, "surf"))
        for peer in ("sift", "otb", "otb180"):
            other = by.get((case, peer))
            if not ours or not other:
                continue

            def q(a, b):
                return a / b if (a is not None and b not in (None, 0) and ours["ok"] and other["ok"]) else None
            out.append({"case": case, "peer": peer,
                        "time": q(ours["time_s"]["total"], other["time_s"]["total"]),
                        "check_rmse": q(ours.get("check_rmse_m"), other.get("check_rmse_m")),
                        "dense_rmse": q(ours.get("dense_rmse_m"), other.get("dense_rmse_m")),
                        "peak_mb": q(ours.get("peak_rss_mb"), other.get("peak_rss_mb")),
                        "peer_failed": not other["ok"]})
    return out


def print_ratios(rat):
    print(f"\n{'case':<13}{'fotogeo SURF / ':<15}{'time':>7}{'check RMSE':>12}{'dense RMSE':>12}{'peak MB':>9}")
    for r in rat:
        note = "  (peer failed)" if r["peer_failed"] else ""
        print(f"{r['case']:<13}{r['peer']:<15}{fmt(r['time']):>7}{fmt(r['check_rmse']):>12}"
              f"{fmt(r['dense_rmse']):>12}{fmt(r['peak_mb']):>9}{note}")


# ------------------------------------------------------------------------------ big image
def make_big_target(path: Path, size: int = BIG_SIZE):
    """Central 640x640 of frame 0182, upsampled (bilinear) to size x size, tiled + DEFLATE."""
    frame = DATA / "ngi" / "frames" / "3324c_2015_1004_05_0182_RGB.tif"
    import rasterio
    with rasterio.open(frame) as ds:
        w, h = ds.width, ds.height
    side = min(w, h)
    x0, y0 = (w - side) // 2, (h - side) // 2
    cmd = ["gdal_translate", "-q", "--config", "GDAL_CACHEMAX", "256", "-srcwin", str(x0), str(y0), str(side),
           str(side), "-outsize", str(size), str(size), "-r", "bilinear", "-co", "TILED=YES",
           "-co", "COMPRESS=DEFLATE", "-co", "BIGTIFF=YES", "-co", "NUM_THREADS=2", str(frame), str(path)]
    t0 = time.perf_counter()
    p = subprocess.run(["/usr/bin/time", "-f", "%M"] + cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"gdal_translate failed: {p.stderr}")
    return {"seconds": time.perf_counter() - t0, "generator_peak_mb": int(p.stderr.strip().splitlines()[-1]) / 1024,
            "file_mb": path.stat().st_size / 2 ** 20, "crop": [x0, y0, side, side], "size": size}


def probe_read(path: str, result: str):
    """Subprocess: fotogeo's decimated read of ``path`` against the same read done in strips of
    256 output rows under a 256 MB GDAL cache (a candidate fix); time, peak RSS, equality."""
    import warnings
    warnings.simplefilter("ignore")
    import rasterio
    from rasterio.enums import Resampling
    from rasterio.windows import Window
    from fotogeo.io.raster import open_raster, read_decimated
    info = open_raster(path)
    out = {"base_rss_mb": _status_mb("VmRSS")}
    t0 = time.perf_counter()
    with rasterio.Env(GDAL_CACHEMAX=CAPPED_CACHE_MB * 2 ** 20):  # bytes when given as an int
        with rasterio.open(path) as ds:
            factor = max(1.0, float(np.sqrt(ds.width * ds.height / 16_000_000)))  # as read_decimated
            ow, oh = max(1, int(round(ds.width / factor))), max(1, int(round(ds.height / factor)))
            fy = ds.height / oh
            strips = np.empty((ds.count, oh, ow), np.dtype(ds.dtypes[0]))
            for i0 in range(0, oh, 256):
                i1 = min(oh, i0 + 256)
                strips[:, i0:i1] = ds.read(window=Window(0, i0 * fy, ds.width, (i1 - i0) * fy),
                                           out_shape=(ds.count, i1 - i0, ow), resampling=Resampling.average)
    out["strips_s"], out["strips_peak_mb"] = time.perf_counter() - t0, _status_mb("VmHWM")
    t0 = time.perf_counter()
    bands, _, _ = read_decimated(info, 16_000_000)
    out["read_decimated_s"], out["read_decimated_peak_mb"] = time.perf_counter() - t0, _status_mb("VmHWM")
    out["identical"] = bool(np.array_equal(bands, strips))
    Path(result).write_text(json.dumps(out))


def big_image(tmp: Path):
    target = tmp / "big_20000.tif"
    gen = make_big_target(target)
    x0, y0, side, _ = gen["crop"]
    case = dict(name="big_20000", reference=str(DATA / "ngi" / "ortho" / "ngi_rgb_byte_1.tif"),
                target=str(target), options={},
                truth={"kind": "ngi", "frame": "3324c_2015_1004_05_0182", "offset": [x0, y0],
                       "scale": side / BIG_SIZE, "size": BIG_SIZE})
    res = run_case(case, "surf", tmp)
    # the same run with GDAL's block cache bounded (GDAL_CACHEMAX defaults to 5 % of the RAM)
    capped = run_case(case, "surf", tmp, env=dict(os.environ, GDAL_CACHEMAX=str(CAPPED_CACHE_MB)))
    probe_json = tmp / "probe.json"
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--probe-read", str(target), str(probe_json)],
                   check=True)
    probe = json.loads(probe_json.read_text())
    truth = Truth(case, tmp)
    for r in (res, capped):
        r["summary"] = summarise(r, truth, case)
    out = {"generation": gen, "result": res, "result_gdal_cachemax_256mb": capped, "read_probe": probe,
           "gdal_cachemax_default_note": "GDAL default block cache = 5 % of physical RAM",
           "physical_ram_mb": os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2 ** 20}
    target.unlink(missing_ok=True)
    return out


def print_big(big):
    g = big["generation"]
    print(f"\nBig image: {g['size']}x{g['size']}x3 uint8 tiled DEFLATE target (central {g['crop'][2]}x{g['crop'][3]} of "
          f"frame 0182 upsampled; {g['file_mb']:.0f} MB on disk, generated in {g['seconds']:.1f} s, generator peak "
          f"{g['generator_peak_mb']:.0f} MB) -> NGI ortho tile 1; machine RAM {big['physical_ram_mb']:.0f} MB")
    for label, key in (("default environment", "result"),
                       (f"GDAL_CACHEMAX={CAPPED_CACHE_MB} MB", "result_gdal_cachemax_256mb")):
        r = big[key]
        print(f"  [{label}]")
        if r["ok"]:
            rep, t, s = r["report"], r["timings_s"], r["summary"]
            print(f"    keypoints ref/tgt {rep['keypoints']['reference']}/{rep['keypoints']['target']}, matches "
                  f"{rep['matches']}, inliers {rep['inliers']}, check RMSE {fmt(rep['check'].get('rmse_m'))} m "
                  f"({fmt(rep['check'].get('rmse_px'))} px), dense {fmt(s.get('dense_rmse_m'))} m vs best homography "
                  f"{fmt(s.get('best_homography_rmse_m'))} m ({fmt(s.get('dense_over_best'))}x)")
            print("    time: " + ", ".join(f"{k} {v:.1f} s" for k, v in t.items()))
        else:
            print(f"    FAILED: {r['error']}")
        peak = r.get("peak_rss_mb")
        print(f"    peak RSS {fmt(peak, '{:.0f}')} MB (after imports {fmt(r.get('base_rss_mb'), '{:.0f}')} MB); "
              f"limit 2048 MB -> {'under' if peak is not None and peak < 2048 else 'EXCEEDED'}")
        print("    peak RSS by the end of each stage (MB): "
              + ", ".join(f"{k}: {v:.0f}" for k, v in r.get("stage_peak_mb", [])))
    p = big["read_probe"]
    print(f"  decimated read of the target alone (fresh process, after imports {p['base_rss_mb']:.0f} MB): in strips of "
          f"256 rows under a {CAPPED_CACHE_MB} MB GDAL cache {p['strips_s']:.1f} s, peak {p['strips_peak_mb']:.0f} MB; "
          f"then fotogeo's read_decimated (default cache) {p['read_decimated_s']:.1f} s, peak "
          f"{p['read_decimated_peak_mb']:.0f} MB; identical arrays: {p['identical']}")


# ------------------------------------------------------------------------------ main
def source_state(root: Path = ROOT) -> dict:
    """git HEAD, uncommitted fotogeo files and a hash of fotogeo's sources under ``root``."""
    import hashlib
    h = hashlib.sha256()
    for f in sorted((root / "fotogeo").rglob("*.py")):
        h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes())

    def git(*args):
        p = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)
        return p.stdout.strip() if p.returncode == 0 else None
    status = git("status", "--porcelain", "--", "fotogeo")
    return {"git_head": git("rev-parse", "--short", "HEAD"), "fotogeo_sha256": h.hexdigest()[:16],
            "fotogeo_uncommitted": status.splitlines() if status else []}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="only the NGI frames and the demo scene, no big image")
    ap.add_argument("--no-otb", action="store_true", help="skip Orfeo ToolBox")
    ap.add_argument("--no-big", action="store_true", help="skip the 20000x20000 memory check")
    ap.add_argument("--big-only", action="store_true", help="only the 20000x20000 memory check (prints, writes no JSON)")
    ap.add_argument("--cases", help="comma-separated case names to run (default: all)")
    ap.add_argument("--methods", help=f"comma-separated methods to run, of {','.join(METHODS)} (default: all)")
    ap.add_argument("--output", type=Path, default=OUT, help=f"the JSON to write (default {OUT.relative_to(ROOT)})")
    ap.add_argument("--merge", action="store_true",
                    help="keep the rows of --output this run does not measure (same case and method: replaced)")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--probe-read", nargs=2, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        return worker(a.worker)
    if a.probe_read:
        return probe_read(*a.probe_read)
    if not DATA.is_dir():
        sys.exit(f"real data not found at {DATA} (set FOTOGEO_DATA)")
    methods = [m for m in METHODS if not (m.startswith("otb") and a.no_otb)
               and (not a.methods or m in a.methods.split(","))]
    if a.merge and not a.output.is_file():
        sys.exit(f"--merge: {a.output} does not exist (run without --merge first)")
    if "otb" in methods and shutil.which(OTB_EXE) is None:
        print(f"note: {OTB_EXE} not on PATH (apt-get install otb-bin); OTB skipped")
        methods = [m for m in methods if not m.startswith("otb")]
    t_start = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="register_bench_") as td:
        tmp = Path(td)
        # Several engineers share the tree: the whole run (this process and every worker) imports
        # one frozen copy of fotogeo/ and tests/, taken now; its hash is recorded.
        snap = tmp / "snapshot"
        for d in ("fotogeo", "tests"):
            shutil.copytree(ROOT / d, snap / d, ignore=shutil.ignore_patterns("__pycache__"))
        state = source_state()
        state["snapshot_sha256"] = source_state(snap)["fotogeo_sha256"]
        os.environ[SNAPSHOT_ENV] = str(snap)
        sys.path[:0] = [str(snap), str(snap / "tests")]
        import fotogeo
        assert Path(fotogeo.__file__).resolve().is_relative_to(snap.resolve()), fotogeo.__file__
        print(f"fotogeo source: git {state['git_head']}, snapshot sha256 {state['snapshot_sha256']}, "
              f"uncommitted: {', '.join(state['fotogeo_uncommitted']) or 'none'}", flush=True)
        cases = [] if a.big_only else build_cases(tmp, a.quick)
        if a.cases:
            cases = [c for c in cases if c["name"] in a.cases.split(",")]
        for case in cases:
            truth = Truth(case, tmp) if case["truth"] else None
            for m in [m for m in methods if m != "otb180" or case.get("otb180")]:
                res = run_case(case, m, tmp, raw_matches=truth is not None)
                s = summarise(res, truth, case)
                rows.append({"case": case["name"], "method": m, "summary": s,
                             "timings_s": res.get("timings_s"), "stage_peak_mb": res.get("stage_peak_mb"),
                             "otb": {k: v for k, v in res.get("otb", {}).items()} or None,
                             "options": case["options"], "fotogeo_imported_from": res.get("fotogeo_imported_from")})
                if res.get("fotogeo_imported_from") and not res["fotogeo_imported_from"].startswith(str(snap)):
                    print(f"WARNING: the worker imported fotogeo from {res['fotogeo_imported_from']}, not the snapshot")
                status = "ok" if s["ok"] else "FAILED"
                print(f"  {case['name']:<13}{m:<5} {status} ({res['process_s']:.1f} s)", flush=True)
        big = None if ((a.quick or a.no_big) and not a.big_only) else big_image(tmp)
    print()
    print_table(rows)
    rat = ratios(rows)
    print_ratios(rat)
    if big:
        print_big(big)
    total = time.perf_counter() - t_start
    state["tree_changed_during_run"] = source_state()["fotogeo_sha256"] != state["fotogeo_sha256"]
    if state["tree_changed_during_run"]:
        print(f"\nnote: fotogeo/ in the tree changed during the run; all rows used the snapshot "
              f"{state['snapshot_sha256']} taken at the start")
    print(f"\nbenchmark wall time {total:.0f} s")
    if a.big_only:  # a development aid: the JSON always holds a whole run
        return
    a.output.parent.mkdir(parents=True, exist_ok=True)
    if big:
        big["result"].pop("raw", None)
    command = " ".join([Path(sys.executable).name] + sys.argv)
    date = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    runs = None
    if a.merge:
        rows, runs = merge_rows(a.output, rows, {"command": command, "date": date, "source": state})
        big = big or json.loads(a.output.read_text()).get("big_image")
        rat = ratios(rows)
    a.output.write_text(json.dumps({
        "quick": a.quick, "methods": methods, "rows": rows, "ratios_fotogeo_surf_over_peer": rat, "big_image": big,
        "runs": runs,
        "notes": {"peak_rss_mb": "max RSS of the fresh Python process that ran the case (includes imports: "
                                 "base_rss_mb); for otb '+N' is the OTB process's own peak",
                  "raw_correct_share": f"share of raw matches within {CORRECT_TOL_PX} reference px of the truth "
                                       "(s2 cases, '~' in the table: of the target's own georeference, approximate)",
                  "georef_rmse_m": "s2 cases: RMSE of the fitted model against the target's own georeference on "
                                   "a 50 px grid (not a truth; the s2_pair target is known to be within ~1 px)",
                  "time_s.total": "register's timings_s.total; for otb: fusion + OTB call + register(tie_points)",
                  "weak_fit": "register's weak-fit check: None when the feature fit was strong; else the corner "
                              "standard error, the fit kept and both fits' RMSE at the windows' check points",
                  "runs": "with --merge: every run whose rows the file holds; each row's 'measured' names its run"},
        "source": state,
        "command": command,
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count(), "platform": platform.platform()},
        "date": date, "wall_s": total,
    }, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
