"""SURF on tiles of other sensors (issue 32): issue 19's protocol beyond its seven tiles.

Run:  .venv/bin/python benchmarks/surf_heldout.py [--split S|all] [--tiles ...] [--cases ...]
(S: seven, dev, heldout, heldout2, heldout3, heldout4, heldout4_late)

The protocol of ``benchmarks/surf_protocol.py`` (top 1500 keypoints by |response|,
repeatability within 2.5 px, ratio-0.8 matches correct within 3 px, all per min(n_A, n_B) in
the overlap; 14 rotation / scale / rotation+scale cases) on tiles of sensors and scenes the
protocol's seven (NGI orthophotos, Sentinel-2, Landsat) do not include: raw NGI aerial frames,
QuickBird-2, Pleiades (uint16), drone JPEGs (snow, rock), Sentinel-2 uint16 bands of another
area. Every image is the band mean stretched 1-99 % to 0..255 uint8 (``surf_protocol.load_tile``).

``seven``: the protocol's own tiles (``surf_protocol.TILES``). The tiles are split: ``DEV`` tiles
were used while changing SURF; ``HELDOUT`` tiles were run only once the changes were fixed;
``HELDOUT2`` tiles were chosen after ``HELDOUT`` had been looked at (and SURF changed for its
misses), and run only once those changes were fixed; ``HELDOUT3`` tiles were fixed and run once
with SURF unchanged before the work on ``HELDOUT2``'s misses, and are the check of what that work
changed; ``HELDOUT4`` / ``HELDOUT4_LATE``: other band sets and input types (see there). Targets
(issue 32): on every tile and case, fotogeo's
repeatability >= mahotas' and matching score >= 0.8x OpenCV SIFT's (SIFT with fotogeo's
-0.25 px correction). fotogeo runs at threshold 10 (as in the protocol); mahotas 1.4.19 with
4000 points.

Peers' scores do not depend on fotogeo: ``--cache FILE`` keeps them between runs.
``--gaussian``: fotogeo with ``surf(gaussian=True)`` (Gaussian-derivative Hessian, the default
since it keeps one keypoint per blob across octaves), rows stored under ``<split>+gaussian``;
without it, box filters (``surf(gaussian=False)``), rows under ``<split>``.
Writes ``benchmarks/results/surf_heldout.json`` (a run's tiles replace their earlier rows there;
a run with --cases only prints).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import surf_protocol as sp  # noqa: E402
from surf_bench import (DATA, apply_h, geometric, inside, rotation_scale, run_mahotas,  # noqa: E402
                        run_sift_corrected)

OUT = HERE / "results" / "surf_heldout.json"

#: (name, path under the data folder, crop (row0, col0, rows, cols) or None[, cases]); a tile
#: larger than 4 Mpx (where fotogeo's fine octave used to be off) runs three cases only.
BIG_CASES = ("scale0.7", "rot45_scale1.3", "rot30_scale0.7")
DEV = [
    ("ngi_frame_0182", "ngi/frames/3324c_2015_1004_05_0182_RGB.tif", None),
    ("qb2_top", "qb2/qb2_basic1b.tif", (0, 0, 700, 850)),
    ("pleiades_left", "rpc/ventoux/left_image.tif", None),
    ("drone_2186", "drone_snowpeak/img/IMG_2186.JPG", (1300, 1900, 800, 800)),
    ("drone_2186_big", "drone_snowpeak/img/IMG_2186.JPG", (0, 0, 2200, 2200), BIG_CASES),
    ("drone_2188_big", "drone_snowpeak/img/IMG_2188.JPG", (600, 1000, 2200, 2200), BIG_CASES),
]
HELDOUT = [
    ("ngi_frame_0184", "ngi/frames/3324c_2015_1004_05_0184_RGB.tif", None),
    ("qb2_bottom", "qb2/qb2_basic1b.tif", (750, 0, 700, 850)),
    ("pleiades_right", "rpc/ventoux/right_image.tif", None),
    ("drone_2281", "drone_snowpeak/img/IMG_2281.JPG", (1300, 1900, 800, 800)),
    ("drone_2212", "drone_snowpeak/img/IMG_2212.JPG", (400, 400, 800, 800)),
    ("s2_ref_north", "s2_pair/ref_S2A_20160608T153121_T33UUU_sub.jp2", (100, 1400, 800, 800)),
    ("s2_tgt_south", "s2_pair/tgt_S2A_20160529T153631_T33UUU_sub.jp2", (2400, 200, 700, 800)),
    ("drone_2280_big", "drone_snowpeak/img/IMG_2280.JPG", (600, 1000, 2200, 2200), BIG_CASES),
]
#: A second held-out split, fixed before the coarse-octave change that followed the first one's
#: misses: frames and crops no SURF protocol had used (drone frames IMG_2282, IMG_2189, IMG_2213,
#: Sentinel-2 crops away from every earlier crop of either date).
HELDOUT2 = [
    ("drone_2282", "drone_snowpeak/img/IMG_2282.JPG", (400, 3000, 800, 800)),
    ("drone_2189", "drone_snowpeak/img/IMG_2189.JPG", (2200, 600, 800, 800)),
    ("drone_2213", "drone_snowpeak/img/IMG_2213.JPG", (1300, 1900, 800, 800)),
    ("s2_ref_south", "s2_pair/ref_S2A_20160608T153121_T33UUU_sub.jp2", (2300, 1300, 800, 800)),
    ("s2_tgt_northwest", "s2_pair/tgt_S2A_20160529T153631_T33UUU_sub.jp2", (300, 100, 800, 800)),
    ("drone_2189_big", "drone_snowpeak/img/IMG_2189.JPG", (1000, 2000, 2200, 2200), BIG_CASES),
    ("drone_2282_big", "drone_snowpeak/img/IMG_2282.JPG", (1100, 300, 2200, 2200), BIG_CASES),
]
#: A third held-out split, fixed (and run once with SURF unchanged) before any change aimed at
#: the second one's misses: crops no split had used, none overlapping an earlier crop of the same
#: frame or scene (drone frames IMG_2280, IMG_2281 (car park), IMG_2282 (road), IMG_2188,
#: IMG_2213; Sentinel-2 crops of both dates west / north-east of every earlier one).
HELDOUT3 = [
    ("drone_2280_east", "drone_snowpeak/img/IMG_2280.JPG", (1200, 3300, 800, 800)),
    ("drone_2281_carpark", "drone_snowpeak/img/IMG_2281.JPG", (2600, 1400, 800, 800)),
    ("drone_2282_south", "drone_snowpeak/img/IMG_2282.JPG", (2400, 2700, 800, 800)),
    ("drone_2188_east", "drone_snowpeak/img/IMG_2188.JPG", (1000, 3300, 800, 800)),
    ("drone_2213_north", "drone_snowpeak/img/IMG_2213.JPG", (200, 3000, 800, 800)),
    ("s2_ref_west", "s2_pair/ref_S2A_20160608T153121_T33UUU_sub.jp2", (1000, 200, 800, 800)),
    ("s2_tgt_northeast", "s2_pair/tgt_S2A_20160529T153631_T33UUU_sub.jp2", (300, 1150, 800, 800)),
    ("drone_2212_big", "drone_snowpeak/img/IMG_2212.JPG", (1256, 2408, 2200, 2200), BIG_CASES),
]
#: A fourth set (issue 32 item 6), fixed before any run: what the earlier splits never varied -- other
#: band sets and input types -- on crops no split used (every raster of the data folder is in an
#: earlier split, so no new sensor is left). 5th element, options of ``surf_protocol.load_variant``:
#: ``raw`` fotogeo gets the native values (Sentinel-2 / Pleiades uint16 DN, DEM heights in metres as
#: float32; the peers get the uint8 stretch); ``band`` a single band (drone green / red, Landsat blue);
#: ``pca`` the first principal component; ``date`` (path, crop): B is warped from that crop of another
#: date (Sentinel-2 2016-05-29 against 2016-06-08, the same 4 x 4 km on the 10 m grid), so every case also crosses
#: dates; the dates' residual misregistration (measured by phase correlation: (+0.57, -1.92) px, not the README's
#: <= 1 px) is part of the truth. ``HELDOUT4_LATE``, a third of the
#: tiles, was run only once changes (if any) to SURF were fixed.
S2_REF = "s2_pair/ref_S2A_20160608T153121_T33UUU_sub.jp2"
S2_TGT = "s2_pair/tgt_S2A_20160529T153631_T33UUU_sub.jp2"
S2_PLACE_REF, S2_PLACE_TGT = (700, 1000, 400, 400), (1149, 456, 400, 400)   # same ground: tgt = ref + (449, -544)
HELDOUT4 = [
    ("s2_ref_sw_u16", S2_REF, (2450, 500, 640, 640), None, {"raw": True}),
    ("s2_tgt_centre", S2_TGT, (1100, 1050, 600, 640), None, {}),
    ("drone_2186_se_green", "drone_snowpeak/img/IMG_2186.JPG", (2600, 3000, 640, 640), None, {"band": 2}),
    ("drone_2188_sw_pca", "drone_snowpeak/img/IMG_2188.JPG", (2800, 0, 640, 640), None, {"pca": True}),
    ("ngi_dem_heights", "ngi/dem.tif", None, None, {"raw": True}),
    ("landsat_blue", "landsat_rgb/RGB.byte.tif", None, None, {"band": 3}),
    ("pleiades_left_u16", "rpc/ventoux/left_image.tif", None, None, {"raw": True}),
    ("s2_place_ref", S2_REF, S2_PLACE_REF, None, {}),
]
HELDOUT4_LATE = [
    ("s2_place_tgt_u16", S2_TGT, S2_PLACE_TGT, None, {"raw": True}),
    ("s2_place_dates", S2_REF, S2_PLACE_REF, None, {"date": (S2_TGT, S2_PLACE_TGT)}),
    ("drone_2213_sw_pca", "drone_snowpeak/img/IMG_2213.JPG", (2600, 200, 640, 640), None, {"pca": True}),
    ("drone_2281_nw_red", "drone_snowpeak/img/IMG_2281.JPG", (200, 200, 640, 640), None, {"band": 1}),
]
SPLITS = {"seven": sp.TILES, "dev": DEV, "heldout": HELDOUT, "heldout2": HELDOUT2, "heldout3": HELDOUT3,
          "heldout4": HELDOUT4, "heldout4_late": HELDOUT4_LATE}
PEERS = {"sift": run_sift_corrected, "mahotas": run_mahotas}


def run_gaussian(img):
    """fotogeo's SURF with the Gaussian-derivative Hessian (``surf(gaussian=True)``)."""
    from fotogeo.features import surf
    r = surf(img, hessian_threshold=10.0, gaussian=True)
    return r.xy, r.scale, r.descriptors, r.response, r.laplacian


