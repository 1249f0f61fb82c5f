"""Benchmark of area-based matching: fotogeo NCC and LSM against OpenCV ECC and scikit-image.

On real textured patches (NGI orthophotos, Landsat) a search image is generated from a
known corner-convention affine (sub-pixel shift, rotation ≤ 10°, scale ±10 %) by exact
float64 Lanczos-4 resampling, optionally with a radiometric change (gain, offset) and
independent Gaussian noise in both images. Every method gets the same 21x21 window around
the same reference points and the same approximation (truth + up to ±1.5 px):

- fotogeo ``ncc`` (quadratic peak fit), ``lsm_many`` (affine + radiometric, bicubic and bilinear)
- OpenCV ``findTransformECC`` (MOTION_AFFINE) on the same template, search patch with margin
- scikit-image ``phase_cross_correlation`` (upsample_factor=100), translation only; also on
  65x65 windows (``phase_corr_65``), closer to its usual use
- LSM runs with its defaults (max_iterations=15), bicubic and bilinear

Reported per scenario and method: success rate (explicit failure or exception), gross errors
(> 0.5 px among the answers given), bias and RMSE (radial, sqrt(mean(dx² + dy²))) of the
answers, and time per match. For LSM also how well σ predicts the error: observed RMSE / RMS σ
per axis and the robust spread of e/σ. Synthetic X targets: :func:`measure_target` error.

    .venv/bin/python benchmarks/matching_bench.py [--quick]

Writes benchmarks/results/matching_bench.json.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # exact warps shared with the tests
from synthetic_images import warp  # noqa: E402
from fotogeo.matching import lsm_many, measure_target, ncc, synthetic_x_target
from fotogeo.pixels import from_centre, to_centre

DATA = ROOT.parent / "shared" / "data"
H = 10  # half window for every method: 21x21 pixels


# -- data ----------------------------------------------------------------------------------


def load_patches():
    import rasterio

    def grey(path, rows, cols):
        with rasterio.open(path) as ds:
            a = ds.read().astype(np.float64).mean(axis=0)[rows, cols]
        if not (a > 0).all():
            raise SystemExit(f"benchmark crop of {path} contains nodata")
        return cv2.GaussianBlur(a, (0, 0), 0.8)  # mild low-pass so resampled truth is exact

    return {
        "ngi_ortho_1": grey(DATA / "ngi/ortho/ngi_rgb_byte_1.tif", slice(450, 850), slice(200, 600)),
        "ngi_ortho_2": grey(DATA / "ngi/ortho/ngi_rgb_byte_2.tif", slice(450, 850), slice(200, 600)),
        "landsat": grey(DATA / "landsat_rgb/RGB.byte.tif", slice(250, 500), slice(100, 350)),
    }


def affine(shift, angle_deg, scale, centre):
    a = np.deg2rad(angle_deg)
    M = scale * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    c = np.asarray(centre, dtype=np.float64)
    return np.column_stack([M, c - M @ c + np.asarray(shift, dtype=np.float64)])


def apply(A, xy):
    return np.atleast_2d(xy) @ A[:, :2].T + A[:, 2]


# -- peer methods on the same windows ------------------------------------------------------


def ecc_match(ref, sea, p, q, margin=4, jacobian=None):
    """OpenCV findTransformECC (affine) of the 21x21 template at p into a patch around q."""
    pc, pr = np.floor(p).astype(int)
    tpl = ref[pr - H:pr + H + 1, pc - H:pc + H + 1].astype(np.float32)
    qc, qr = np.floor(q).astype(int)
    m = H + margin
    if qr - m < 0 or qc - m < 0 or qr + m >= sea.shape[0] or qc + m >= sea.shape[1]:
        return None
    inp = sea[qr - m:qr + m + 1, qc - m:qc + m + 1].astype(np.float32)
    # template pixel (0,0) (centre convention) starts at the approximation
    t_ref = to_centre(p) - [pc - H, pr - H]  # ref_xy in template array coordinates
    q_in = to_centre(q) - [qc - m, qr - m]   # approximation in input array coordinates
    J = np.eye(2) if jacobian is None else np.asarray(jacobian)
    W = np.column_stack([J, q_in - J @ t_ref]).astype(np.float32)
    if np.isnan(tpl).any() or np.isnan(inp).any():
        return None
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-6)
    try:
        _, W = cv2.findTransformECC(tpl, inp, W, cv2.MOTION_AFFINE, crit, None, 1)
    except cv2.error:
        return None
    x_in = W[:, :2] @ t_ref + W[:, 2]
    return from_centre(x_in + [qc - m, qr - m])


def phase_match(ref, sea, p, q, h=H):
    from skimage.filters import window
    from skimage.registration import phase_cross_correlation

    pc, pr = np.floor(p).astype(int)
    qc, qr = np.floor(q).astype(int)
    if min(qr, qc, pr, pc) - h < 0 or max(qr, pr) + h >= sea.shape[0] or max(qc, pc) + h >= sea.shape[1]:
        return None
    a = ref[pr - h:pr + h + 1, pc - h:pc + h + 1]
    b = sea[qr - h:qr + h + 1, qc - h:qc + h + 1]
    # Hann window against the wrap-around edges of non-periodic patches (as the skimage
    # gallery recommends); without it the sub-pixel peak is pulled to 0.2-0.5 px errors
    w = window("hann", a.shape)
    shift, _, _ = phase_cross_correlation((a - a.mean()) * w, (b - b.mean()) * w, upsample_factor=100)
    # b(x) = a(x - d) with d = -shift (dy, dx); p sits at p - [pc, pr] in a
    d = -shift[::-1]
    return (np.asarray(p) - [pc, pr]) + d + [qc, qr]


# -- scenarios ------------------------------------------------------------------------------


SCENARIOS = {
    "shift": {"rot": 0.0, "scale": 0.0, "gain": 0.0, "noise": 0.0},
    "affine": {"rot": 10.0, "scale": 0.10, "gain": 0.0, "noise": 0.0},
    "affine+radiometric+noise": {"rot": 10.0, "scale": 0.10, "gain": 0.3, "noise": 2.0},
}


def make_pair(master, rng, spec):
    rows, cols = master.shape
    A = affine(rng.uniform(-2, 2, 2), rng.uniform(-spec["rot"], spec["rot"]),
               1 + rng.uniform(-spec["scale"], spec["scale"]), (cols / 2, rows / 2))
    sea = warp(master, A)
    ref = master.copy()
    if spec["gain"]:
        sea = (1 + rng.uniform(-spec["gain"], spec["gain"])) * sea + rng.uniform(-20, 20)
    if spec["noise"]:
        ref = ref + rng.normal(0, spec["noise"], ref.shape)
        sea = sea + rng.normal(0, spec["noise"], sea.shape)
    return ref, sea, A


def summarise(err, ok, seconds, n):
    e = err[ok]
    r = np.hypot(e[:, 0], e[:, 1]) if len(e) else np.array([])
    good = r <= 0.5
    out = {"n": int(n), "success": float(ok.mean()), "gross_gt_0.5px": int((~good).sum()),
           "ms_per_match": 1e3 * seconds / max(n, 1)}
    if len(e):
        out.update(bias=[float(v) for v in e.mean(axis=0)], rmse=float(np.sqrt((r ** 2).mean())),
                   rmse_without_gross=float(np.sqrt((r[good] ** 2).mean())) if good.any() else None,
                   median=float(np.median(r)))
    return out


def run_scenario(patches, spec, rng, n_pairs, n_pts):
    errs = {k: [] for k in ("ncc", "lsm_bicubic", "lsm_bilinear", "ecc_affine", "phase_corr",
                            "phase_corr_65")}
    oks = {k: [] for k in errs}
    times = {k: 0.0 for k in errs}
    sig, lsm_err = [], []
    statuses = {"lsm_bicubic": {}, "lsm_bilinear": {}}
    for master in patches.values():
        for _ in range(n_pairs):
            ref, sea, A = make_pair(master, rng, spec)
            rows, cols = master.shape
            pts = np.floor(rng.uniform(45, min(rows, cols) - 45, (n_pts, 2))) + rng.uniform(0, 1, (n_pts, 2))
            truth = apply(A, pts)
            approx = truth + rng.uniform(-1.5, 1.5, truth.shape)
            for key, interp in (("lsm_bicubic", "bicubic"), ("lsm_bilinear", "bilinear")):
                t0 = time.perf_counter()
                b = lsm_many(ref, sea, pts, approx, half_window=H, interpolation=interp)
                times[key] += time.perf_counter() - t0
                errs[key].append(b.xy - truth)
                oks[key].append(b.ok)
                for st in b.status:
                    statuses[key][st] = statuses[key].get(st, 0) + 1
                if key == "lsm_bicubic":
                    sig.append(b.sigma)
                    lsm_err.append(np.where(b.ok[:, None], b.xy - truth, np.nan))
            for key, fn in (("ncc", None), ("ecc_affine", ecc_match), ("phase_corr", phase_match),
                            ("phase_corr_65", lambda *a: phase_match(*a, h=32))):
                e = np.full((n_pts, 2), np.nan)
                t0 = time.perf_counter()
                for i in range(n_pts):
                    if fn is None:
                        r = ncc(ref, sea, pts[i], approx[i], half_window=H, search_radius=4)
                        xy = r.xy if r.ok else None
                    else:
                        xy = fn(ref, sea, pts[i], approx[i])
                    if xy is not None:
                        e[i] = np.asarray(xy) - truth[i]
                times[key] += time.perf_counter() - t0
                errs[key].append(e)
                oks[key].append(np.isfinite(e).all(axis=1))
    res = {}
    for k, ek in errs.items():
        E, O = np.concatenate(ek), np.concatenate(oks[k])
        res[k] = summarise(E, O, times[k], len(O))
        if k in statuses:
            res[k]["statuses"] = statuses[k]
    S, E = np.concatenate(sig), np.concatenate(lsm_err)
    ok = np.isfinite(E).all(axis=1)
    rms_sigma = np.sqrt((S[ok] ** 2).mean(axis=0))
    rmse_axis = np.sqrt((E[ok] ** 2).mean(axis=0))
    z = E[ok] / S[ok]
    res["lsm_sigma"] = {"rmse_xy": rmse_axis.tolist(), "rms_sigma_xy": rms_sigma.tolist(),
                        "ratio_rmse_to_sigma": (rmse_axis / rms_sigma).tolist(),
                        "robust_spread_of_e_over_sigma": (1.4826 * np.median(np.abs(z), axis=0)).tolist()}
    return res


def run_targets(rng, n):
    err, sig, t = [], [], 0.0
    fails = 0
    for _ in range(n):
        c = np.array([40.0, 40.0]) + rng.uniform(-0.5, 0.5, 2)
        rot = rng.uniform(-15, 15)
        img = synthetic_x_target((81, 81), c, rng.uniform(2.5, 4.5), (45 + rot, 135 + rot + rng.uniform(-5, 5)),
                                 rng.uniform(150, 230), rng.uniform(20, 80), supersample=16)
        img = np.clip(np.round(cv2.GaussianBlur(img, (0, 0), 0.7) + rng.normal(0, 2.0, img.shape)), 0, 255)
        t0 = time.perf_counter()
        r = measure_target(img.astype(np.uint8), c + rng.uniform(-2.5, 2.5, 2))
        t += time.perf_counter() - t0
        if not r.ok:
            fails += 1
            continue
        err.append(r.xy - c)
        sig.append(r.sigma)
    e, s = np.array(err), np.array(sig)
    rr = np.hypot(e[:, 0], e[:, 1])
    return {"n": n, "failed": fails, "rmse": float(np.sqrt((rr ** 2).mean())), "max": float(rr.max()),
            "bias": e.mean(axis=0).tolist(), "rms_sigma_xy": np.sqrt((s ** 2).mean(axis=0)).tolist(),
            "ms_per_target": 1e3 * t / n}


def run_real_pair(rng, n):
    """Orthophoto tile 1 -> raw frame 0182 (rotated ~180°, relief), truth from camera geometry.

    Truth: ortho pixel -> map (X, Y) -> DEM height -> frame pixel (fotogeo.geometry.camera); the data
    README measures this geometry to about 0.8 ortho px RMSE, so the discrepancy below is an
    agreement with the geometry, not an accuracy. The truth-free measure is the closure of a
    forward (ortho -> frame) and backward (frame -> ortho) LSM, compared with LSM's σ.
    """
    try:
        import rasterio

        from fotogeo.io.camera import load_ngi_frame
        from fotogeo.io.raster import read_dem
        from fotogeo.pixels import pixel_to_map
    except ImportError as exc:
        return {"skipped": f"needs fotogeo.geometry.camera / fotogeo.dem: {exc}"}

    def grey(path):
        with rasterio.open(path) as ds:
            a = ds.read().astype(np.float64)
            t = ds.transform
        g = a.mean(axis=0)
        g[(a == 0).all(axis=0)] = np.nan
        return g, t

    ortho, T = grey(DATA / "ngi/ortho/ngi_rgb_byte_1.tif")
    frame_img, _ = grey(DATA / "ngi/frames/3324c_2015_1004_05_0182_RGB.tif")
    frame = load_ngi_frame(DATA / "ngi", "3324c_2015_1004_05_0182")
    dem = read_dem(DATA / "ngi/dem.tif")

    def to_frame(xy):
        XY = pixel_to_map(T, xy)
        return frame.world_to_pixel(np.column_stack([XY, dem.heights(XY)]))

    rows, cols = ortho.shape
    pts = np.floor(rng.uniform(40, [cols - 40, rows - 40], (4 * n, 2))) + 0.5
    truth = to_frame(pts)
    inside = (np.isfinite(truth).all(axis=1) & (truth[:, 0] > 40) & (truth[:, 1] > 40)
              & (truth[:, 0] < frame_img.shape[1] - 40) & (truth[:, 1] < frame_img.shape[0] - 40))
    pts, truth = pts[inside][:n], truth[inside][:n]
    J = np.stack([(to_frame(pts + [1, 0]) - to_frame(pts - [1, 0])) / 2,
                  (to_frame(pts + [0, 1]) - to_frame(pts - [0, 1])) / 2], axis=2)  # d frame / d ortho
    approx = truth + rng.uniform(-1.5, 1.5, truth.shape)
    t0 = time.perf_counter()
    fwd = lsm_many(ortho, frame_img, pts, approx, half_window=H, approx_jacobian=J)
    t_lsm = time.perf_counter() - t0
    ok = fwd.ok
    d = fwd.xy[ok] - truth[ok]
    back = lsm_many(frame_img, ortho, fwd.xy[ok], pts[ok], half_window=H, approx_jacobian=np.linalg.inv(J[ok]))
    closure = back.xy[back.ok] - pts[ok][back.ok]
    # predicted closure covariance: J⁻¹ C_fwd J⁻ᵀ + C_back (ortho pixels)
    Ji = np.linalg.inv(J[ok][back.ok])
    C = np.einsum("kij,kjl,kml->kim", Ji, fwd.covariance[ok][back.ok], Ji) + back.covariance[back.ok]
    closure_pred = np.sqrt(np.einsum("kii->ki", C).mean(axis=0))
    # ECC from the same start (affine initialised with the geometric Jacobian)
    e_ecc = []
    for i in range(len(pts)):
        xy = ecc_match(ortho, frame_img, pts[i], approx[i], margin=8, jacobian=J[i])
        if xy is not None:
            e_ecc.append(xy - truth[i])
    e_ecc = np.array(e_ecc)
    r, rc, re = np.hypot(*d.T), np.hypot(*closure.T), np.hypot(*e_ecc.T)
    return {
        "n": len(pts), "lsm_success": float(ok.mean()),
        "lsm_statuses": {s: int(c) for s, c in zip(*np.unique(fwd.status, return_counts=True))},
        "lsm_vs_geometry_median_px": float(np.median(r)), "lsm_vs_geometry_rmse_px": float(np.sqrt((r ** 2).mean())),
        "lsm_vs_geometry_bias_px": d.mean(axis=0).tolist(),
        "ecc_returned": len(e_ecc), "ecc_vs_geometry_median_px": float(np.median(re)),
        "ecc_vs_geometry_rmse_px": float(np.sqrt((re ** 2).mean())),
        "closure_n": int(back.ok.sum()), "closure_rms_per_axis_px": np.sqrt((closure ** 2).mean(axis=0)).tolist(),
        "closure_median_px": float(np.median(rc)),
        "closure_predicted_rms_per_axis_px": closure_pred.tolist(),
        "closure_ratio_observed_to_predicted": (np.sqrt((closure ** 2).mean(axis=0)) / closure_pred).tolist(),
        "backward_statuses": {s: int(c) for s, c in zip(*np.unique(back.status, return_counts=True))},
        "lsm_rms_sigma_xy_px": np.sqrt((fwd.sigma[ok] ** 2).mean(axis=0)).tolist(),
        "lsm_ms_per_match": 1e3 * t_lsm / len(pts),
        "scale_frame_per_ortho_px": float(np.sqrt(np.abs(np.linalg.det(J))).mean()),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer pairs and points (about 15 s)")
    ap.add_argument("--seed", type=int, default=20261121)
    args = ap.parse_args(argv)
    n_pairs, n_pts, n_tgt = (1, 40, 40) if args.quick else (3, 80, 200)
    rng = np.random.default_rng(args.seed)
    cv2.setNumThreads(1)
    patches = load_patches()
    results = {"config": {"quick": args.quick, "seed": args.seed, "half_window": H, "pairs_per_patch": n_pairs,
                          "points_per_pair": n_pts, "patches": list(patches), "python": platform.python_version(),
                          "opencv": cv2.__version__}}
    for name, spec in SCENARIOS.items():
        results[name] = run_scenario(patches, spec, rng, n_pairs, n_pts)
    results["x_targets"] = run_targets(rng, n_tgt)
    results["real_pair_ortho_to_frame"] = run_real_pair(rng, 60 if args.quick else 200)

    print(f"{'scenario':26s} {'method':13s} {'ok%':>6s} {'gross':>5s} {'bias x':>8s} {'bias y':>8s} "
          f"{'RMSE':>7s} {'RMSE*':>7s} {'ms':>6s}")
    for name in SCENARIOS:
        for k, v in results[name].items():
            if k == "lsm_sigma":
                continue
            b = v.get("bias", [np.nan, np.nan])
            rs = v.get("rmse_without_gross")
            print(f"{name:26s} {k:13s} {100 * v['success']:6.1f} {v['gross_gt_0.5px']:5d} {b[0]:8.4f} {b[1]:8.4f} "
                  f"{v.get('rmse', np.nan):7.4f} {rs if rs is not None else np.nan:7.4f} {v['ms_per_match']:6.2f}")
        s = results[name]["lsm_sigma"]
        print(f"{'':26s} LSM σ: RMSE/RMSσ x {s['ratio_rmse_to_sigma'][0]:.2f} y {s['ratio_rmse_to_sigma'][1]:.2f};"
              f" robust spread of e/σ x {s['robust_spread_of_e_over_sigma'][0]:.2f}"
              f" y {s['robust_spread_of_e_over_sigma'][1]:.2f}")
    t = results["x_targets"]
    print(f"X targets: n {t['n']} failed {t['failed']} RMSE {t['rmse']:.4f} px max {t['max']:.4f} px "
          f"RMS σ {t['rms_sigma_xy'][0]:.4f}/{t['rms_sigma_xy'][1]:.4f} {t['ms_per_target']:.1f} ms")
    print("RMSE* = RMSE without gross errors (> 0.5 px); ms = time per match on one core")
    rp = results["real_pair_ortho_to_frame"]
    if "skipped" in rp:
        print("real pair:", rp["skipped"])
    else:
        print(f"real pair ortho 1 -> frame 0182 (rotated 180°, scale {rp['scale_frame_per_ortho_px']:.2f}): "
              f"LSM ok {100 * rp['lsm_success']:.0f}% of {rp['n']}, vs camera geometry median "
              f"{rp['lsm_vs_geometry_median_px']:.2f} px RMSE {rp['lsm_vs_geometry_rmse_px']:.2f} px "
              f"(ECC median {rp['ecc_vs_geometry_median_px']:.2f} RMSE {rp['ecc_vs_geometry_rmse_px']:.2f}); "
              f"forward/backward closure RMS {rp['closure_rms_per_axis_px'][0]:.3f}/"
              f"{rp['closure_rms_per_axis_px'][1]:.3f} px (n {rp['closure_n']}), predicted from LSM σ "
              f"{rp['closure_predicted_rms_per_axis_px'][0]:.3f}/{rp['closure_predicted_rms_per_axis_px'][1]:.3f} px")
    out = ROOT / "benchmarks" / "results" / "matching_bench.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(results, indent=2))
    tmp.replace(out)
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
