"""``benchmarks/ortho_bench.py``'s measurements: a command timed under ``/usr/bin/time`` (wall, CPU = user + system,
peak memory, the child's own ``WORK`` seconds), medians over runs, and the agreement of two outputs on one pixel
grid (128 x 128 tiles phase-correlated; module docstring of ``ortho_bench.py``)."""
from __future__ import annotations

import os
import statistics
import subprocess

import numpy as np


def timed(cmd, env=None) -> dict:
    """Run ``cmd`` under /usr/bin/time: wall seconds, peak RSS (MB), the child's WORK seconds if printed."""
    full = ["/usr/bin/time", "-f", "TIME %e %M %U %S", *cmd]
    p = subprocess.run(full, capture_output=True, text=True, env={**os.environ, **(env or {})})
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))[:200]} failed: {p.stderr.strip()[-600:]}")
    line = next(ln for ln in p.stderr.splitlines() if ln.startswith("TIME "))
    wall, rss, user, system = line.split()[1:5]
    work = next((float(ln.split()[1]) for ln in p.stdout.splitlines() if ln.startswith("WORK ")), None)
    return {"wall_s": float(wall), "cpu_s": float(user) + float(system), "peak_mb": int(rss) / 1024, "work_s": work}


def repeat(cmd, n, before=None, env=None) -> dict:
    runs = []
    for _ in range(n):
        if before:
            before()
        runs.append(timed(cmd, env))
    return summary(runs)


def summary(runs) -> dict:
    """Medians of :func:`timed`'s fields over ``runs``."""
    med = {k: statistics.median([r[k] for r in runs]) if runs[0][k] is not None else None for k in runs[0]}
    return {**{k: (round(v, 3) if v is not None else None) for k, v in med.items()}, "runs": len(runs)}


def ratio_range(ratios) -> dict:
    return {"median": round(statistics.median(ratios), 3), "min": round(min(ratios), 3),
            "max": round(max(ratios), 3)}


def tile_shifts(a_path, b_path, tile: int = 128) -> dict:
    """Local shifts (px) between two rasters on the same pixel grid (module docstring)."""
    import cv2
    import rasterio
    from rasterio.windows import from_bounds
    with rasterio.open(a_path) as a, rasterio.open(b_path) as b:
        if abs(a.transform.a - b.transform.a) > 1e-9:
            raise RuntimeError("outputs on different pixel sizes")
        l, r = max(a.bounds.left, b.bounds.left), min(a.bounds.right, b.bounds.right)
        bo, t = max(a.bounds.bottom, b.bounds.bottom), min(a.bounds.top, b.bounds.top)
        wins = [from_bounds(l, bo, r, t, d.transform).round_offsets().round_lengths() for d in (a, b)]
        h = min(w.height for w in wins)
        w_ = min(w.width for w in wins)
        wins = [w.__class__(w.col_off, w.row_off, w_, h) for w in wins]
        A, B = (d.read(1, window=w).astype(np.float32) for d, w in zip((a, b), wins))
        valid = (a.read_masks(1, window=wins[0]) > 0) & (b.read_masks(1, window=wins[1]) > 0)
    hann = cv2.createHanningWindow((tile, tile), cv2.CV_32F)
    shifts = []
    for i in range(0, h - tile + 1, tile):
        for j in range(0, w_ - tile + 1, tile):
            if valid[i:i + tile, j:j + tile].all():
                (dx, dy), _ = cv2.phaseCorrelate(A[i:i + tile, j:j + tile], B[i:i + tile, j:j + tile], hann)
                shifts.append((dx, dy))
    s = np.array(shifts)
    length = np.hypot(s[:, 0], s[:, 1])
    return {"tiles": len(s), "median_dx": round(float(np.median(s[:, 0])), 4),
            "median_dy": round(float(np.median(s[:, 1])), 4), "p95_px": round(float(np.percentile(length, 95)), 4),
            "max_px": round(float(length.max()), 4),
            "mean_abs_diff": round(float(np.abs(A - B)[valid].mean()), 3), "overlap_px": int(valid.sum())}
