"""Which criterion picks the terrain-aware registration's 3-D model with the smallest true error?

For the NGI frames 0182/0184 registered to their orthophoto and to Sentinel-2, SURF with box or
Gaussian layers, without and with LSM: the pipeline's tie points (with DEM heights) are captured as
``register(..., dem=...)`` passes them to :func:`fotogeo.orientation.terrain.fit_terrain`; on that
selection's control points every ``auto`` candidate (DLT and the RFMs) is fitted and compared by

* ``check``   — the check RMSE, simplest within 5 % (the rule before the blocked cross-validation);
* ``check+SE`` — the check RMSE, simplest whose mean squared error exceeds the best's by less than one
  standard error of the paired difference (a parsimony rule that knows the check set's size);
* ``blocked`` — the blocked cross-validation RMSE (3 x 3 regions), simplest within 5 % (``auto`` now);

against the dense-grid error to the true geometry (camera + exterior orientation + DEM, metres). Also
printed: the tie points' error against the true geometry (frame px; RMS, and RMS of its means over
3 x 3 regions), the fraction of the dense grid inside the tie points' hull (the JSON has each
candidate's dense error inside and outside it), the distance from a check point to its nearest
control point, and the correlation of the tie-point errors between points 0-10 px and 30-60 px apart.
Each case is evaluated for the control/check splits of ``--split-seeds`` (default 0 1 2; register's
own seed is 0). Run: ``.venv/bin/python benchmarks/terrain_choice_bench.py`` (about 10 minutes under load);
writes ``benchmarks/results/terrain_choice_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
from pyproj import CRS
from matplotlib.path import Path as MplPath
from scipy.spatial import ConvexHull, cKDTree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from ngi_truth import FRAMES, truth_points  # noqa: E402

from fotogeo.crs import transform_points  # noqa: E402
from fotogeo.features import detect  # noqa: E402
from fotogeo.io.camera import load_ngi_frame  # noqa: E402
from fotogeo.io.raster import read_dem  # noqa: E402
from fotogeo.models import get_model  # noqa: E402
from fotogeo.models.robust import cell_ids  # noqa: E402
from fotogeo.orientation import terrain  # noqa: E402
from fotogeo.tools.register.tool import register  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
NAMES = ("dlt", "rfm-poly", "rfm-common", "rfm")


def captured_ties(ref, frame, dem, refine):
    """The tie points ``(target px, ground XYZ, fit keyword arguments, output CRS)`` register() fits."""
    seen, original = {}, terrain.fit_terrain

    def spy(src, ground, **kw):
        seen.update(src=np.array(src), ground=np.array(ground), kw=kw)
        return original(src, ground, **kw)

    terrain.fit_terrain = spy
    try:
        with tempfile.TemporaryDirectory() as tmp:
            r = register(ref, frame, Path(tmp) / "o.tif", dem=dem, model="dlt", refine=refine, seed=0)
    finally:
        terrain.fit_terrain = original
    kw = {k: seen["kw"][k] for k in ("threshold_m", "min_sigma_m", "check_fraction", "rng", "is_valid")}
    return seen["src"], seen["ground"], kw, r.georeference.crs


def correlation(xy, e, lo, hi):
    """Correlation of the vectors ``e`` between points ``lo``-``hi`` px apart."""
    pairs = cKDTree(xy).query_pairs(hi, output_type="ndarray")
    pairs = pairs[np.hypot(*(xy[pairs[:, 0]] - xy[pairs[:, 1]]).T) >= lo]
    a, b = e[pairs[:, 0]], e[pairs[:, 1]]
    return float(np.sum(a * b) / np.sqrt(np.sum(a * a) * np.sum(b * b)))


def simplest_within(score, tol=0.05):
    best = min(v for v in score.values() if np.isfinite(v))
    return next(n for n in NAMES if score[n] <= (1 + tol) * best)


def evaluate(src, ground, kw, crs, frame, px, truth, frame_crs):
    """Every candidate's check, blocked and dense error; each rule's pick; the tie errors' structure."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sel = terrain.fit_terrain(src, ground, model="dlt", **kw)
        hull = MplPath(src[sel.inliers][ConvexHull(src[sel.inliers]).vertices]).contains_points(px)
        control, check = sel.role == "control", sel.role == "check"
        rows, sq = {}, {}
        for n in NAMES:
            cls = get_model(n)
            m = cls.estimate(ground[control], src[control])
            sq[n] = np.sum((m.forward(ground[check]) - src[check]) ** 2, axis=1)
            with np.errstate(all="ignore"):
                on = transform_points(crs, "EPSG:32735", m.inverse(px, truth[:, 2])[:, :2])
            d2 = np.sum((on - truth[:, :2]) ** 2, axis=1)
            rows[n] = {"check_rmse_px": float(np.sqrt(sq[n].mean())),
                       "blocked_cv_rmse_px": terrain.blocked_cv_rmse(cls, ground[control], src[control]),
                       "dense_rmse_m": float(np.sqrt(np.nanmean(d2))),
                       "dense_in_hull_m": float(np.sqrt(np.nanmean(d2[hull]))),
                       "dense_outside_hull_m": float(np.sqrt(np.nanmean(d2[~hull])))}
    best = min(NAMES, key=lambda n: sq[n].mean())
    se_pick = next(n for n in NAMES if n == best or (sq[n] - sq[best]).mean()
                   <= (sq[n] - sq[best]).std(ddof=1) / np.sqrt(check.sum()))
    inl = sel.inliers
    in_frame_crs = np.column_stack([transform_points(crs, frame_crs, ground[:, :2]), ground[:, 2]])
    err = (src - frame.world_to_pixel(in_frame_crs))[inl]
    cell = cell_ids(src[inl], 3)
    region_mean = np.array([err[cell == c].mean(axis=0) for c in np.unique(cell)])
    err = err - err.mean(axis=0)
    return {"candidates": rows, "n_control": int(control.sum()), "n_check": int(check.sum()),
            "pick": {"check": simplest_within({n: r["check_rmse_px"] for n, r in rows.items()}), "check+SE": se_pick,
                     "blocked": simplest_within({n: r["blocked_cv_rmse_px"] for n, r in rows.items()})},
            "tie_error_rms_px": float(np.sqrt(np.mean(np.sum(err ** 2, axis=1)))),
            "tie_error_region_mean_rms_px": float(np.sqrt(np.mean(np.sum(region_mean ** 2, axis=1)))),
            "hull_fraction": float(hull.mean()),
            "check_to_control_median_px": float(np.median(cKDTree(src[control]).query(src[check])[0])),
            "tie_error_correlation": {"0-10 px": correlation(src[inl], err, 0, 10),
                                      "30-60 px": correlation(src[inl], err, 30, 60)}}


