"""Issue-19 SURF protocol: repeatability and matching score on held-out real tiles.

Run:  .venv/bin/python benchmarks/surf_bench.py --protocol [--images ...] [--cases ...]

Every method (fotogeo SURF, OpenCV SIFT, mahotas SURF; OTB where installed, matches only)
gets the same uint8 images: tile A (a real image, band mean stretched 1-99 % to 0..255)
and B = T(A) for a known rotation, scale or rotation + scale T (bilinear warp onto a
canvas holding all of B). Protocol of issue 19:

- each method keeps its **1500** keypoints of largest |response| in A and in B;
- only keypoints whose transformed position lies inside the other image's valid area
  (eroded by 16 px) count; n = min(n_A, n_B) of those;
- repeatability = min(#A with a B keypoint within **2.5 px** of T(x_A), #B with an A
  keypoint within 2.5 px) / n (position only, no scale test);
- matches: nearest neighbour in descriptor space (L2; SURF methods only across equal
  Laplacian signs) passing Lowe's **0.8** ratio test; *correct* when |T(x_A) - x_B| <= **3 px**;
  matching score = correct matches / n; precision = correct matches / matches.

Localisation (``localisation``): the keypoints' own position error under a known warp,
before any LSM: for the correct ratio-test matches of a method, e = T(x_A) - x_B, reported
as median |e| and RMS |e|, and the dense error (mean and max over the image, in B pixels)
of a least-squares homography fitted to RANSAC inliers (3 px) against the exact warp.
OpenCV SIFT keypoints are corrected by the -0.25 px that fotogeo's pipeline applies
(:data:`fotogeo.features.detect.SIFT_OFFSET`).
"""
from __future__ import annotations

import time

import cv2
import numpy as np

N_TOP = 1500
REP_TOL = 2.5
MATCH_TOL = 3.0
RATIO = 0.8
MIN_VALID = 0.5      # smallest valid fraction of a fourth-set tile (surf_heldout; earlier splits have 42 %)

#: held-out tiles: (name, path under the data folder, crop (row0, col0, rows, cols) or None)
TILES = [
    ("ngi_ortho_2", "ngi/ortho/ngi_rgb_byte_2.tif", None),
    ("ngi_ortho_2_512", "ngi/ortho/ngi_rgb_byte_2.tif", (450, 150, 512, 512)),
    ("ngi_ortho_1", "ngi/ortho/ngi_rgb_byte_1.tif", None),
    ("sentinel2_ngi", "ngi/sentinel2_b432_byte.tif", None),
    ("landsat", "landsat_rgb/RGB.byte.tif", None),
    ("s2_ref_crop", "s2_pair/ref_S2A_20160608T153121_T33UUU_sub.jp2", (1200, 1300, 900, 900)),
    ("s2_tgt_crop", "s2_pair/tgt_S2A_20160529T153631_T33UUU_sub.jp2", (1700, 1000, 900, 900)),
]

CASES = ([("rotation", f"rot{d}", d, 1.0) for d in (15, 30, 45, 90, 135, 180)]
         + [("scale", f"scale{s}", 0, s) for s in (0.5, 0.7, 1.4, 2.0)]
         + [("rotation+scale", f"rot{d}_scale{s}", d, s) for d, s in ((45, 1.3), (30, 0.7), (90, 1.5), (135, 0.6))])


def load_tile(data, rel, crop):
    """Band mean stretched (1-99 %) to 0..255 uint8 and its valid mask (all bands > 0)."""
    import rasterio
    from rasterio.windows import Window
    with rasterio.open(data / rel) as ds:
        win = None if crop is None else Window(crop[1], crop[0], crop[3], crop[2])
        a = ds.read(window=win).astype(np.float32)
    valid = (a > 0).all(0)
    m = a.mean(0)
    lo, hi = np.percentile(m[valid], [1, 99])
    img = np.clip((m - lo) / (hi - lo) * 255, 0, 255)
    img[~valid] = 0
    return np.rint(img).astype(np.uint8), valid