def run_box(img):
    """fotogeo's SURF with Bay et al.'s box filters (``surf(gaussian=False)``)."""
    from fotogeo.features import surf
    r = surf(img, hessian_threshold=10.0, gaussian=False)
    return r.xy, r.scale, r.descriptors, r.response, r.laplacian


def tile_rows(name, rel, crop, cases, cache, log=print, only=None, run_ours=run_box, opts=None):
    """Protocol rows of one tile: fotogeo (``run_ours``) computed, peers from ``cache`` when
    present; ``only``: the tile's own case list; ``opts``: ``surf_protocol.load_variant``'s options,
    and ``date`` = (path, crop) of the image B is warped from (default: the tile itself)."""
    floor, opts = (0.0, {}) if opts is None else (sp.MIN_VALID, opts)   # the fourth set's tiles: >= half valid
    a, va, ra = sp.load_variant(DATA, rel, crop, opts, floor)
    src, shift = (a, va, ra), np.eye(3)
    if opts.get("date"):    # the dates' residual misregistration d (B content at x + d), part of the truth
        src = sp.load_variant(DATA, *opts["date"], opts)
        win = cv2.createHanningWindow(a.shape[::-1], cv2.CV_32F)
        shift[:2, 2] = cv2.phaseCorrelate(a.astype(np.float32), src[0].astype(np.float32), win)[0]
        log(f"  {name}: the other date is shifted by ({shift[0, 2]:+.2f}, {shift[1, 2]:+.2f}) px (phase correlation)")
    fa, peers_a = run_ours(a if ra is None else ra), {}
    rows = []
    for fam, label, deg, s in sp.CASES:
        if (cases and label not in cases and fam not in cases) or (only and label not in only):
            continue
        b, vb, hm = geometric(src[0], src[1], rotation_scale(deg, s))
        hm = hm @ shift
        ours_b = b if src[2] is None else geometric(src[2], src[1], rotation_scale(deg, s))[0]
        row = {"image": name, "family": fam, "case": label}
        t0 = time.process_time()
        row["fotogeo"], _ = sp.evaluate(fa, run_ours(ours_b), hm, va, vb, apply_h, inside)
        row["fotogeo"]["cpu_s_b"] = time.process_time() - t0
        for m, f in PEERS.items():
            key = f"{name}|{label}|{m}"
            if key not in cache:
                if m not in peers_a:
                    peers_a[m] = f(a)
                cache[key], _ = sp.evaluate(peers_a[m], f(b), hm, va, vb, apply_h, inside)
            row[m] = cache[key]
        row["ms_ratio"] = row["fotogeo"]["matching_score"] / max(row["sift"]["matching_score"], 1e-9)
        row["rep_margin"] = row["fotogeo"]["repeatability"] - row["mahotas"]["repeatability"]
        rows.append(row)
        log(f"  {name:15s} {label:16s} rep {row['fotogeo']['repeatability']:.3f} / {row['mahotas']['repeatability']:.3f}"
            f"  ms {row['fotogeo']['matching_score']:.3f} / {row['sift']['matching_score']:.3f}"
            f"  ratio {row['ms_ratio']:.2f}  margin {row['rep_margin']:+.3f}"
            + ("  MISS" if row["ms_ratio"] < 0.8 or row["rep_margin"] < 0 else ""), flush=True)
    return rows


