"""The grey image ``fotogeo dsm`` matches, on clean and noisy bands (sweep case v13).

Run (cwd outside any checkout; PYTHONPATH the tree measured):
      PYTHONPATH=TREE python TREE/benchmarks/dsm_bands_bench.py [--label NAME] [--cases rendered,ventoux,ngi]

* ``rendered`` — the rendered frame pair of ``tests/rendered_pair.py`` (400², truth known) as it is (one band),
  as three clean bands (the band, ``0.8 b + 20`` and ``0.6 b + 40``, each with its own noise of σ 2) and with
  bands 2–3 replaced by uniform noise (0–255): RMSE, NMAD, median of DSM − truth (``rendered_pair.accuracy``),
  the share of the overlap with a height;
* ``ventoux`` — the Pleiades pair (``--rpc``) as it is and with three bands of uniform noise (0–4000) after its
  band: completeness and, for the noisy copy, DSM − the clean DSM (median, NMAD, cells);
* ``ngi`` — frames 0182/0184 (RGB) with the 24 m DEM: DSM − DEM median, NMAD, completeness.

Each run's rows go under ``--label`` (default: the folder fotogeo was imported from) in
``benchmarks/results/dsm_bands_bench.json`` of this script's tree, with the command and CPU seconds of each call.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import rasterio

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
DATA = Path(os.environ.get("FOTOGEO_DATA", "/work/shared/data"))


def _run(images, out, **kw) -> tuple:
    from fotogeo.tools.dsm import dsm
    c = time.process_time()
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            rep = dsm([str(p) for p in images], out, **kw)
        except Exception as exc:  # noqa: BLE001 -- a refusal is a result here
            return {"error": str(exc)[:200]}, time.process_time() - c, [str(w.message)[:200] for w in said]
    return rep, time.process_time() - c, [str(w.message)[:200] for w in said]


def _bands(src: Path, dst: Path, make) -> Path:
    with rasterio.open(src) as ds:
        prof, a = ds.profile, ds.read(1)
    out = make(a)
    prof.update(count=len(out), dtype=out[0].dtype)
    with rasterio.open(dst, "w", **prof) as ds:
        ds.write(np.stack(out))
    for side in (".geom",):
        if src.with_suffix(side).exists():
            shutil.copy(src.with_suffix(side), dst.with_suffix(side))
    return dst


def rendered(tmp: Path) -> list:
    from rendered_pair import accuracy, render
    sc = render(tmp, 400)
    rng = np.random.default_rng(5)

    def clean(a):
        f = a.astype(np.float32)
        return [a] + [np.clip(np.round(g * f + o + rng.normal(0, 2, a.shape)), 1, 255).astype(np.uint8)
                      for g, o in ((0.8, 20), (0.6, 40))]

    def noisy(a):
        return [a] + [rng.integers(0, 256, a.shape).astype(np.uint8) for _ in range(2)]
    rows = []
    for label, make in (("one band", None), ("three clean bands", clean), ("bands 2-3 noise", noisy)):
        d = tmp / label.replace(" ", "_")
        d.mkdir()
        images = [p if make is None else _bands(Path(p), d / Path(p).name, make) for p in sc["images"]]
        out = d / "dsm.tif"
        rep, cpu, said = _run(images, out, camera=sc["camera"], eo=sc["eo"], crs="EPSG:32635")
        row = {"case": f"rendered pair 400, {label}", "cpu_s": cpu, "warnings": said}
        if "error" in rep:
            row["error"] = rep["error"]
        else:
            a = accuracy(out)
            row.update(rmse_m=a["rmse_m"], nmad_m=a["nmad_m"], median_m=a["median_m"],
                       completeness=rep["completeness"])
        rows.append(row)
    return rows


def _diff(a_path, b_path) -> dict:
    with rasterio.open(a_path) as a, rasterio.open(b_path) as b:
        if (a.width, a.height, a.transform) != (b.width, b.height, b.transform):
            return {"vs_clean": "different grids"}
        x, y = a.read(1), b.read(1)
        ok = (x != a.nodata) & (y != b.nodata)
    d = (x - y)[ok].astype(float)
    if not d.size:
        return {"vs_clean_cells": 0}
    med = float(np.median(d))
    return {"vs_clean_median_m": med, "vs_clean_nmad_m": float(1.4826 * np.median(np.abs(d - med))),
            "vs_clean_cells": int(d.size)}


def ventoux(tmp: Path) -> list:
    v = DATA / "rpc" / "ventoux"
    rng = np.random.default_rng(1)
    rows, clean_out = [], None
    for label, make in (("one band", None),
                        ("band + 3 noise bands", lambda a: [a] + [rng.integers(0, 4000, a.shape).astype(a.dtype)
                                                                  for _ in range(3)])):
        d = tmp / label.replace(" ", "_")
        d.mkdir()
        images = []
        for n in ("left_image", "right_image"):
            if make is None:
                shutil.copy(v / f"{n}.tif", d / f"{n}.tif")
                shutil.copy(v / f"{n}.geom", d / f"{n}.geom")
                images.append(d / f"{n}.tif")
            else:
                images.append(_bands(v / f"{n}.tif", d / f"{n}.tif", make))
        out = d / "dsm.tif"
        rep, cpu, said = _run(images, out, rpc=True)
        row = {"case": f"ventoux, {label}", "cpu_s": cpu, "warnings": said}
        if "error" in rep:
            row["error"] = rep["error"]
        else:
            row["completeness"] = rep["completeness"]
            if clean_out is None:
                clean_out = out
            else:
                row.update(_diff(out, clean_out))
        rows.append(row)
    return rows


def ngi(tmp: Path) -> list:
    from dsm_bench import _against, _stats
    d = DATA / "ngi"
    frames = [d / "frames" / f"3324c_2015_1004_05_{n}_RGB.tif" for n in ("0182", "0184")]
    out = tmp / "ngi.tif"
    rep, cpu, said = _run(frames, out, camera=d / "interior_orientation.yaml", eo=d / "exterior_orientation.txt",
                          dem=d / "dem.tif")
    s = _stats(_against(out, d / "dem.tif"))
    return [{"case": "NGI 0182/0184 RGB, --dem", "vs_dem_median_m": s["median"], "vs_dem_nmad_m": s["nmad"],
             "vs_dem_rmse_m": s["rmse"], "completeness": rep["completeness"], "cpu_s": cpu, "warnings": said}]


def main():
    import fotogeo
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="rendered,ventoux,ngi")
    ap.add_argument("--label", default=str(Path(fotogeo.__file__).resolve().parents[1]))
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT / "benchmarks"))
    os.environ.setdefault("GDAL_PAM_ENABLED", "NO")
    rows = []
    with tempfile.TemporaryDirectory(prefix="dsm_bands_") as t:
        for case in args.cases.split(","):
            (Path(t) / case).mkdir()
            rows += {"rendered": rendered, "ventoux": ventoux, "ngi": ngi}[case](Path(t) / case)
    for r in rows:
        print(" | ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items()
                         if k != "warnings"))
    out = ROOT / "benchmarks" / "results" / "dsm_bands_bench.json"
    runs = json.loads(out.read_text()) if out.is_file() else {}
    runs[args.label] = {"command": " ".join(sys.argv), "load_average": os.getloadavg(), "rows": rows}
    out.write_text(json.dumps(runs, indent=1, default=str) + "\n")
    print(f"-> {out}")


if __name__ == "__main__":
    main()
