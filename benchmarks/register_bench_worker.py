"""One case x method of benchmarks/register_bench.py in a fresh process (:func:`run_case` starts
``register_bench.py --worker SPEC``, which runs :func:`worker`), and Orfeo ToolBox's tie points on the very images
fotogeo matches (:func:`otb_tie_points`)."""
from __future__ import annotations

import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from register_bench_common import OTB_EXE, SCRIPT, _maxrss_mb, _status_mb


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
    p = subprocess.run([sys.executable, str(SCRIPT), "--worker", str(work / "spec.json")],
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
