"""SURF benchmark (issue 3): fotogeo's SURF vs mahotas SURF, Orfeo ToolBox SURF, OpenCV SIFT.

Run:  .venv/bin/python benchmarks/surf_bench.py [--quick]
      .venv/bin/python benchmarks/surf_bench.py --protocol [--jobs N] [--tiles ...] [--cases ...]

``--protocol`` runs issue 19's protocol instead (held-out tiles, top 1500 keypoints by
|response|, repeatability within 2.5 px, ratio-0.8 matches correct within 3 px; see
``benchmarks/surf_protocol.py``) and the keypoints' localisation error under a known warp;
a full protocol run stores its rows under ``"protocol"`` in the JSON, keeping the rest;
``--jobs N`` runs N tiles at once (one process each).

Quality: image A (a real image, robustly stretched to 0..255, uint8) and B = T(A) for a
known transform T (rotation 15..180 deg, scale 0.5..2, a viewpoint homography, Gaussian
blur, brightness/contrast, noise). Every method gets the same uint8 images and no mask.
Each method keeps its N strongest keypoints in A (N = 1000) and N x area(B)/area(A) in B.

- A keypoint pair *corresponds* when T(xa) lies within 1.5 px of xb and the scales agree
  within +-30 % (scale_b / (scale_a * local scale of T) in [1/1.3, 1.3]).
- Only keypoints whose transformed position falls inside the other image (its valid area
  eroded by 16 px, so that no detector sees the nodata edge) count ("in the overlap").
- repeatability = corresponding keypoints / min(n_A, n_B in the overlap);
  matching score = correct nearest-neighbour descriptor matches / min(n_A, n_B);
  ratio score = correct matches passing the 0.8 ratio test / min(n_A, n_B).
  Nearest neighbours: L2 on descriptors; SURF methods compare only equal Laplacian signs.
- OTB's HomologousPointsExtraction only outputs matched pairs (its own ratio test, set to
  0.8, no scales): it gets a ratio score = correct pairs (1.5 px) / min(keypoints found in
  A, in B) -- the whole images, which slightly favours nobody but is not the overlap.
- Real pair: NGI frame 0182 vs orthophoto tile 1 (~180 deg, relief): ratio-test matches and
  their inliers of a RANSAC homography (5 px).

Speed: detection + description of one image of about 1, 4 and 16 Mpx (mirror-tiled from
the NGI orthophoto, real texture at every size), each method in a fresh process with its
default settings; peak memory = growth of the process's resident high-water mark during
the call. OTB runs as a command line (HomologousPointsExtraction against a 64x64 second
image), so its time includes the application start-up (reported separately) and its
memory is the whole process's peak.

Writes benchmarks/results/surf_bench.json and prints tables with ratios vs the peers.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "benchmarks" / "results" / "surf_bench.json"
N_KEEP = 1000
#: Match SURF keypoints only within equal Laplacian sign (as SURF prescribes; SIFT has none).
#: Measured: no change in any score (opposite-contrast descriptors are far apart anyway).
USE_LAPLACIAN = True
TOL = 1.5
IMAGES = {
    "ngi_frame_0182": "ngi/frames/3324c_2015_1004_05_0182_RGB.tif",
    "ngi_ortho_1": "ngi/ortho/ngi_rgb_byte_1.tif",
    "landsat_rgb": "landsat_rgb/RGB.byte.tif",
}


# ----------------------------------------------------------------------------- data
def load(rel):
    """Band mean of a real RGB image stretched (1-99 %) to 0..255 as uint8, and its valid mask."""
    from surf_protocol import load_tile  # one loader for both benchmarks
    return load_tile(DATA, rel, None)


def _canvas(h, w, hm):
    """Size of the canvas holding the whole transformed image and the shift putting it at 0."""
    c = np.array([[0, 0, 1], [w - 1, 0, 1], [0, h - 1, 1], [w - 1, h - 1, 1]], float).T
    p = hm @ c
    p = p[:2] / p[2]
    lo, hi = np.floor(p.min(1)), np.ceil(p.max(1))
    shift = np.array([[1, 0, -lo[0]], [0, 1, -lo[1]], [0, 0, 1]])
    return int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1), shift @ hm


def geometric(img, valid, hm):
    """Warp with the 3x3 homography hm (centre convention) onto a canvas holding all of it."""
    h, w = img.shape
    nw, nh, hm = _canvas(h, w, hm)
    b = cv2.warpPerspective(img, hm, (nw, nh), flags=cv2.INTER_LINEAR)
    vb = cv2.warpPerspective(valid.astype(np.float32), hm, (nw, nh), flags=cv2.INTER_LINEAR) > 0.999
    b[~vb] = 0
    return b, vb, hm


def rotation_scale(deg, scale):
    m = cv2.getRotationMatrix2D((0.0, 0.0), deg, scale)
    return np.vstack([m, [0, 0, 1]])


def transforms(quick):
    """(family, label, function(img, valid) -> (img_b, valid_b, H)) for every test case."""
    rot = [30, 90, 180] if quick else [15, 30, 45, 90, 135, 180]
    scl = [0.5, 2.0] if quick else [0.5, 0.7, 1.4, 2.0]
    out = [("rotation", f"rot{d}", lambda a, v, d=d: geometric(a, v, rotation_scale(d, 1.0)))
           for d in rot]
    out += [("scale", f"scale{s}", lambda a, v, s=s: geometric(a, v, rotation_scale(0, s)))
            for s in scl]
    rs = [(45, 1.3)] if quick else [(45, 1.3), (30, 0.7), (90, 1.5), (135, 0.6)]
    out += [("rotation+scale", f"rot{d}_scale{s}", lambda a, v, d=d, s=s: geometric(a, v, rotation_scale(d, s)))
            for d, s in rs]

    def view(a, v, k):
        h, w = a.shape
        src = np.float32([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]])
        dst = src + np.float32([[k * w, k * h], [-k * w, 0], [0, 0], [0, -k * h * 0.5]])
        return geometric(a, v, cv2.getPerspectiveTransform(src, dst))
    out += [("viewpoint", f"homography{k}", lambda a, v, k=k: view(a, v, k))
            for k in ([0.15] if quick else [0.1, 0.2])]

    def photometric(f):
        return lambda a, v: (np.where(v, f(a), 0).astype(np.uint8), v.copy(), np.eye(3))
    out += [("blur", f"blur{s}", photometric(lambda a, s=s: cv2.GaussianBlur(a, (0, 0), s)))
            for s in ([2.0] if quick else [1.0, 2.0, 3.0])]
    bc = [(0.6, 40), (1.4, -40)] if not quick else [(0.6, 40)]
    out += [("brightness", f"gain{g}_off{o}", photometric(
        lambda a, g=g, o=o: np.clip(g * a.astype(np.float32) + o, 0, 255).round()))
        for g, o in bc]
    rng_seed = 7
    out += [("noise", f"noise{s}", photometric(
        lambda a, s=s: np.clip(a + np.random.default_rng(rng_seed).normal(0, s, a.shape), 0, 255).round()))
        for s in ([8] if quick else [5, 10])]
    return out


# ----------------------------------------------------------------------------- methods
def run_ours(img):
    """fotogeo's SURF with the box filters (``gaussian=False``): the detector these tables were measured with and
    the registration pipeline's; the Gaussian-layer default is measured by ``surf_heldout.py --gaussian``."""
    from fotogeo.features import surf
    r = surf(img, hessian_threshold=10.0, gaussian=False)
    return r.xy, r.scale, r.descriptors, r.response, r.laplacian


