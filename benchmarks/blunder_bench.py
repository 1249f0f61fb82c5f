"""Blunder detection at click noise: false alarms on clean GCPs, detection of one planted blunder.

    PYTHONPATH=. .venv/bin/python benchmarks/blunder_bench.py [--trials 200] [--noise 0.8] [--seed 1000]
                                                              [--models dlt,...] [--cells 15:5,8:0]

Ground control points over relief (the 640 x 1152 px frame of the tests, 120 mm lens at 5000 m over
250 m hills), pixels from each model's own truth (the pinhole frame for ``dlt``; for ``affine-height``
and ``projective`` that model fitted noise-free to 200 pinhole points) plus Gaussian click noise of
``--noise`` px per axis. Cells: 8 clean GCPs (false alarms), and 12 / 15 / 20 GCPs with one GCP moved
3 / 5 / 10 px in a random direction. Each GCP set is tested by :func:`fotogeo.orientation.blunders.
detect_blunders` with the image σ given (``--noise``) and estimated; and, for comparison, by the
single-pass Pope τ test (:func:`fotogeo.orientation.adjustment.standardised_residuals`, α = 0.1 %) that
``orient`` used before. Per cell: the rate of fits flagging anything (clean sets: false alarms), the
blunder flagged, the blunder flagged alone. Prints a table and writes ``benchmarks/results/blunder_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame  # noqa: E402
from fotogeo.geometry.dem import Dem  # noqa: E402
from fotogeo.models import get_model  # noqa: E402
from fotogeo.orientation.adjustment import critical_w, standardised_residuals  # noqa: E402
from fotogeo.orientation.blunders import detect_blunders  # noqa: E402
from fotogeo.orientation.simulation import make_gcps  # noqa: E402

CAM = FrameCamera(120.0, (92.16, 165.888), (640, 1152))
FRAME = OrientedFrame(CAM, ExteriorOrientation(500.0, -300.0, 5000.0, 1.5, -2.0, -179.0))
MODELS = ("dlt", "affine-height", "projective")
CELLS = [(8, 0.0)] + [(n, b) for n in (12, 15, 20) for b in (3.0, 5.0, 10.0)]


def relief_dem():
    from affine import Affine

    from fotogeo.pixels import pixel_centres
    t = Affine(25.0, 0.0, -5000.0, 0.0, -25.0, 5000.0)
    x, y = pixel_centres(400, 400)
    X, Y = t.a * x + t.c, t.e * y + t.f
    return Dem(300 + 250 * np.sin(X / 900.0) * np.cos(Y / 700.0) + 0.02 * X, t)


def truths(dem):
    """Per model, ``truth(ground) -> pixel``."""
    g = make_gcps(FRAME, dem, 200, 0, noise=0.0, seed=99)
    out = {"dlt": lambda xyz: FRAME.world_to_pixel(xyz)}
    for name in ("affine-height", "projective"):
        cls = get_model(name)
        src = g.gcp_ground if cls.src_dims == 3 else g.gcp_ground[:, :2]
        m = cls.estimate(src, g.gcp_pixel_true)
        out[name] = (lambda m, d: lambda xyz: m.forward(xyz if d == 3 else xyz[:, :2]))(m, cls.src_dims)
    return out


def pool(dem, size: int = 4000):
    """Exact ground points of pixels spread over the frame (rays intersected with the DEM once)."""
    g = make_gcps(FRAME, dem, size, 0, noise=0.0, seed=99)
    return g.gcp_ground, g.gcp_pixel_true


def one_set(points, truth, n, blunder, noise, rng):
    """``n`` GCPs stratified over the frame (one per cell of a near-square grid of ``n`` cells or a few
    more), pixels from ``truth`` plus click noise, one moved ``blunder`` px; returns (ground, pixels, k)."""
    ground, px = points
    w, h = CAM.image_size
    cols = max(1, round(np.sqrt(n * w / h)))
    rows = int(np.ceil(n / cols))
    cell = np.minimum((px[:, 1] / h * rows).astype(int), rows - 1) * cols + np.minimum(
        (px[:, 0] / w * cols).astype(int), cols - 1)
    chosen = rng.choice(rows * cols, n, replace=False)
    pick = np.array([rng.choice(np.flatnonzero(cell == c)) for c in chosen])
    xyz = ground[pick]
    pix = truth(xyz) + rng.normal(0, noise, (n, 2))
    k = int(rng.integers(n))
    if blunder:
        a = rng.uniform(0, 2 * np.pi)
        pix[k] += blunder * np.array([np.cos(a), np.sin(a)])
    return xyz, pix, k


def flagged(test):
    """Points flagged as a blunder or a suspect."""
    return np.isin(test.flag, ("blunder", "suspect"))


def pope(cls, src, pix):
    """The previous test: flags where Pope's τ exceeds its α = 0.1 % quantile (one pass, σ0 from the fit)."""
    n = len(src)
    crit = critical_w(2 * n - cls.n_params)
    if crit is None:
        return np.zeros(n, bool)
    _, w = standardised_residuals(cls, src, pix, np.ones(n, bool))
    return np.nan_to_num(w) > crit


