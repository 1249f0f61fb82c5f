"""Tie points of a distorted block with and without the distortion removed before the epipolar RANSAC (issue 20).

The rendered oblique drone block (``tests/rendered_oblique.py``: 20 frames 640 × 480, four look directions,
gimbal −60°, Brown distortion k1 −0.06, k2 0.02, p1 0.0004, p2 −0.0003 as DJI's ``DewarpData`` writes it,
~14 px at the corners) is matched by :func:`fotogeo.tools.triangulate.match.block_tie_points` twice with the
true orientations: the fundamental-matrix RANSAC on the measured pixels (``before``) and on the pixels of the
distortion-free camera (``after``, :func:`~fotogeo.tools.triangulate.match.ideal_pixels`). Detection on pyramid
level 1, no thinning, no LSM, so the counts are the RANSAC's alone.

Per variant: pairs, epipolar inliers (sum, median and minimum per pair) and how many are right — their distance
to the true epipolar line (the fundamental matrix of the true cameras, in distortion-free pixels) below 2 px —
by the pair's inlier count; tracks, rays per track, and the right and wrong observation pairs within the tracks
(after union–find joined the pairs). Pairs are chosen on round footprints (the ``start`` hook that collects
each pair's inliers asks for them), the same for both variants.

    .venv/bin/python benchmarks/triangulate_undistort_bench.py [--seeds N]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from fotogeo.geometry.camera import OrientedFrame
from fotogeo.tools.triangulate.match import block_tie_points, ideal_pixels

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from rendered_oblique import DEWARP, oblique_block  # noqa: E402

RIGHT_PX = 2.0  # a matched pair within this distance of the true epipolar line counts as right


def true_fundamental(camera, eo_i, eo_j) -> np.ndarray:
    """The fundamental matrix of two pinhole frames (distortion-free pixels), from exact correspondences."""
    a, b = OrientedFrame(camera, eo_i), OrientedFrame(camera, eo_j)
    g = np.random.default_rng(0).uniform(-1, 1, (400, 2))
    centre = (eo_i.centre + eo_j.centre)[:2] / 2
    ground = np.column_stack([centre + 60 * g, np.random.default_rng(1).uniform(280, 320, 400)])
    pi, pj = a.world_to_pixel(ground), b.world_to_pixel(ground)
    seen = np.isfinite(pi).all(axis=1) & np.isfinite(pj).all(axis=1)  # in front of both cameras
    F, _ = cv2.findFundamentalMat(pi[seen], pj[seen], cv2.FM_8POINT)
    return F


def epipolar_distance(F, xi, xj) -> np.ndarray:
    """Distance (px) of ``xj`` to the epipolar line ``F xi`` (both ``(n, 2)``)."""
    hi, hj = np.column_stack([xi, np.ones(len(xi))]), np.column_stack([xj, np.ones(len(xj))])
    lines = hi @ F.T
    return np.abs(np.sum(lines * hj, axis=1)) / np.hypot(lines[:, 0], lines[:, 1])


def true_distances(frame, track, pixel, camera, eos, ideal) -> np.ndarray:
    """The distance (px) of every matched observation pair (every two observations of a track) to its true
    epipolar line, in distortion-free pixels."""
    out, cache = [], {}
    order = np.argsort(track, kind="stable")
    for members in np.split(order, np.flatnonzero(np.diff(track[order])) + 1):
        for x in range(len(members)):
            for y in range(x + 1, len(members)):
                i, j = int(frame[members[x]]), int(frame[members[y]])
                F = cache.setdefault((i, j), true_fundamental(camera, eos[i], eos[j]))
                out.append(epipolar_distance(F, ideal(pixel[[members[x]]]), ideal(pixel[[members[y]]]))[0])
    return np.array(out)


def pair_rows(inliers, camera, eos, ideal) -> dict:
    """Per class of pair (by its inlier count): pairs, inliers and how many are right (< ``RIGHT_PX`` from the true
    epipolar line) — the RANSAC's own inliers, before tracks join them."""
    out = {}
    for i, j, a, b in inliers:
        if len(a) == 0:
            continue
        d = epipolar_distance(true_fundamental(camera, eos[i], eos[j]), ideal(a), ideal(b))
        key = next(f"{lo}-{hi}" for lo, hi in CLASSES if lo <= len(a) < hi)
        row = out.setdefault(key, {"pairs": 0, "inliers": 0, "right": 0})
        row["pairs"] += 1
        row["inliers"] += int(len(a))
        row["right"] += int((d < RIGHT_PX).sum())
    return out


CLASSES = ((0, 15), (15, 30), (30, 60), (60, 10 ** 9))


def run(seed: int) -> list:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        blk = oblique_block(Path(tmp), seed=seed)
        cam, eos = blk["camera"], [blk["truth"][n] for n in blk["names"]]
        k1, k2, p1, p2, k3 = DEWARP
        dist = (k1, k2, k3, p1, p2)
        ideal = ideal_pixels(cam, dist)
        for name, d in (("before", None), ("after", dist)):
            got = []

            def keep_inliers(e, inliers):  # the start hook sees every pair's RANSAC inliers (pairs: round footprints)
                got.extend(inliers)
                return e, None, {}
            t0 = time.perf_counter()
            frame, track, pixel, _, rep = block_tie_points(blk["gimbal"], cam, eos, 300.0, level=1, per_region=None,
                                                           lsm=False, distortion=d, start=keep_inliers)
            dt = time.perf_counter() - t0
            inl = np.array([p["inliers"] for p in rep["pairs"]])
            per_class = pair_rows(got, cam, eos, ideal)
            dist_px = true_distances(frame, track, pixel, cam, eos, ideal)
            rows.append({"seed": seed, "variant": name, "pairs": len(inl),
                         "matches": int(sum(p["matches"] for p in rep["pairs"])), "inliers": int(inl.sum()),
                         "median_inliers_per_pair": float(np.median(inl)), "min_inliers_per_pair": int(inl.min()),
                         "right_inliers": sum(r["right"] for r in per_class.values()), "by_inliers": per_class,
                         "tracks": rep["tracks"], "rays_per_track": rep["rays_per_track"],
                         "track_pairs_right": int((dist_px < RIGHT_PX).sum()),
                         "track_pairs_wrong": int((dist_px >= RIGHT_PX).sum()), "match_s": dt})
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "triangulate_undistort_bench.json"))
    a = ap.parse_args(argv)
    rows = [r for seed in range(a.seeds) for r in run(seed)]
    head = ("seed", "variant", "pairs", "matches", "inliers", "right_inliers", "median_inliers_per_pair",
            "min_inliers_per_pair", "tracks", "track_pairs_right", "track_pairs_wrong", "match_s")
    print(" | ".join(head))
    for r in rows:
        print(" | ".join(f"{r[k]:.3g}" if isinstance(r[k], float) else str(r[k]) for k in head))
    for seed in range(a.seeds):
        b, f = (next(r for r in rows if r["seed"] == seed and r["variant"] == v) for v in ("before", "after"))
        print(f"seed {seed}: inliers after/before {f['inliers'] / b['inliers']:.3f}, right inliers after/before "
              f"{f['right_inliers'] / max(b['right_inliers'], 1):.3f}")
        for v in (b, f):
            print(f"  {v['variant']}: " + "; ".join(f"pairs with {k} inliers: {r['pairs']} pairs, {r['right']}/"
                                                     f"{r['inliers']} right" for k, r in v["by_inliers"].items()))
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps({"note": "load-dependent times (2 shared cores)", "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