def run_ours_refined(img):
    """fotogeo's SURF with positions from the Gaussian scale-space fit (refine_positions=True)."""
    from fotogeo.features import surf
    r = surf(img, hessian_threshold=10.0, refine_positions=True, gaussian=False)
    return r.xy, r.scale, r.descriptors, r.response, r.laplacian


def run_ours_no_fine(img):
    """fotogeo's SURF without the fine octave (surf(upscale=False), the default before issue 19; box filters)."""
    from fotogeo.features import surf
    r = surf(img, hessian_threshold=10.0, upscale=False, gaussian=False)
    return r.xy, r.scale, r.descriptors, r.response, r.laplacian


def run_sift(img):
    sift = cv2.SIFT_create()
    kp, d = sift.detectAndCompute(img, None)
    if not kp:
        return np.zeros((0, 2)), np.zeros(0), np.zeros((0, 128), np.float32), np.zeros(0), None
    xy = np.array([k.pt for k in kp], float) + 0.5      # OpenCV centre -> GDAL corner
    return xy, np.array([k.size for k in kp]), d, np.array([k.response for k in kp]), None


def run_mahotas(img, max_points=4 * N_KEEP):
    import mahotas.features.surf as ms
    p = ms.surf(img.astype(np.float64), max_points=max_points)
    if not len(p):
        return np.zeros((0, 2)), np.zeros(0), np.zeros((0, 64), np.float32), np.zeros(0), np.zeros(0)
    xy = p[:, [1, 0]] + 0.5                              # array indices -> GDAL corner
    return xy, p[:, 2], p[:, 6:].astype(np.float32), p[:, 3], np.sign(p[:, 4])