def run_cell(points, truth, name, n, blunder, noise, trials, rng):
    cls = get_model(name)
    methods = {"sigma given": lambda s, p: flagged(detect_blunders(cls, s, p, sigma=noise)),
               "sigma estimated": lambda s, p: flagged(detect_blunders(cls, s, p)),
               "Pope tau (before)": lambda s, p: pope(cls, s, p)}
    counts = {m: {"any": 0, "blunder": 0, "alone": 0} for m in methods}
    for _ in range(trials):
        ground, pix, k = one_set(points, truth, n, blunder, noise, rng)
        src = ground if cls.src_dims == 3 else ground[:, :2]
        for m, test in methods.items():
            hit = test(src, pix)
            counts[m]["any"] += bool(hit.any())
            if blunder:
                counts[m]["blunder"] += bool(hit[k])
                counts[m]["alone"] += bool(hit[k] and hit.sum() == 1)
    return {m: {k: v / trials for k, v in c.items()} for m, c in counts.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--noise", type=float, default=0.8)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--cells", default=None, help="GCPs:blunder px pairs, e.g. 15:5,8:0 [all]")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "blunder_bench.json")
    a = ap.parse_args()
    dem = relief_dem()
    truth, points = truths(dem), pool(dem)
    rng = np.random.default_rng(a.seed)
    rows, t0 = [], time.perf_counter()
    print(f"{a.trials} trials per cell, click noise {a.noise} px per axis; rates: any point flagged / "
          f"the blunder flagged / the blunder flagged alone")
    print(f"{'model':14s} {'GCPs':>4s} {'blunder':>7s}  {'σ given':>17s}  {'σ estimated':>17s}  {'Pope τ (before)':>17s}")
    for name in a.models.split(","):
        cells = [(int(c.split(":")[0]), float(c.split(":")[1])) for c in a.cells.split(",")] if a.cells else CELLS
        for n, b in cells:
            res = run_cell(points, truth[name], name, n, b, a.noise, a.trials, rng)
            rows.append({"model": name, "gcps": n, "blunder_px": b, **res})
            cols = ["   {any:5.3f}           ".format(**r) if not b else "{any:5.3f} {blunder:5.3f} {alone:5.3f}".format(**r)
                    for r in res.values()]
            print(f"{name:14s} {n:4d} {b:7.1f}  " + "  ".join(cols), flush=True)
            a.out.parent.mkdir(parents=True, exist_ok=True)  # after every cell: a long run's rows are kept
            a.out.write_text(json.dumps({"trials": a.trials, "noise_px": a.noise, "seed": a.seed,
                                         "time_s": time.perf_counter() - t0, "rows": rows}, indent=1))
    print(f"wrote {a.out} ({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
