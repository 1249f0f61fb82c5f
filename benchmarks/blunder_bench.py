"""Blunder detection at click noise: false alarms on clean GCPs, detection of one planted blunder.

    PYTHONPATH=. .venv/bin/python benchmarks/blunder_bench.py [--trials 200] [--noise 0.8] [--seed 1000]
        [--models dlt,...] [--cells 15:5,8:0] [--scene synthetic|ngi:0182|ngi:0184] [--sigma-given 1.0]
        [--alpha 0.01] [--out FILE]

Ground control points over relief, pixels from each model's own truth (the pinhole frame for ``dlt``; for
``affine-height`` and ``projective`` that model fitted noise-free to 200 pinhole points) plus Gaussian click
noise of ``--noise`` px per axis. Scenes: ``synthetic``, the 640 x 1152 px frame of the tests (120 mm lens at
5000 m over 250 m hills); ``ngi:0182`` / ``ngi:0184``, the true geometry of an NGI frame over its DEM
(``../shared/data/ngi``, several hundred metres of relief). Cells: 8 and 15 clean GCPs (false alarms), and
12 / 15 / 20 GCPs with one GCP moved 3 / 5 / 10 px in a random direction. Each GCP set is tested by
:func:`fotogeo.orientation.blunders.detect_blunders` with the image σ given as the true noise, given as
``--sigma-given`` (a click σ guessed too large), and estimated; and, for comparison, by the single-pass Pope τ
test (:func:`fotogeo.orientation.adjustment.standardised_residuals`, α = 0.1 %) that ``orient`` used before.
Per cell: the rate of fits flagging anything (clean sets: false alarms), the blunder flagged, the blunder
flagged alone; ``power``, the mean over the sets of the point test's power for the planted blunder at its
point (non-central χ²(2), σ true, from the noise-free geometry) — what no test at this α can beat; and for σ
true, ``mdb_ok`` the share of sets whose blunder is at least the point's minimal detectable blunder and
``alone_mdb_ok`` the rate flagged alone among those. Prints a table and writes the JSON (``--out``).
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
CELLS = [(8, 0.0), (15, 0.0)] + [(n, b) for n in (12, 15, 20) for b in (3.0, 5.0, 10.0)]
DATA = ROOT.parent / "shared" / "data"


class Scene:
    """A frame over a DEM: ``size`` (w, h), the oriented ``frame`` and the ``dem``."""

    def __init__(self, name: str):
        if name == "synthetic":
            self.frame, self.dem = FRAME, relief_dem()
        elif name.startswith("ngi:"):
            from fotogeo.io.camera import load_ngi_frame
            from fotogeo.io.raster import read_dem
            if not (DATA / "ngi").is_dir():
                raise SystemExit(f"{DATA / 'ngi'} is missing: the NGI scenes need ../shared/data")
            self.frame = load_ngi_frame(DATA / "ngi", f"3324c_2015_1004_05_{name[4:]}")
            self.dem = read_dem(DATA / "ngi" / "dem.tif")
        else:
            raise SystemExit(f"--scene must be synthetic or ngi:FRAME (0182, 0184); got {name!r}")
        self.size = self.frame.camera.image_size


def relief_dem():
    from affine import Affine

    from fotogeo.pixels import pixel_centres
    t = Affine(25.0, 0.0, -5000.0, 0.0, -25.0, 5000.0)
    x, y = pixel_centres(400, 400)
    X, Y = t.a * x + t.c, t.e * y + t.f
    return Dem(300 + 250 * np.sin(X / 900.0) * np.cos(Y / 700.0) + 0.02 * X, t)


def truths(dem, frame=FRAME):
    """Per model, ``truth(ground) -> pixel``."""
    g = make_gcps(frame, dem, 200, 0, noise=0.0, seed=99)
    out = {"dlt": lambda xyz: frame.world_to_pixel(xyz)}
    for name in ("affine-height", "projective"):
        cls = get_model(name)
        src = g.gcp_ground if cls.src_dims == 3 else g.gcp_ground[:, :2]
        m = cls.estimate(src, g.gcp_pixel_true)
        out[name] = (lambda m, d: lambda xyz: m.forward(xyz if d == 3 else xyz[:, :2]))(m, cls.src_dims)
    return out


def pool(dem, size: int = 4000, frame=FRAME):
    """Exact ground points of pixels spread over the frame (rays intersected with the DEM once)."""
    g = make_gcps(frame, dem, size, 0, noise=0.0, seed=99)
    return g.gcp_ground, g.gcp_pixel_true


def one_set(points, truth, n, blunder, noise, rng, size=None, with_step=False):
    """``n`` GCPs stratified over the frame (one per cell of a near-square grid of ``n`` cells or a few
    more; ``size`` (w, h), the test frame's by default), pixels from ``truth`` plus click noise, one moved
    ``blunder`` px; returns (ground, pixels, k) and with ``with_step`` the blunder's (2,) step too."""
    ground, px = points
    w, h = size or CAM.image_size
    cols = max(1, round(np.sqrt(n * w / h)))
    rows = int(np.ceil(n / cols))
    cell = np.minimum((px[:, 1] / h * rows).astype(int), rows - 1) * cols + np.minimum(
        (px[:, 0] / w * cols).astype(int), cols - 1)
    chosen = rng.choice(rows * cols, n, replace=False)
    pick = np.array([rng.choice(np.flatnonzero(cell == c)) for c in chosen])
    xyz = ground[pick]
    pix = truth(xyz) + rng.normal(0, noise, (n, 2))
    k = int(rng.integers(n))
    step = np.zeros(2)
    if blunder:
        a = rng.uniform(0, 2 * np.pi)
        step = blunder * np.array([np.cos(a), np.sin(a)])
        pix[k] += step
    return (xyz, pix, k, step) if with_step else (xyz, pix, k)


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


def expected_power(cls, src, truth_pix, k, step, noise, alpha):
    """The point test's power for blunder ``step`` (2,) at point ``k`` (module docstring)."""
    from scipy.stats import chi2, ncx2

    from fotogeo.orientation.blunders import _Fit
    R = _Fit(cls, src, truth_pix, np.ones(len(src), bool), None, {}).R[k]
    return float(ncx2.sf(chi2.isf(alpha / len(src), 2), 2, step @ R @ step / noise ** 2))


def run_cell(points, truth, name, n, blunder, noise, trials, rng, sigma_given=1.0, alpha=0.01, size=None):
    cls = get_model(name)
    methods = {"sigma true": lambda s, p: detect_blunders(cls, s, p, sigma=noise, alpha=alpha),
               f"sigma {sigma_given:g} given": lambda s, p: detect_blunders(cls, s, p, sigma=sigma_given, alpha=alpha),
               "sigma estimated": lambda s, p: detect_blunders(cls, s, p, alpha=alpha),
               "Pope tau (before)": lambda s, p: pope(cls, s, p)}
    counts = {m: {"any": 0, "blunder": 0, "alone": 0} for m in methods}
    power = mdb_ok = alone_mdb_ok = 0.0
    for _ in range(trials):
        ground, pix, k, step = one_set(points, truth, n, blunder, noise, rng, size, with_step=True)
        src = ground if cls.src_dims == 3 else ground[:, :2]
        for m, test in methods.items():
            result = test(src, pix)
            hit = result if m.startswith("Pope") else flagged(result)
            counts[m]["any"] += bool(hit.any())
            if blunder:
                counts[m]["blunder"] += bool(hit[k])
                counts[m]["alone"] += bool(hit[k] and hit.sum() == 1)
            if blunder and m == "sigma true":
                ok = bool(np.nan_to_num(result.mdb[k], nan=np.inf) <= blunder)
                mdb_ok += ok
                alone_mdb_ok += ok and bool(hit[k] and hit.sum() == 1)
        if blunder:
            power += expected_power(cls, src, truth(ground), k, step, noise, alpha)
    out = {m: {k: v / trials for k, v in c.items()} for m, c in counts.items()}
    if blunder:
        out["power"] = power / trials
        out["mdb_ok"] = mdb_ok / trials
        out["alone_mdb_ok"] = alone_mdb_ok / mdb_ok if mdb_ok else None
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--noise", type=float, default=0.8)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--cells", default=None, help="GCPs:blunder px pairs, e.g. 15:5,8:0 [all]")
    ap.add_argument("--scene", default="synthetic", help="synthetic, ngi:0182 or ngi:0184")
    ap.add_argument("--sigma-given", type=float, default=1.0, help="the click σ given while the noise is --noise")
    ap.add_argument("--alpha", type=float, default=0.01, help="false alarms per fit of detect_blunders")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "blunder_bench.json")
    a = ap.parse_args()
    scene = Scene(a.scene)
    truth, points = truths(scene.dem, scene.frame), pool(scene.dem, frame=scene.frame)
    rng = np.random.default_rng(a.seed)
    rows, t0 = [], time.perf_counter()
    print(f"{a.scene}: {a.trials} trials per cell, click noise {a.noise} px per axis, α {a.alpha:g} per fit; rates: "
          f"any point flagged / the blunder flagged / the blunder flagged alone; power: the point test's mean power "
          f"(σ true); mdb≤b: sets whose blunder is at least its point's MDB, and the rate flagged alone among them")
    heads = ["σ true", f"σ {a.sigma_given:g} given", "σ estimated", "Pope τ (before)"]
    print(f"{'model':14s} {'GCPs':>4s} {'blunder':>7s}  " + "  ".join(f"{h:>17s}" for h in heads)
          + f"  {'power':>5s} {'mdb≤b':>11s}")
    for name in a.models.split(","):
        cells = [(int(c.split(":")[0]), float(c.split(":")[1])) for c in a.cells.split(",")] if a.cells else CELLS
        for n, b in cells:
            res = run_cell(points, truth[name], name, n, b, a.noise, a.trials, rng, a.sigma_given, a.alpha,
                           scene.size)
            rows.append({"model": name, "gcps": n, "blunder_px": b, **res})
            cols = ["   {any:5.3f}           ".format(**r) if not b else "{any:5.3f} {blunder:5.3f} {alone:5.3f}".format(**r)
                    for r in res.values() if isinstance(r, dict)]
            extra = "" if not b else f"  {res['power']:5.3f} {res['mdb_ok']:5.3f} " + (
                "  -  " if res["alone_mdb_ok"] is None else f"{res['alone_mdb_ok']:5.3f}")
            print(f"{name:14s} {n:4d} {b:7.1f}  " + "  ".join(cols) + extra, flush=True)
            a.out.parent.mkdir(parents=True, exist_ok=True)  # after every cell: a long run's rows are kept
            a.out.write_text(json.dumps({"scene": a.scene, "trials": a.trials, "noise_px": a.noise, "seed": a.seed,
                                         "sigma_given_px": a.sigma_given, "alpha": a.alpha,
                                         "command": " ".join(["python", "benchmarks/blunder_bench.py", *sys.argv[1:]]),
                                         "time_s": time.perf_counter() - t0, "rows": rows}, indent=1))
    print(f"wrote {a.out} ({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