def run_sift_corrected(img):
    """SIFT with fotogeo's pipeline correction of OpenCV's +0.25 px offset (detect.SIFT_OFFSET)."""
    from fotogeo.features.detect import SIFT_OFFSET
    xy, s, d, r, lap = run_sift(img)
    return xy - SIFT_OFFSET, s, d, r, lap


METHODS = {"fotogeo": run_ours, "mahotas": run_mahotas, "sift": run_sift}
DEFAULTS = {  # speed runs: every method as a user would call it
    "fotogeo": lambda img: __import__("fotogeo.features", fromlist=["surf"]).surf(img),
    "mahotas": lambda img: run_mahotas(img, max_points=1024),
    "sift": run_sift,
}


def write_tif(path, img):
    import warnings

    import rasterio
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(path, "w", driver="GTiff", width=img.shape[1], height=img.shape[0],
                           count=1, dtype="uint8") as ds:
            ds.write(img, 1)


def run_otb(img_a, img_b, tmp):
    """OTB SURF matches (corner convention) and keypoint counts, or None if OTB is missing."""
    exe = shutil.which("otbcli_HomologousPointsExtraction")
    if exe is None:
        return None
    pa, pb, out = Path(tmp) / "a.tif", Path(tmp) / "b.tif", Path(tmp) / "pairs.txt"
    write_tif(pa, img_a)
    write_tif(pb, img_b)
    t0 = time.perf_counter()
    p = subprocess.run([exe, "-in1", str(pa), "-in2", str(pb), "-out", str(out), "-algorithm", "surf",
                        "-threshold", "0.8"], capture_output=True, text=True, check=False)
    dt = time.perf_counter() - t0
    n = [int(line.split("Found ")[1].split()[0]) for line in (p.stdout + p.stderr).splitlines()
         if "surf points in image" in line]
    pairs = np.loadtxt(out, ndmin=2) if out.exists() and out.stat().st_size else np.zeros((0, 4))
    # OTB writes physical coordinates; without a georeference they equal GDAL's (corner)
    # pixel coordinates (checked: the identity/blur cases match at < 0.5 px).
    return pairs.reshape(-1, 4), (n + [0, 0])[:2], dt


# ----------------------------------------------------------------------------- evaluation
def apply_h(hm, xy):
    c = np.asarray(xy, float) - 0.5
    p = np.column_stack([c, np.ones(len(c))]) @ hm.T
    return p[:, :2] / p[:, 2:] + 0.5


def local_scale(hm, xy):
    """sqrt |det J| of the homography at corner-convention points."""
    e = 0.5
    px, py = apply_h(hm, xy + [e, 0]) - apply_h(hm, xy - [e, 0]), apply_h(hm, xy + [0, e]) - apply_h(hm, xy - [0, e])
    return np.sqrt(np.abs(px[:, 0] * py[:, 1] - px[:, 1] * py[:, 0]))


