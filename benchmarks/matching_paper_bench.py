"""The matching paper's experiment: NCC vs LSM over window sizes and resolutions, fed to an adjustment.

The 'Görüntü Eşleme' study (area-based matching, the Alaaddin software) matched the same tie points of a
4-photo block by normalised cross-correlation and by least-squares matching, on scans of three
resolutions with two window sizes (one 15x15), fed every set into a bundle adjustment and compared the
accuracy of the adjusted test points (its Table 2) — 12 runs. Its findings: LSM more accurate than NCC in
every run; larger windows more accurate, NCC most; higher resolution more accurate, and at high
resolution the window size hardly matters; NCC reached its expected 0.5 px and the adjustment
0.2–0.35 px, LSM its expected 0.3 px and the adjustment 0.15–0.34 px.

Here, on a real aerial photo with exact truth: NGI frame 0182 (grey, mildly low-passed, σ 0.8 px) is
the left photo; the right photo is the same under a known homography — ``strong``: rotation 5°, scale
0.93, perspective 0.05 / −0.03 over the frame (what a second exposure's κ and scale do to a window);
``mild``: 0.5°, 0.99, 0.01 / −0.01 (near-vertical photos of one strip, the paper's case) — sampled
with the Keys bicubic kernel in float64, another radiometry (gain 0.9, offset +12), Gaussian noise σ 2
grey levels in both, 8 bits. The three resolutions are the two photos 'scanned' at 1, 2 and 4 times
the pixel (block means: levels 0, 1, 2); the same tie points (Shi–Tomasi corners of the coarsest
level) are matched at every level, with 9x9, 15x15 and 25x25 windows, from approximations off by up to
±3 px (search radius 5 px):

- ``ncc-pixel`` — the correlation peak on the pixel grid (no interpolation);
- ``ncc`` — the same with the quadratic sub-pixel peak (:func:`fotogeo.matching.ncc`);
- ``lsm`` — affine + radiometric least-squares matching from the NCC pixel peak
  (:func:`fotogeo.matching.lsm_many`), as the paper does (LSM needs good approximations).

Per level x window x method: the share of points matched (a status other than ok is a failure), of
gross errors (> 1 px of that level), the RMSE of the others against the truth in x and y (px of the
level) and per axis in full-resolution px (the ground: what the paper's resolutions compare); then the
adjustment: a homography fitted to all matched points with data snooping (Baarda; blunders removed,
:func:`fotogeo.orientation.adjustment.fit_orientation`) — its residual RMS (the adjustment's own
precision, what the paper's 0.15–0.35 px are; per axis, as every RMSE here) and its check RMSE against the true homography on a
20x20 grid over the tie points (the accuracy the matches give the fitted model), in full-resolution px.

Run: ``.venv/bin/python benchmarks/matching_paper_bench.py`` (``--seed``). Prints a table and writes
``benchmarks/results/matching_paper_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from known_warps import warp_matrix  # noqa: E402
from synthetic_pair import apply_h  # noqa: E402
from fotogeo.matching import lsm_many, ncc  # noqa: E402
from fotogeo.matching.interpolation import sample  # noqa: E402
from fotogeo.orientation.adjustment import fit_orientation  # noqa: E402
from fotogeo.pixels import from_centre, pixel_centres, to_centre  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
FRAME = "ngi/frames/3324c_2015_1004_05_0182_RGB.tif"
LEVELS = (0, 1, 2)
WINDOWS = (9, 15, 25)
APPROX_PX, SEARCH_PX, GROSS_PX = 3.0, 5, 1.0
#: right px -> left px: rotation (°), scale, perspective over the frame
WARPS = {"strong": (5.0, 0.93, (0.05, -0.03)), "mild": (0.5, 0.99, (0.01, -0.01))}
METHODS = ("ncc-pixel", "ncc", "lsm")


def load_left(path: Path) -> np.ndarray:
    import rasterio
    with rasterio.open(path) as ds:
        grey = ds.read().astype(np.float64).mean(axis=0)
    return cv2.GaussianBlur(grey, (0, 0), 0.8)  # band-limited: the bicubic resampling is then exact


def right_photo(left: np.ndarray, H: np.ndarray) -> np.ndarray:
    """right(y) = left(H y) (H: right px -> left px, corner convention), Keys bicubic, float64."""
    rows, cols = left.shape
    X, Y = pixel_centres(cols, rows)
    src = to_centre(apply_h(H, np.column_stack([X.ravel(), Y.ravel()])))
    values, _ = sample(left, src[:, 0], src[:, 1], method="bicubic")
    return np.nan_to_num(values.reshape(rows, cols), nan=0.0)


def scanned(img: np.ndarray, level: int, rng, gain=1.0, offset=0.0) -> np.ndarray:
    """``img`` 'scanned' at 2^level times its pixel (block means), radiometry, noise σ 2, 8 bits."""
    f = 2 ** level
    h, w = img.shape[0] // f * f, img.shape[1] // f * f
    block = img[:h, :w].reshape(h // f, f, w // f, f).mean(axis=(1, 3))
    return np.clip(np.round(gain * block + offset + rng.normal(0, 2.0, block.shape)), 0, 255)


def tie_points(left2: np.ndarray, right_ok, margin: int) -> np.ndarray:
    """Shi–Tomasi corners of the coarsest level (corner convention, level-2 px) far from both borders."""
    mask = np.zeros(left2.shape, np.uint8)
    mask[margin:-margin, margin:-margin] = 255
    c = cv2.goodFeaturesToTrack(left2.astype(np.float32), 300, 0.02, 6, mask=mask)
    p = from_centre(c.reshape(-1, 2).astype(np.float64))
    return p[right_ok(p)]


def pixel_peak(xy: np.ndarray, ref_xy: np.ndarray) -> np.ndarray:
    """The NCC peak on the search grid (the lattice of the template's fractional position)."""
    frac = ref_xy - (np.floor(ref_xy) + 0.5)
    return np.round(xy - frac - 0.5) + 0.5 + frac


def match(left, right, p, approx, window: int) -> dict:
    """Matches ``(N, 2)`` (NaN where failed) of every method, and the time per point."""
    h = window // 2
    t0 = time.perf_counter()
    res = [ncc(left, right, a, b, half_window=h, search_radius=SEARCH_PX) for a, b in zip(p, approx)]
    t_ncc = (time.perf_counter() - t0) / len(p)
    sub = np.array([r.xy if r.ok else [np.nan, np.nan] for r in res])
    pix = np.where(np.isfinite(sub), pixel_peak(sub, p), np.nan)
    ok = np.isfinite(pix).all(axis=1)
    lsm = np.full_like(pix, np.nan)
    t0 = time.perf_counter()
    if ok.any():
        b = lsm_many(left, right, p[ok], pix[ok], half_window=h)
        lsm[np.flatnonzero(ok)[b.status == "converged"]] = b.xy[b.status == "converged"]
    t_lsm = (time.perf_counter() - t0) / max(ok.sum(), 1)
    return {"ncc-pixel": (pix, t_ncc), "ncc": (sub, t_ncc), "lsm": (lsm, t_ncc + t_lsm)}


def adjustment(p, q, truth_h, grid, f: int) -> dict:
    """A homography fitted to the matches with data snooping: residual RMS and check RMSE (full-res px)."""
    ok = np.isfinite(q).all(axis=1)
    ids = np.arange(len(p)).astype(str)
    fit = fit_orientation("projective", p[ok], q[ok], np.full(ok.sum(), "control", object), ids[ok],
                          remove_blunders=True)
    c = fit.stats["control"]
    d = fit.model.forward(grid) - apply_h(truth_h, grid)
    return {"residual_rms_px": f * c["rms_xy_px"] / np.sqrt(2), "blunders": int((fit.role == "blunder").sum()),
            "check_rmse_px": f * float(np.sqrt(np.mean(np.sum(d ** 2, axis=1)) / 2))}


def evaluate(xy, truth, f: int) -> dict:
    found = np.isfinite(xy).all(axis=1)
    e = xy[found] - truth[found]
    good = np.hypot(*e.T) <= GROSS_PX
    rx, ry = np.sqrt(np.mean(e[good] ** 2, axis=0)) if good.any() else (np.nan, np.nan)
    return {"matched": float(found.mean()), "gross": float((~good).mean()) if len(e) else 0.0,
            "rmse_x_px": float(rx), "rmse_y_px": float(ry),
            "rmse_full_res_px": float(f * np.sqrt(np.mean(e[good] ** 2))) if good.any() else None}


def run(seed: int, warp: str) -> tuple[list, int]:
    rng = np.random.default_rng(seed)
    left0 = load_left(DATA / FRAME)
    size = left0.shape[1]
    H = warp_matrix(*WARPS[warp], size, (left0.shape[1] / 2, left0.shape[0] / 2))  # right px -> left px
    Hi = np.linalg.inv(H)
    right0 = right_photo(left0, H)
    lefts = {k: scanned(left0, k, rng) for k in LEVELS}
    rights = {k: scanned(right0, k, rng, 0.9, 12.0) for k in LEVELS}
    f2 = 2 ** max(LEVELS)
    margin = max(WINDOWS) // 2 + SEARCH_PX + int(APPROX_PX) + 4

    def inside_right(p2):
        q = apply_h(Hi, p2 * f2) / f2
        shape = rights[max(LEVELS)].shape
        return ((q >= margin) & (q <= np.array(shape[::-1]) - margin)).all(axis=1)

    p2 = tie_points(lefts[max(LEVELS)], inside_right, margin)
    offsets = rng.uniform(-APPROX_PX, APPROX_PX, p2.shape)
    rows = []
    for k in LEVELS:
        f = 2 ** k
        S = np.diag([f, f, 1.0])
        Hk = np.linalg.inv(S) @ Hi @ S  # left level-k px -> right level-k px
        p = p2 * (f2 / f)
        truth = apply_h(Hk, p)
        lo, hi = p.min(axis=0), p.max(axis=0)
        gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], 20), np.linspace(lo[1], hi[1], 20))
        grid = np.column_stack([gx.ravel(), gy.ravel()])
        for w in WINDOWS:
            out = match(lefts[k], rights[k], p, truth + offsets, w)
            for m in METHODS:
                xy, t = out[m]
                rows.append({"warp": warp, "level": k, "pixel_factor": f, "window": w, "method": m, "points": len(p),
                             **evaluate(xy, truth, f), "adjustment": adjustment(p, xy, Hk, grid, f),
                             "ms_per_point": 1000 * t})
    return rows, len(p2)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "matching_paper_bench.json")
    a = ap.parse_args(argv)
    if not (DATA / FRAME).exists():
        raise SystemExit(f"needs the NGI frame {DATA / FRAME}")
    rows, n = [], {}
    for warp in WARPS:
        r, n[warp] = run(a.seed, warp)
        rows += r
    print(f"tie points {n}, the same at every resolution; RMSE without the gross errors (> {GROSS_PX:g} px)")
    print("| warp | pixel | window | method | matched | gross | RMSE x / y (level px) | RMSE (full-res px) | "
          "adjustment residual RMS (full-res px) | blunders | check RMSE (full-res px) | ms/point |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        ad = r["adjustment"]
        print(f"| {r['warp']} | {r['pixel_factor']}x | {r['window']}x{r['window']} | {r['method']} | {100 * r['matched']:.0f} % | "
              f"{100 * r['gross']:.0f} % | {r['rmse_x_px']:.3f} / {r['rmse_y_px']:.3f} | {r['rmse_full_res_px']:.3f} | "
              f"{ad['residual_rms_px']:.3f} | {ad['blunders']} | {ad['check_rmse_px']:.3f} | {r['ms_per_point']:.2f} |")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps({"benchmark": "matching_paper_bench", "seed": a.seed, "frame": FRAME,
                                 "warps": {k: {"rotation_deg": w[0], "scale": w[1], "perspective": w[2]}
                                           for k, w in WARPS.items()},
                                 "tie_points": n, "rows": rows}, indent=1))
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
