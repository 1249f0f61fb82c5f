"""Where SURF's protocol misses come from: the scores of surf_heldout.py split by keypoint scale.

Run:  .venv/bin/python benchmarks/surf_scales.py TILE CASE [--method fotogeo|refined|sift]

TILE is a tile name of ``surf_heldout.py`` (any split), CASE a case label of the protocol
(``surf_protocol.CASES``). Same images, top-1500 cut and overlap as the protocol; A's keypoints
in the overlap are binned by scale (SURF s; SIFT sigma = OpenCV size / 2) and per bin the script
prints: how many, the share repeated (a B keypoint within 2.5 px of T(x_A)), correctly matched
(ratio 0.8, within 3 px), passing the ratio test at all, the median distance from T(x_A) to the
nearest B keypoint, and for the repeated ones the mean signed error in A's frame (a bias) and the
median scale ratio s_B / (s_A x scale of T). ``refined`` is ``surf(refine_positions=True)``.
Prints only.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import surf_heldout as sh  # noqa: E402
import surf_protocol as sp  # noqa: E402
from surf_bench import DATA, apply_h, geometric, inside, rotation_scale, run_sift_corrected  # noqa: E402

EDGES = (0.0, 1.6, 3.2, 6.0, 11.6, np.inf)


def features(img, method):
    """(xy, scale, descriptors, response, laplacian) of one method."""
    if method == "sift":
        xy, size, d, r, _ = run_sift_corrected(img)
        return xy, size / 2, d, r, np.zeros(len(r), np.int8)
    from fotogeo.features import surf
    r = surf(img, hessian_threshold=10.0, refine_positions=method == "refined")
    return r.xy, r.scale, r.descriptors, r.response, r.laplacian


def by_scale(fa, fb, hm, va, vb, scale):
    """Rows per scale bin of A's top keypoints in the overlap (see the module docstring)."""
    def top(f):
        i = np.argsort(-np.abs(f[3]), kind="stable")[:sp.N_TOP]
        return [a[i] for a in (f[0], f[1], f[2], f[4])]
    (xa, sa, da, la), (xb, sb, db, lb) = top(fa), top(fb)
    ma = apply_h(hm, xa)
    ia = inside(vb, ma) & inside(va, xa)
    ib = inside(va, apply_h(np.linalg.inv(hm), xb)) & inside(vb, xb)
    xa, sa, da, la, ma = xa[ia], sa[ia], da[ia].astype(np.float32), la[ia], ma[ia]
    xb, sb, db, lb = xb[ib], sb[ib], db[ib].astype(np.float32), lb[ib]
    dist = np.sqrt(((ma[:, None] - xb[None]) ** 2).sum(-1))
    near, jn = dist.min(1), dist.argmin(1)
    dd = (da * da).sum(1)[:, None] + (db * db).sum(1)[None] - 2 * da @ db.T
    dd[la[:, None] != lb[None]] = np.inf
    nn = dd.argmin(1)
    part = np.sqrt(np.maximum(np.partition(dd, 1, axis=1)[:, :2], 0))
    ok = np.isfinite(part[:, 0]) & (part[:, 0] < sp.RATIO * part[:, 1])
    correct = ok & (np.hypot(*(ma - xb[nn]).T) <= sp.MATCH_TOL)
    err = apply_h(np.linalg.inv(hm), xb[jn]) - xa
    rows = []
    for lo, hi in zip(EDGES[:-1], EDGES[1:]):
        m = (sa >= lo) & (sa < hi)
        if not m.any():
            continue
        rep = m & (near <= sp.REP_TOL)
        rows.append({"bin": (lo, hi), "n": int(m.sum()), "repeated": float((near[m] <= sp.REP_TOL).mean()),
                     "correct": float(correct[m].mean()), "ratio_ok": float(ok[m].mean()),
                     "median_px": float(np.median(near[m])),
                     "bias_px": err[rep].mean(0).round(2).tolist() if rep.any() else None,
                     "scale_ratio": float(np.median(sb[jn[rep]] / (sa[rep] * scale))) if rep.any() else None})
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tile")
    ap.add_argument("case")
    ap.add_argument("--method", choices=("fotogeo", "refined", "sift"), default="fotogeo")
    args = ap.parse_args(argv)
    tile = next(t for t in sh.DEV + sh.HELDOUT + sh.HELDOUT2 if t[0] == args.tile)
    _, _, deg, s = next(c for c in sp.CASES if c[1] == args.case)
    a, va = sp.load_tile(DATA, tile[1], tile[2])
    b, vb, hm = geometric(a, va, rotation_scale(deg, s))
    t0 = time.process_time()
    fa = features(a, args.method)
    t1 = time.process_time()
    fb = features(b, args.method)
    print(f"{args.tile} {args.case} {args.method}: CPU A {t1 - t0:.1f} s, B {time.process_time() - t1:.1f} s")
    print("scale bin      n    repeated correct ratio-ok median px  bias px (A frame)  s_B/(s_A k)")
    for r in by_scale(fa, fb, hm, va, vb, s):
        lo, hi = r["bin"]
        print(f"[{lo:4.1f},{hi:5.1f}) {r['n']:5d}   {r['repeated']:.2f}     {r['correct']:.2f}    {r['ratio_ok']:.2f}"
              f"     {r['median_px']:5.2f}    {str(r['bias_px']):16s}   {r['scale_ratio'] or float('nan'):.3f}")


if __name__ == "__main__":
    main()