def inside(valid, xy, margin=16):
    er = cv2.erode(valid.astype(np.uint8), np.ones((2 * margin + 1,) * 2, np.uint8)) > 0
    c = np.floor(xy).astype(int)
    ok = (c[:, 0] >= 0) & (c[:, 1] >= 0) & (c[:, 0] < valid.shape[1]) & (c[:, 1] < valid.shape[0])
    ok[ok] = er[c[ok, 1], c[ok, 0]]
    return ok


def top(feat, n):
    """The n strongest keypoints: (xy, scale, descriptors, laplacian sign or None)."""
    xy, s, d, r, lap = feat
    i = np.argsort(-r, kind="stable")[:n]
    return xy[i], s[i], d[i], (None if lap is None else lap[i])


def evaluate(fa, fb, hm, va, vb):
    (xa, sa, da, la), (xb, sb, db, lb) = fa, fb
    ma = apply_h(hm, xa)
    ia = inside(vb, ma) & inside(va, xa)
    ib = inside(va, apply_h(np.linalg.inv(hm), xb)) & inside(vb, xb)
    xa, sa, da, ma = xa[ia], sa[ia], da[ia], ma[ia]
    xb, sb, db = xb[ib], sb[ib], db[ib]
    use_lap = USE_LAPLACIAN and la is not None and lb is not None
    if use_lap:
        la, lb = la[ia], lb[ib]
    n = min(len(xa), len(xb))
    if n == 0:
        return {"n_a": len(xa), "n_b": len(xb), "repeatability": 0.0, "matching_score": 0.0, "ratio_score": 0.0,
                    "ratio_precision": 0.0, "correct_ratio": 0}
    ls = local_scale(hm, xa)
    d2 = ((ma[:, None, :] - xb[None]) ** 2).sum(-1)
    sr = sb[None] / (sa * ls)[:, None]
    geo = (d2 <= TOL ** 2) & (sr >= 1 / 1.3) & (sr <= 1.3)
    rep = min(geo.any(1).sum(), geo.any(0).sum()) / n
    da, db = da.astype(np.float32), db.astype(np.float32)
    dd = (da * da).sum(1)[:, None] + (db * db).sum(1)[None] - 2 * da @ db.T
    if use_lap:   # SURF compares only keypoints of equal contrast type (Bay et al. 2008, 4.3)
        dd[la[:, None] != lb[None]] = np.inf
    nn = dd.argmin(1)
    part = np.partition(dd, 1, axis=1)[:, :2] if dd.shape[1] > 1 else np.c_[dd, np.full(len(dd), np.inf)]
    ratio = np.sqrt(np.maximum(part[:, 0], 0)) < 0.8 * np.sqrt(np.maximum(part[:, 1], 0))
    correct = geo[np.arange(len(xa)), nn]
    return {"n_a": len(xa), "n_b": len(xb), "repeatability": float(rep),
                "matching_score": float(correct.sum() / n), "ratio_score": float((correct & ratio).sum() / n),
                "ratio_precision": float((correct & ratio).sum() / max(ratio.sum(), 1)),
                "correct_ratio": int((correct & ratio).sum())}


def evaluate_otb(res, hm, n_keep):
    if res is None:
        return None
    pairs, (na, nb), dt = res
    if not len(pairs):
        return {"n_a": na, "n_b": nb, "ratio_score": 0.0, "ratio_precision": 0.0, "correct_ratio": 0, "seconds": dt}
    e = np.linalg.norm(apply_h(hm, pairs[:, :2]) - pairs[:, 2:], axis=1)
    c = int((e <= TOL).sum())
    return {"n_a": na, "n_b": nb, "ratio_score": c / max(min(na, nb), 1), "ratio_precision": c / len(pairs),
                "correct_ratio": c, "seconds": dt}


