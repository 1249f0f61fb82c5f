"""Orientation models from GCPs on the NGI frames, beside GDAL's GCP transformers.

For each frame, spread (homogeneous = stratified, clustered = GCPs in 3 discs, check points
everywhere; see :mod:`fotogeo.orientation.simulation`), GCP/check split and seeded trial, GCPs and check points
are generated from the true geometry (camera + exterior orientation + DEM), the GCP pixel
coordinates get Gaussian noise (default 0.3 px per axis), every model is fitted ground ->
image on the GCPs, and the check points' image errors are pooled over the trials:

* ``check_rms`` — RMS per axis (x = col, y = row) in pixels, pooled over all trials
  (the paper's mx, my); ``check_median`` / ``check_max`` — of the error-vector lengths;
* ``gcp_rms`` — RMS per axis of the residuals at the GCPs (against the noisy measurements).

2-D models (fotogeo's affine, projective, bilinear, poly1-3 and GDAL's polynomial 1-3 and
thin-plate spline through ``osgeo.gdal.Transformer`` with ``METHOD=GCP_POLYNOMIAL`` /
``GCP_TPS``, ground -> pixel via the transformer's inverse direction) see the ground X, Y only.
``rfm-plain``, ``rfm-common-plain``, ``rfm-poly-plain`` and ``rfm-plain-i2g`` are the paper's unregularised
RFMs (registered models, :mod:`fotogeo.models.rfm`) beside fotogeo's regularised ones. ``*-i2g`` models are
fitted image -> ground ((col, row, Z) -> (X, Y)) and checked through their inverse at the check point's
height. ``collinearity`` knows the interior orientation.

Splits: the paper's five per model family (Öztürk, Karşlı & Dihkan, Table 1): 40/0, 20/20, 15/25, 10/30,
6/34 for the classical models and GDAL's, 60/0, 55/5, 50/10, 45/15, 40/20 for the RFMs (``--splits`` gives
one list for every model). Errors are also given in mm on the photo at the frame's pixel pitch (the NGI
frames are downsampled: 144 µm; the paper's scan was 21 µm).

Run: ``.venv/bin/python benchmarks/orient_bench.py`` (``--trials``, ``--splits 40/20,20/20``,
``--frames``, ``--noise`` to change). Prints a table and writes ``benchmarks/results/orient_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fotogeo.io.camera import load_ngi_frame
from fotogeo.io.raster import read_dem
from fotogeo.errors import FotogeoError
from fotogeo.orientation.simulation import make_gcps
from fotogeo.models import MODELS, IllPosedWarning

FOTOGEO_MODELS = ["affine", "projective", "bilinear", "poly1", "poly2", "poly3", "affine-height", "poly3d-2",
                  "poly3d-3", "dlt", "rfm-plain", "rfm-common-plain", "rfm-poly-plain", "rfm-plain-i2g", "rfm",
                  "rfm-common", "rfm-poly", "rfm-i2g", "collinearity"]
#: the paper's splits (control/check) per model family: model-name prefix -> splits
PAPER_SPLITS = {"": "40/0,20/20,15/25,10/30,6/34", "rfm": "60/0,55/5,50/10,45/15,40/20"}
GDAL_MODELS = ["gdal-poly1", "gdal-poly2", "gdal-poly3", "gdal-tps"]
GDAL_MIN = {"gdal-poly1": 3, "gdal-poly2": 6, "gdal-poly3": 10, "gdal-tps": 3}


def gdal_predict(kind: str, gcp_ground, gcp_pixel, check_ground):
    """Ground X, Y -> pixel through a GDAL GCP transformer fitted on the GCPs."""
    from osgeo import gdal

    gdal.UseExceptions()
    ds = gdal.GetDriverByName("MEM").Create("", 640, 1152, 1)
    ds.SetGCPs([gdal.GCP(float(X), float(Y), 0.0, float(c), float(r))
                for (X, Y, _), (c, r) in zip(gcp_ground, gcp_pixel)], "")
    opts = ["METHOD=GCP_TPS"] if kind == "gdal-tps" else ["METHOD=GCP_POLYNOMIAL", f"MAX_GCP_ORDER={kind[-1]}"]
    tr = gdal.Transformer(ds, None, opts)
    pts, ok = tr.TransformPoints(1, [(float(X), float(Y), 0.0) for X, Y, _ in check_ground])
    out = np.array([p[:2] for p in pts], dtype=np.float64)
    out[~np.asarray(ok, bool)] = np.nan
    return out


def predict(name, frame, g):
    """Check-point pixels predicted by model ``name`` fitted on the GCPs of ``g``."""
    if name.startswith("gdal-") and not len(g.check_ground):
        return np.zeros((0, 2)), gdal_predict(name, g.gcp_ground, g.gcp_pixel, g.gcp_ground) - g.gcp_pixel
    if name.startswith("gdal-"):
        return (gdal_predict(name, g.gcp_ground, g.gcp_pixel, g.check_ground),
                gdal_predict(name, g.gcp_ground, g.gcp_pixel, g.gcp_ground) - g.gcp_pixel)
    cls = MODELS[name]
    fit = cls.options_from(camera=frame.camera)  # the camera of the collinearity model, else nothing
    if name.endswith("-i2g"):
        m = cls.estimate(np.column_stack([g.gcp_pixel, g.gcp_ground[:, 2]]), g.gcp_ground[:, :2])
        back = m.inverse(g.gcp_ground[:, :2], g.gcp_ground[:, 2])[:, :2] - g.gcp_pixel
        return m.inverse(g.check_ground[:, :2], g.check_ground[:, 2])[:, :2], back
    if cls.src_dims == 2:
        m = cls.estimate(g.gcp_ground[:, :2], g.gcp_pixel)
        return m.forward(g.check_ground[:, :2]), m.forward(g.gcp_ground[:, :2]) - g.gcp_pixel
    m = cls.estimate(g.gcp_ground, g.gcp_pixel, **fit)
    return m.forward(g.check_ground), m.forward(g.gcp_ground) - g.gcp_pixel


def parse_splits(text):
    return [tuple(int(v) for v in s.split("/")) for s in text.split(",")]


def splits_of(name, table):
    """The splits of model ``name``: those of the longest key of ``table`` its name starts with."""
    return table[max((k for k in table if name.startswith(k)), key=len)]


def run(frames, split_table, spreads, trials, noise, all_models, data, clusters=3, cluster_radius=0.1):
    ngi = data / "ngi"
    dem = read_dem(ngi / "dem.tif")
    rows = []
    every = list(dict.fromkeys(s for m in all_models for s in splits_of(m, split_table)))
    for fname in frames:
        frame = load_ngi_frame(ngi, fname)
        mm_per_px = frame.camera.sensor_size[0] / frame.camera.image_size[0]
        for spread in spreads:
            for n_gcp, n_chk in every:
                models = [m for m in all_models if (n_gcp, n_chk) in splits_of(m, split_table)]
                errs = {m: [] for m in models}
                gres = {m: [] for m in models}
                times = {m: 0.0 for m in models}
                skipped = {}
                for seed in range(trials):
                    g = make_gcps(frame, dem, n_gcp, n_chk, spread, noise=noise, seed=seed, n_clusters=clusters,
                                   cluster_radius=cluster_radius)
                    for name in models:
                        need = GDAL_MIN.get(name) or MODELS[name].min_points
                        if n_gcp < need:
                            skipped[name] = f"needs >= {need} GCPs"
                            continue
                        t0 = time.perf_counter()
                        try:
                            with warnings.catch_warnings():
                                warnings.simplefilter("ignore", IllPosedWarning)
                                pred, res = predict(name, frame, g)
                        except (FotogeoError, RuntimeError) as exc:
                            skipped[name] = f"failed: {exc}"
                            continue
                        times[name] += time.perf_counter() - t0
                        errs[name].append(pred.reshape(-1, 2) - g.check_pixel.reshape(-1, 2))
                        if res is not None:
                            gres[name].append(res)
                for name in models:
                    if not errs[name]:
                        rows.append({"frame": frame.name, "spread": spread, "split": f"{n_gcp}/{n_chk}",
                                     "model": name, "skipped": skipped.get(name, "no result")})
                        continue
                    e = np.concatenate(errs[name])
                    d = np.hypot(*e.T)
                    row = {"frame": frame.name, "spread": spread, "split": f"{n_gcp}/{n_chk}", "model": name,
                           "trials": len(errs[name]), "noise_px": noise, "mm_per_px": mm_per_px,
                           "fit_seconds_per_trial": times[name] / len(errs[name])}
                    if len(e):
                        row.update(check_rms=np.sqrt(np.nanmean(e ** 2, axis=0)).tolist(),
                                   check_min=float(np.nanmin(d)), check_median=float(np.nanmedian(d)),
                                   check_max=float(np.nanmax(d)))
                    if gres[name]:
                        row["gcp_rms"] = np.sqrt(np.nanmean(np.concatenate(gres[name]) ** 2, axis=0)).tolist()
                    if name in skipped:
                        row["note"] = skipped[name]
                    rows.append(row)
    return rows


def table(rows):
    lines = [(f"{'frame':<28} {'spread':<12} {'split':<6} {'model':<14} {'check x':>9} {'check y':>9} "
              f"{'median':>8} {'max':>9} {'gcp x':>7} {'gcp y':>7}")]
    for r in rows:
        head = f"{r['frame']:<28} {r['spread']:<12} {r['split']:<6} {r['model']:<14}"
        if "skipped" in r:
            lines.append(f"{head} {r['skipped']}")
            continue
        gx, gy = r.get("gcp_rms", [np.nan, np.nan])
        cx, cy = r.get("check_rms", [np.nan, np.nan])
        lines.append(f"{head} {cx:9.3f} {cy:9.3f} {r.get('check_median', np.nan):8.3f} "
                     f"{r.get('check_max', np.nan):9.2f} {gx:7.3f} {gy:7.3f}")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--frames", default="3324c_2015_1004_05_0182,3324c_2015_1004_05_0184")
    ap.add_argument("--splits", default=None, help="control/check splits for every model [the paper's per family]")
    ap.add_argument("--spreads", default="homogeneous,clustered")
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--noise", type=float, default=0.3)
    ap.add_argument("--clusters", type=int, default=3, help="clustered spread: number of GCP discs")
    ap.add_argument("--cluster-radius", type=float, default=0.1, help="disc radius / shorter image side")
    ap.add_argument("--models", default=",".join(FOTOGEO_MODELS + GDAL_MODELS))
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "orient_bench.json")
    a = ap.parse_args(argv)
    splits = {"": parse_splits(a.splits)} if a.splits else {k: parse_splits(v) for k, v in PAPER_SPLITS.items()}
    t0 = time.time()
    rows = run(a.frames.split(","), splits, a.spreads.split(","), a.trials, a.noise, a.models.split(","), a.data,
               a.clusters, a.cluster_radius)
    print(table(rows))
    from osgeo import gdal

    a.out.parent.mkdir(parents=True, exist_ok=True)
    result = {"benchmark": "orient_bench", "units": "pixels (x = col, y = row)",
              "config": {"frames": a.frames, "splits": a.splits or PAPER_SPLITS, "spreads": a.spreads, "trials": a.trials,
                         "noise_px": a.noise, "clusters": a.clusters,
                         "cluster_radius": a.cluster_radius, "gcp_generation": "fotogeo.orientation.simulation.make_gcps (seeds 0..trials-1)"},
              "environment": {"python": platform.python_version(), "numpy": np.__version__,
                              "gdal": gdal.__version__},
              "seconds": time.time() - t0, "rows": rows}
    tmp = a.out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(result, indent=1))
    tmp.replace(a.out)
    print(f"\nwrote {a.out} ({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