def load_variant(data, rel, crop, opts=None, min_valid=0.0):
    """A tile as :func:`load_tile` with the variant options of ``opts`` (issue 32's other band sets):
    ``band`` (1-based) one band instead of the band mean; ``pca`` the first principal component
    (:func:`fotogeo.image.fusion.pca_fuse`) instead of the mean; ``raw`` also return the values
    before the uint8 stretch (float32, 0 outside the valid mask), which fotogeo then gets instead
    of the uint8 image (a 16-bit band or float heights as a user passes them). Valid: every band
    finite and > 0. Returns (uint8 image, valid mask, raw values or None)."""
    import rasterio
    from rasterio.windows import Window
    opts = opts or {}
    with rasterio.open(data / rel) as ds:
        win = None if crop is None else Window(crop[1], crop[0], crop[3], crop[2])
        a = ds.read(window=win).astype(np.float32)
    if opts.get("band"):
        a = a[[opts["band"] - 1]]
    valid = (np.isfinite(a) & (a > 0)).all(0)
    if valid.mean() < min_valid:    # a crop of the swath's nodata would score a handful of keypoints
        raise ValueError(f"{rel} crop {crop}: only {valid.mean():.0%} of the pixels are valid "
                         f"(> 0); choose a crop at least {min_valid:.0%} valid")
    if opts.get("pca"):
        from fotogeo.image.fusion import pca_fuse
        m = pca_fuse(a, valid).image
    else:
        m = np.where(valid, a.mean(0), 0).astype(np.float32)
    lo, hi = np.percentile(m[valid], [1, 99])
    img = np.clip((m - lo) / (hi - lo) * 255, 0, 255)
    img[~valid] = 0
    raw = np.where(valid, m, 0).astype(np.float32) if opts.get("raw") else None
    return np.rint(img).astype(np.uint8), valid, raw


def evaluate(fa, fb, hm, va, vb, apply_h, inside):
    """Protocol scores of keypoints/descriptors fa = (xy, s, desc, response, lap) in A, fb in B."""
    def topn(f):
        xy, _, d, r, lap = f
        i = np.argsort(-np.abs(r), kind="stable")[:N_TOP]
        return xy[i], d[i], (None if lap is None else lap[i])
    (xa, da, la), (xb, db, lb) = topn(fa), topn(fb)
    ma = apply_h(hm, xa)
    ia = inside(vb, ma) & inside(va, xa)
    ib = inside(va, apply_h(np.linalg.inv(hm), xb)) & inside(vb, xb)
    xa, da, ma, xb, db = xa[ia], da[ia], ma[ia], xb[ib], db[ib]
    n = min(len(xa), len(xb))
    res = {"n_a": int(len(xa)), "n_b": int(len(xb)), "repeatability": 0.0, "matching_score": 0.0,
           "precision": 0.0, "matches": 0, "correct": 0}
    if n == 0:
        return res, None
    d2 = ((ma[:, None, :] - xb[None]) ** 2).sum(-1)
    near = d2 <= REP_TOL ** 2
    res["repeatability"] = float(min(near.any(1).sum(), near.any(0).sum()) / n)
    da, db = da.astype(np.float32), db.astype(np.float32)
    dd = (da * da).sum(1)[:, None] + (db * db).sum(1)[None] - 2 * da @ db.T
    if la is not None and lb is not None:
        dd[la[ia][:, None] != lb[ib][None]] = np.inf
    if dd.shape[1] < 2:
        return res, None
    nn = dd.argmin(1)
    part = np.sqrt(np.maximum(np.partition(dd, 1, axis=1)[:, :2], 0))
    ok = np.isfinite(part[:, 0]) & (part[:, 0] < RATIO * part[:, 1])
    err = ma - xb[nn]
    correct = ok & (np.hypot(err[:, 0], err[:, 1]) <= MATCH_TOL)
    res.update(matching_score=float(correct.sum() / n), precision=float(correct.sum() / max(ok.sum(), 1)),
               matches=int(ok.sum()), correct=int(correct.sum()))
    return res, (xa[ok], xb[nn[ok]], correct[ok])