def quality(quick, tmp, families=None, images=None):
    names = images or (["ngi_ortho_1"] if quick else list(IMAGES))
    rows = []
    for name in names:
        a, va = load(IMAGES.get(name, name))   # a key of IMAGES or a path under DATA
        feats_a = {m: top(f(a), N_KEEP) for m, f in METHODS.items()}
        for fam, label, tf in transforms(quick):
            if families and fam not in families:
                continue
            b, vb, hm = tf(a, va)
            nb = round(N_KEEP * vb.sum() / va.sum())
            row = {"image": name, "family": fam, "case": label}
            for m, f in METHODS.items():
                row[m] = evaluate(feats_a[m], top(f(b), nb), hm, va, vb)
            row["otb"] = evaluate_otb(run_otb(a, b, tmp), hm, N_KEEP)
            rows.append(row)
            print(f"  {name:15s} {label:18s} " + "  ".join(
                f"{m} rep {row[m]['repeatability']:.2f} ms {row[m]['matching_score']:.2f}" for m in METHODS)
                + (f"  otb ratio {row['otb']['ratio_score']:.2f}" if row["otb"] else ""), flush=True)
    return rows


def real_pair(tmp):
    """NGI frame 0182 vs orthophoto tile 1 (about 180 deg apart): RANSAC homography inliers."""
    a, _ = load(IMAGES["ngi_frame_0182"])
    b, _ = load(IMAGES["ngi_ortho_1"])
    out = {}
    for m, f in METHODS.items():
        (xa, _, da, _), (xb, _, db, _) = top(f(a), 2000), top(f(b), 2000)
        matcher = cv2.BFMatcher(cv2.NORM_L2)
        knn = matcher.knnMatch(da.astype(np.float32), db.astype(np.float32), k=2)
        good = [p[0] for p in knn if len(p) == 2 and p[0].distance < 0.8 * p[1].distance]
        out[m] = _ransac(xa[[g.queryIdx for g in good]], xb[[g.trainIdx for g in good]])
    res = run_otb(a, b, tmp)
    if res is not None:
        out["otb"] = _ransac(res[0][:, :2], res[0][:, 2:])
    return out


def _ransac(pa, pb):
    if len(pa) < 8:
        return {"matches": len(pa), "inliers": 0}
    _, inl = cv2.findHomography(pa.astype(np.float32), pb.astype(np.float32), cv2.RANSAC, 5.0,
                                maxIters=5000, confidence=0.999)
    return {"matches": len(pa), "inliers": int(inl.sum()) if inl is not None else 0}