def line(row) -> str:
    """One printed row: each candidate's check / blocked / dense error, each rule's pick, the tie errors."""
    c, p = row["candidates"], row["pick"]
    return (f"{row['layers']:8s} {row['frame'][-4:]} {row['reference']:5s} {row['refine']:4s} s{row['split_seed']} "
            + " ".join(f"{n} {c[n]['check_rmse_px']:.3f}/{c[n]['blocked_cv_rmse_px']:.3f}/{c[n]['dense_rmse_m']:.2f}"
                       for n in NAMES)
            + " | " + " ".join(f"{k}: {v} {c[v]['dense_rmse_m']:.2f}" for k, v in p.items())
            + f" | tie err {row['tie_error_rms_px']:.2f} px"
              f" (3x3 region means {row['tie_error_region_mean_rms_px']:.2f}),"
              f" hull {row['hull_fraction']:.2f}, check->control {row['check_to_control_median_px']:.1f} px, corr "
            + " ".join(f"{v:.2f}" for v in row["tie_error_correlation"].values()))


def summary(rows) -> dict:
    """Per rule: the picks within 0.05 m of the candidate with the smallest dense error, and the worst excess."""
    out = {}
    for rule in rows[0]["pick"]:
        excess = [r["candidates"][r["pick"][rule]]["dense_rmse_m"] - min(c["dense_rmse_m"] for c in
                                                                         r["candidates"].values()) for r in rows]
        out[rule] = {"best_within_0.05_m": int(sum(e <= 0.05 for e in excess)), "cases": len(rows),
                     "worst_excess_m": float(max(excess))}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "terrain_choice_bench.json")
    ap.add_argument("--split-seeds", type=int, nargs="+", default=[0, 1, 2],
                    help="seeds of the control/check split (and the prefilter's RANSAC) evaluated per case")
    args = ap.parse_args()
    ngi = args.data / "ngi"
    rows, pipeline_gaussian = [], detect.PIPELINE_GAUSSIAN
    frame_crs = CRS.from_wkt(read_dem(ngi / "dem.tif").crs.to_wkt())  # the exterior orientation's
    try:
        for layers in ("box", "gaussian"):
            detect.PIPELINE_GAUSSIAN = layers == "gaussian"
            for name, ortho in FRAMES:
                px, truth = truth_points(ngi, name)
                frame = load_ngi_frame(ngi, name)
                for ref_name, ref in (("ortho", ngi / "ortho" / ortho), ("S2", ngi / "sentinel2_b432_byte.tif")):
                    for refine in ("none", "lsm"):
                        src, ground, kw, crs = captured_ties(ref, ngi / "frames" / f"{name}_RGB.tif",
                                                             ngi / "dem.tif", refine)
                        for seed in args.split_seeds:
                            rows.append({"layers": layers, "frame": name, "reference": ref_name, "refine": refine,
                                         "split_seed": seed, **evaluate(src, ground, dict(kw, rng=seed), crs, frame,
                                                                        px, truth, frame_crs)})
                            print(line(rows[-1]), flush=True)
    finally:
        detect.PIPELINE_GAUSSIAN = pipeline_gaussian
    total = summary(rows)
    for rule, t in total.items():
        print(f"{rule:9s}: the best candidate (within 0.05 m) in {t['best_within_0.05_m']} of {t['cases']}, "
              f"worst {t['worst_excess_m']:.2f} m more")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"benchmark": "terrain_choice_bench", "columns": "check px / blocked px / dense m",
                                    "summary": total, "rows": rows}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