def report(rows, log=print):
    """Mean scores, the worst ratio / margin and the misses."""
    if not rows:
        return {}
    ms = [r["ms_ratio"] for r in rows]
    rep = [r["rep_margin"] for r in rows]
    miss = [(r["image"], r["case"], round(r["ms_ratio"], 3), round(r["rep_margin"], 3))
            for r in rows if r["ms_ratio"] < 0.8 or r["rep_margin"] < 0]
    out = {"pairs": len(rows), "met": len(rows) - len(miss), "misses": miss,
           "mean_rep": {m: float(np.mean([r[m]["repeatability"] for r in rows])) for m in ("fotogeo", "mahotas", "sift")},
           "mean_ms": {m: float(np.mean([r[m]["matching_score"] for r in rows])) for m in ("fotogeo", "mahotas", "sift")},
           "worst_ms_ratio": float(min(ms)), "worst_rep_margin": float(min(rep)),
           "cpu_s_fotogeo_b": float(sum(r["fotogeo"]["cpu_s_b"] for r in rows))}
    log(f"\n{out['met']}/{out['pairs']} pairs meet both targets; worst matching ratio {out['worst_ms_ratio']:.2f}, "
        f"worst repeatability margin {out['worst_rep_margin']:+.3f}")
    log("mean repeatability fotogeo / mahotas / sift: " + " / ".join(f"{v:.3f}" for v in out["mean_rep"].values()))
    log("mean matching score fotogeo / mahotas / sift: " + " / ".join(f"{v:.3f}" for v in out["mean_ms"].values()))
    log(f"fotogeo CPU seconds on the B images: {out['cpu_s_fotogeo_b']:.1f}")
    for x in miss:
        log(f"  miss: {x}")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", choices=(*SPLITS, "all"), default="dev")
    ap.add_argument("--tiles", help="comma-separated tile names of the split")
    ap.add_argument("--cases", help="comma-separated case labels or families (default: all 14)")
    ap.add_argument("--cache", type=Path, help="JSON file keeping the peers' scores between runs")
    ap.add_argument("--gaussian", action="store_true",
                    help="fotogeo with surf(gaussian=True) (else box filters); rows stored under '<split>+gaussian'")
    ap.add_argument("--out", type=Path, default=OUT, help=f"results JSON (default {OUT.relative_to(HERE.parent)})")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        sys.exit(f"surf_heldout: real data not found at {DATA} (set FOTOGEO_DATA)")
    tiles = [t for tl in SPLITS.values() for t in tl] if args.split == "all" else SPLITS[args.split]
    names = args.tiles.split(",") if args.tiles else None
    cases = args.cases.split(",") if args.cases else None
    cache = json.loads(args.cache.read_text()) if args.cache and args.cache.exists() else {}
    rows = []
    for name, rel, crop, *more in tiles:
        if names and name not in names:
            continue
        rows += tile_rows(name, rel, crop, cases, cache, only=more[0] if more else None,
                          run_ours=run_gaussian if args.gaussian else run_box, opts=more[1] if len(more) > 1 else None)
        if args.cache:
            args.cache.write_text(json.dumps(cache))
    report(rows)
    if cases:       # a partial case list is printed only
        return
    # rows of the tiles run replace their earlier rows; each split's summary covers its stored rows
    out = args.out
    old = json.loads(out.read_text()) if out.exists() else {}
    for split, tl in SPLITS.items():
        s = split + ("+gaussian" if args.gaussian else "")
        mine = {t[0] for t in tl}
        new = [r for r in rows if r["image"] in mine]
        if new:
            done = {r["image"] for r in new}
            kept = [r for r in old.get(s, {}).get("rows", []) if r["image"] not in done] + new
            order = [t[0] for t in tl]
            kept.sort(key=lambda r: (order.index(r["image"]), [c[1] for c in sp.CASES].index(r["case"])))
            old[s] = {"tiles": [list(t) for t in tl], "rows": kept, "summary": report(kept, log=lambda *a, **k: None),
                      "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    old["protocol"] = {"n_top": sp.N_TOP, "repeatability_px": sp.REP_TOL, "match_px": sp.MATCH_TOL,
                       "ratio": sp.RATIO, "fotogeo_threshold": 10.0}
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(old, indent=1))
    tmp.replace(out)
    print(f"wrote {out} ({len(rows)} pairs of this run)")


if __name__ == "__main__":
    main()