# ----------------------------------------------------------------------------- speed
def speed_image(mpx):
    a, _ = load(IMAGES["ngi_ortho_1"])
    side = round(np.sqrt(mpx * 1e6))
    reps = (-(-side // a.shape[0]), -(-side // a.shape[1]))
    tiles = np.block([[a if (i + j) % 2 == 0 else a[::-1, ::-1] for j in range(reps[1])]
                      for i in range(reps[0])])
    return np.ascontiguousarray(tiles[:side, :side])


def _status_kb(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    return 0


def child(method, path):
    """Time one call in a fresh process; print JSON {seconds, peak_mb, n}.

    Peak memory: the kernel's high-water mark of this process (VmHWM, reset after the
    warm-up through /proc/self/clear_refs) minus the resident size before the call.
    ru_maxrss is not used: it inherits the parent's size at fork.
    """
    img = np.load(path)
    f = DEFAULTS[method]
    f(np.ascontiguousarray(img[:256, :256]))          # warm-up (lazy imports, allocators)
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass
    base = _status_kb("VmRSS")
    t0 = time.perf_counter()
    r = f(img)
    dt = time.perf_counter() - t0
    peak = max(_status_kb("VmHWM"), base)
    n = len(r) if not isinstance(r, tuple) else len(r[0])
    print(json.dumps({"seconds": dt, "peak_mb": (peak - base) / 1024, "n": n}))


#: Runs a command from a small process and reports its wall time and max RSS (a child forked
#: from this big benchmark process would inherit our size in ru_maxrss).
_WRAP = ("import resource, subprocess, sys, time, json; t = time.perf_counter(); "
         "p = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
         "dt = time.perf_counter() - t; "
         "print(json.dumps(dict(seconds=dt, maxrss_kb=resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, "
         "out=p.stdout + p.stderr)))")


def speed(quick, tmp):
    sizes = [1, 4] if quick else [1, 4, 16]
    rows = []
    exe = shutil.which("otbcli_HomologousPointsExtraction")
    small = Path(tmp) / "small.tif"
    otb_startup = None
    for mpx in sizes:
        img = speed_image(mpx)
        path = Path(tmp) / f"speed_{mpx}.npy"
        np.save(path, img)
        row = {"mpx": round(img.size / 1e6, 2)}
        for m in DEFAULTS:
            best = None
            for _ in range(2 if mpx < 16 else 1):
                p = subprocess.run([sys.executable, __file__, "--child", m, str(path)],
                                   capture_output=True, text=True, check=True)
                r = json.loads(p.stdout.strip().splitlines()[-1])
                best = r if best is None or r["seconds"] < best["seconds"] else best
            row[m] = best
        if exe:
            if otb_startup is None:
                write_tif(small, img[:64, :64])
                otb_startup = min(_otb_time(exe, small, small, tmp)[0] for _ in range(2))
            tif = Path(tmp) / f"speed_{mpx}.tif"
            write_tif(tif, img)
            dt, mb, n = _otb_time(exe, tif, small, tmp)
            row["otb"] = {"seconds": dt, "seconds_minus_startup": dt - otb_startup, "peak_mb": mb, "n": n}
        rows.append(row)
        print("  " + f"{row['mpx']:5.1f} Mpx  " + "  ".join(
            f"{m} {row[m]['seconds']:.2f}s {row[m]['peak_mb']:.0f}MB n={row[m]['n']}"
            for m in list(DEFAULTS) + (["otb"] if "otb" in row else [])), flush=True)
    return rows, otb_startup


def _otb_time(exe, a, b, tmp):
    """Wall time (s), max RSS (MB) and keypoints in image 1 of one OTB SURF run."""
    p = subprocess.run([sys.executable, "-c", _WRAP, exe, "-in1", str(a), "-in2", str(b),
                        "-out", str(Path(tmp) / "t.txt"), "-algorithm", "surf"],
                       capture_output=True, text=True, check=True)
    r = json.loads(p.stdout)
    n = [int(line.split("Found ")[1].split()[0]) for line in r["out"].splitlines()
         if "surf points in image 1" in line]
    return r["seconds"], r["maxrss_kb"] / 1024, (n or [0])[0]


# ----------------------------------------------------------------------------- report
def summarise(rows):
    fams = list(dict.fromkeys(r["family"] for r in rows))
    table = {}
    for fam in fams:
        sel = [r for r in rows if r["family"] == fam]
        t = {}
        for m in list(METHODS) + ["otb"]:
            vals = [r[m] for r in sel if r.get(m)]
            if not vals:
                continue
            t[m] = {k: float(np.mean([v[k] for v in vals])) for k in vals[0] if k != "seconds"}
        table[fam] = t
    return table


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one image, fewer transforms, 1 and 4 Mpx")
    ap.add_argument("--child", nargs=2, metavar=("METHOD", "NPY"), help=argparse.SUPPRESS)
    ap.add_argument("--no-speed", action="store_true", help="skip the timing runs")
    ap.add_argument("--speed-only", action="store_true", help="only the timing runs")
    ap.add_argument("--families", help="comma-separated transform families to run (e.g. scale,rotation+scale); "
                                       "a partial run prints its tables and does not write the JSON")
    ap.add_argument("--protocol", action="store_true", help="issue 19's protocol on held-out tiles and the "
                                                            "localisation error under a known warp")
    ap.add_argument("--tiles", help="protocol: comma-separated tile names (default: all of surf_protocol.TILES)")
    ap.add_argument("--cases", help="protocol: comma-separated case labels or families (default: all)")
    ap.add_argument("--jobs", type=int, default=1, help="protocol: tiles run in this many processes at once")
    ap.add_argument("--images", help=f"comma-separated images: {', '.join(IMAGES)} or RGB paths under the data folder")
    args = ap.parse_args(argv)
    families = args.families.split(",") if args.families else None
    images = args.images.split(",") if args.images else None
    if args.child:
        return child(*args.child)
    if not DATA.is_dir():
        sys.exit(f"surf_bench: real data not found at {DATA} (set FOTOGEO_DATA)")
    if args.protocol:
        return protocol_main(args)
    with tempfile.TemporaryDirectory() as tmp:
        rows, table, rp = [], {}, {}
        if not args.speed_only:
            print("quality (mean over images and cases of each family):", flush=True)
            rows = quality(args.quick, tmp, families, images)
            table = summarise(rows)
            if families or images:   # a partial run: tables only
                print_tables(table, {}, [], None)
                return
            print("real pair (ngi frame 0182 vs ortho 1):", flush=True)
            rp = real_pair(tmp)
            print("  " + "  ".join(f"{m}: {v['inliers']}/{v['matches']}" for m, v in rp.items()))
        print("speed (detection + description):", flush=True)
        sp, startup = ([], None) if args.no_speed else speed(args.quick, tmp)
    quick = {"quality": args.quick, "speed": args.quick}
    if args.speed_only or args.no_speed:   # partial runs merge into an existing result
        old = json.loads(OUT.read_text()) if OUT.exists() else {}
        old_quick = old.get("quick") if isinstance(old.get("quick"), dict) else {}
        if args.speed_only:
            rows, table, rp = old.get("cases", []), old.get("families", {}), old.get("real_pair", {})
            quick["quality"] = old_quick.get("quality")
        else:
            sp, startup = old.get("speed", []), old.get("otb_startup_s")
            quick["speed"] = old_quick.get("speed")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    result = {"quick": quick, "n_keep": N_KEEP, "tolerance_px": TOL, "cases": rows, "families": table,
                  "real_pair": rp, "speed": sp, "otb_startup_s": startup,
                  "machine": {"cpus": os.cpu_count(), "opencv": cv2.__version__, "numpy": np.__version__},
                  "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    tmp_out = OUT.with_suffix(".json.tmp")
    tmp_out.write_text(json.dumps(result, indent=1))
    tmp_out.replace(OUT)
    print_tables(table, rp, sp, startup)
    print(f"wrote {OUT.relative_to(ROOT)}")


def protocol_main(args):
    """Issue 19's protocol (surf_protocol.py): every tile and case, then the localisation."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import surf_protocol as sp
    methods = {"fotogeo": run_ours, "fotogeo_no_fine": run_ours_no_fine, "sift": run_sift_corrected}
    try:
        import mahotas  # noqa: F401
        methods["mahotas"] = run_mahotas
    except ImportError:
        print("mahotas not installed (pip install mahotas): its column is left out", flush=True)
    if shutil.which("otbcli_HomologousPointsExtraction") is None:
        print("OTB (otb-bin) not installed: its column is left out", flush=True)
    tiles = args.tiles.split(",") if args.tiles else None
    cases = args.cases.split(",") if args.cases else None
    t0 = time.perf_counter()
    print("protocol (top %d by |response|, repeatability %.1f px, ratio %.1f matches correct within %.0f px):"
          % (sp.N_TOP, sp.REP_TOL, sp.RATIO, sp.MATCH_TOL), flush=True)
    loc_methods = {"fotogeo": run_ours, "fotogeo_refined": run_ours_refined,
                   **{m: f for m, f in methods.items() if m != "fotogeo"}}
    names = [t[0] for t in sp.TILES if not tiles or t[0] in tiles]
    with ProcessPoolExecutor(max(1, args.jobs)) as pool:    # one tile per task, results in TILES order
        done = list(pool.map(_protocol_tile, names, [cases] * len(names), [methods] * len(names),
                             [loc_methods] * len(names)))
    rows = [r for tile_rows, _ in done for r in tile_rows]
    loc = [r for _, tile_loc in done for r in tile_loc]
    misses = {m: sp.worst(rows, m) for m in methods if m.startswith("fotogeo")}
    print_protocol(rows, list(methods))
    print("\ntargets missed (tile, case, matching score / SIFT's, repeatability - mahotas'):")
    for m, miss in misses.items():
        for x in miss:
            print("  ", m, x)
    if tiles or cases:
        return
    old = json.loads(OUT.read_text()) if OUT.exists() else {}
    old["protocol"] = {"n_top": sp.N_TOP, "repeatability_px": sp.REP_TOL, "match_px": sp.MATCH_TOL,
                       "ratio": sp.RATIO, "tiles": [list(t) for t in sp.TILES], "cases": rows,
                       "per_case": sp.summary(rows, list(methods)), "misses": misses, "localisation": loc,
                       "seconds": time.perf_counter() - t0,
                       "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    tmp_out = OUT.with_suffix(".json.tmp")
    tmp_out.write_text(json.dumps(old, indent=1))
    tmp_out.replace(OUT)
    print(f"wrote {OUT.relative_to(ROOT)} (key 'protocol')")


def _protocol_tile(tile, cases, methods, loc_methods):
    """Protocol rows and localisation of one tile (a process pool task of protocol_main)."""
    import surf_protocol as sp
    rows = sp.run(DATA, methods, geometric, rotation_scale, apply_h, inside, [tile], cases)
    print(f"localisation of {tile} under a known warp (200 deg, x0.9, perspective), before LSM:", flush=True)
    return rows, sp.localise(DATA, loc_methods, geometric, apply_h, inside, [tile])


def print_protocol(rows, methods):
    """Repeatability / matching score per tile and case, ratios vs SIFT and mahotas."""
    print("\ntile            case             " + "  ".join(f"{m:>13s}" for m in methods) + "  ms/sift  rep-mah")
    for r in rows:
        cells = "  ".join(f"{r[m]['repeatability']:.3f} / {r[m]['matching_score']:.3f}" for m in methods)
        ratio = r["fotogeo"]["matching_score"] / max(r["sift"]["matching_score"], 1e-9)
        dm = r["fotogeo"]["repeatability"] - r["mahotas"]["repeatability"] if "mahotas" in r else float("nan")
        print(f"{r['image']:15s} {r['case']:16s} {cells}  {ratio:7.2f}  {dm:+7.3f}")


def print_tables(table, rp, sp, startup):
    print("\nfamily       metric          fotogeo  mahotas     sift      otb   vs mahotas  vs otb  vs sift")
    for fam, t in table.items():
        for k in ("repeatability", "matching_score", "ratio_score"):
            ours = t["fotogeo"][k]
            cells = [t.get(m, {}).get(k) for m in ("mahotas", "sift", "otb")]
            txt = "  ".join(f"{c:7.3f}" if c is not None else "      -" for c in cells)
            rat = "  ".join(f"{ours / c:8.2f}" if c else "       -" for c in (cells[0], cells[2], cells[1]))
            print(f"{fam:12s} {k:15s} {ours:7.3f}  {txt}  {rat}")
    if sp:
        print("\n  Mpx   fotogeo s (MB)    mahotas s (MB)    sift s (MB)     otb s (MB)   ours/mahotas ours/otb ours/sift")
        for r in sp:
            o = r["fotogeo"]["seconds"]
            cells = "  ".join(f"{r[m]['seconds']:6.2f} ({r[m]['peak_mb']:5.0f})" for m in ("fotogeo", "mahotas", "sift")
                              if m in r)
            otb = f"{r['otb']['seconds']:6.2f} ({r['otb']['peak_mb']:5.0f})" if "otb" in r else "     -"
            rat = [o / r["mahotas"]["seconds"], o / r["otb"]["seconds"] if "otb" in r else np.nan,
                   o / r["sift"]["seconds"]]
            print(f"{r['mpx']:5.1f}  {cells}  {otb}   " + "  ".join(f"{x:8.2f}" for x in rat))
        if startup is not None:
            print(f"(otb times include {startup:.2f} s of application start-up; peak MB for otb is the whole process)")


if __name__ == "__main__":
    main()
