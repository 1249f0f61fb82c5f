"""The big-image memory check of benchmarks/register_bench.py: a 20000 x 20000 target made by ``gdal_translate``
(:func:`make_big_target`), registered with the default and a bounded GDAL cache (:func:`big_image`), and the decimated
read probed alone (:func:`probe_read`, run as ``register_bench.py --probe-read``)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from register_bench_cases import Truth
from register_bench_common import BIG_SIZE, CAPPED_CACHE_MB, DATA, SCRIPT, _status_mb, fmt
from register_bench_tables import summarise
from register_bench_worker import run_case


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
    subprocess.run([sys.executable, str(SCRIPT), "--probe-read", str(target), str(probe_json)],
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
    print(f"\nBig image: {g['size']}x{g['size']}x3 uint8 tiled DEFLATE target "
          f"(central {g['crop'][2]}x{g['crop'][3]} of "
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
    print(f"  decimated read of the target alone (fresh process, after imports {p['base_rss_mb']:.0f} MB): "
          f"in strips of "
          f"256 rows under a {CAPPED_CACHE_MB} MB GDAL cache {p['strips_s']:.1f} s, peak {p['strips_peak_mb']:.0f} MB; "
          f"then fotogeo's read_decimated (default cache) {p['read_decimated_s']:.1f} s, peak "
          f"{p['read_decimated_peak_mb']:.0f} MB; identical arrays: {p['identical']}")