def localisation(pairs, hm, shape_a, apply_h):
    """Position error of correct matches and dense error of a fitted homography (B pixels)."""
    xa, xb, correct = pairs
    e = np.hypot(*(apply_h(hm, xa[correct]) - xb[correct]).T)
    out = {"n_correct": int(correct.sum()), "median_px": float(np.median(e)) if len(e) else None,
           "rms_px": float(np.sqrt(np.mean(e ** 2))) if len(e) else None}
    if len(xa) >= 8:
        h, inl = cv2.findHomography(xa - 0.5, xb - 0.5, cv2.RANSAC, MATCH_TOL, maxIters=5000, confidence=0.999)
        if h is not None:
            sel = inl.ravel() > 0
            h, _ = cv2.findHomography(xa[sel] - 0.5, xb[sel] - 0.5, 0)    # least squares on inliers
            rows, cols = shape_a
            gy, gx = np.mgrid[0:rows:8, 0:cols:8]
            g = np.column_stack([gx.ravel(), gy.ravel()]) + 0.5
            de = np.hypot(*(apply_h(h, g) - apply_h(hm, g)).T)
            out.update(inliers=int(sel.sum()), dense_mean_px=float(de.mean()), dense_max_px=float(de.max()))
    return out


def run(data, methods, geometric, rotation_scale, apply_h, inside, tiles=None, cases=None, log=print):
    """Protocol rows: one per (tile, case) with every method's scores; ``methods``: name -> f(img)."""
    rows = []
    for name, rel, crop in TILES:
        if tiles and name not in tiles:
            continue
        a, va = load_tile(data, rel, crop)
        t0 = time.perf_counter()
        feats_a = {m: f(a) for m, f in methods.items()}
        for fam, label, deg, s in CASES:
            if cases and label not in cases and fam not in cases:
                continue
            b, vb, hm = geometric(a, va, rotation_scale(deg, s))
            row = {"image": name, "family": fam, "case": label}
            for m, f in methods.items():
                row[m], _ = evaluate(feats_a[m], f(b), hm, va, vb, apply_h, inside)
            rows.append(row)
            log(f"  {name:14s} {label:16s} " + "  ".join(
                f"{m} rep {row[m]['repeatability']:.3f} ms {row[m]['matching_score']:.3f} "
                f"pr {row[m]['precision']:.2f}" for m in methods), flush=True)
        log(f"  ({name}: {time.perf_counter() - t0:.0f} s)", flush=True)
    return rows


def warp_matrix(deg=200.0, scale=0.9, persp=(2e-5, -1e-5)):
    """The localisation warp (centre convention): rotation + scale + a mild perspective."""
    h = np.eye(3)
    h[:2] = cv2.getRotationMatrix2D((0.0, 0.0), deg, scale)
    h[2, :2] = persp
    return h


def localise(data, methods, geometric, apply_h, inside, tiles=None, log=print):
    """Per tile and method: position error of correct matches and fitted-homography dense error
    under :func:`warp_matrix` (B pixels), before any LSM."""
    out = []
    for name, rel, crop in TILES:
        if tiles and name not in tiles:
            continue
        a, va = load_tile(data, rel, crop)
        b, vb, hm = geometric(a, va, warp_matrix())
        row = {"image": name}
        for m, f in methods.items():
            res, pairs = evaluate(f(a), f(b), hm, va, vb, apply_h, inside)
            row[m] = localisation(pairs, hm, a.shape, apply_h) if pairs is not None else None
        out.append(row)
        log(f"  {name:14s} " + "  ".join(
            f"{m} med {row[m]['median_px']:.3f} rms {row[m]['rms_px']:.3f} "
            f"dense {row[m].get('dense_mean_px', np.nan):.3f}" for m in methods if row[m]), flush=True)
    return out


def summary(rows, methods):
    """Per case (mean over tiles), and per tile and case the ratios the issue's targets use."""
    out = {}
    for fam, label, _, _ in CASES:
        sel = [r for r in rows if r["case"] == label]
        if sel:
            out[label] = {m: {k: float(np.mean([r[m][k] for r in sel]))
                              for k in ("repeatability", "matching_score", "precision")} for m in methods}
    return out


def worst(rows, ours="fotogeo"):
    """Targets per (tile, case): ms_ours / ms_sift >= 0.8, rep_ours >= rep_mahotas; the misses."""
    miss = []
    for r in rows:
        ms = r[ours]["matching_score"] / max(r["sift"]["matching_score"], 1e-9)
        rep = r[ours]["repeatability"] - r["mahotas"]["repeatability"] if "mahotas" in r else 0.0
        if ms < 0.8 or rep < 0:
            miss.append((r["image"], r["case"], round(ms, 3), round(rep, 3)))
    return miss
