"""Tie points of a rendered synthetic block, before and after the pyramid / Gruber / LSM steps (issue 13).

A block of rendered frames (:func:`fotogeo.orientation.block_render.render_block`: texture on the
terrain, every frame through its true camera) is matched by
:func:`fotogeo.tools.triangulate.match.block_tie_points` in several configurations and adjusted
with the block's simulated control (:func:`fotogeo.orientation.bundle.adjust_block`):

* ``before`` — the first version: SURF on the full-resolution frames, every epipolar inlier, no
  thinning, no LSM, one a priori σ for all observations;
* ``pyramid`` — detection on pyramid level 1, thinned to Gruber positions (3 x 3 regions, 25 each), no LSM;
* ``after`` — the same, followed down by least-squares matching at full resolution, each
  observation with its LSM σ;
* ``full+lsm`` — level-0 detection, thinned, LSM.

Printed and written to ``benchmarks/results/triangulate_ties_bench.json``: tracks, observations,
σ₀, image RMS (px), check RMSE in plan and height (m and GSD), wall time of matching and adjustment.

``--bands mixed`` writes the frames in other band sets (issue 32): three textures rendered through the same
cameras make R, G, B (each mostly the first texture), and the frames cycle through RGB, a NIR-like band alone,
panchromatic and 4 bands in the order NIR, B, G, R (:func:`known_warps.derived_bands`), so that pairs of frames
match across band sets. ``--variants`` picks the configurations.

    .venv/bin/python benchmarks/triangulate_ties_bench.py [--quick] [--bands mixed] [--variants after]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block
from fotogeo.tools.triangulate.match import block_tie_points

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from known_warps import derived_bands  # noqa: E402
from rendered_block_ties import with_ties, write_frames  # noqa: E402

VARIANTS = {
    "before": dict(level=0, per_region=None, lsm=False),
    "pyramid": dict(level=1, per_region=25, lsm=False),
    "after": dict(level=1, per_region=25, lsm=True),
    "full+lsm": dict(level=0, per_region=25, lsm=True),
}


#: the band sets the frames of ``--bands mixed`` cycle through (:func:`mixed_band_frames`)
MIXED = ("rgb", "n", "pan", "nbgr")


def mixed_band_frames(sb, seed: int) -> list:
    """One ``(bands, rows, cols)`` uint8 array per frame of ``sb`` in the band sets :data:`MIXED` (module docstring):
    three rendered textures T0, T1, T2 make R = 0.7 T0 + 0.3 T1, G = 0.7 T0 + 0.3 T2, B = 0.6 T0 + 0.4 T1."""
    t = [np.asarray(render_block(sb, seed=seed + 1000 * k)[0], np.float64) for k in range(3)]
    out = []
    for f in range(len(t[0])):
        rgb = np.stack([0.7 * t[0][f] + 0.3 * t[1][f], 0.7 * t[0][f] + 0.3 * t[2][f], 0.6 * t[0][f] + 0.4 * t[1][f]])
        kind = MIXED[f % len(MIXED)]
        bands = derived_bands(rgb, "rgbn")[[3, 2, 1, 0]] if kind == "nbgr" else derived_bands(rgb, kind)
        out.append(np.clip(np.rint(bands), 0, 255).astype(np.uint8))
    return out


def run_variant(sb, paths, name, kw, a_priori):
    b = sb.block
    height = float(np.nanmean(b.point_xyz[:, 2]))
    t0 = time.perf_counter()
    frame, track, pixel, sigma, rep = block_tie_points(paths, b.camera, b.eo, height, **kw)
    t1 = time.perf_counter()
    res = adjust_block(with_ties(sb, frame, track, pixel, sigma, a_priori), BundleOptions())
    t2 = time.perf_counter()
    st, gsd = res.stats, sb.gsd
    chk = st["check"]
    return {"variant": name, **kw, "tracks": rep["tracks"], "observations": int(len(frame)),
            "median_sigma_px": float(np.median(sigma)) if sigma is not None else a_priori,
            "lsm": rep.get("lsm"), "sigma0": res.sigma0, "image_rms_px": st.get("image_rms_px"),
            "check_n": chk["n"], "check_plan_m": chk["rmse_planimetric_m"], "check_z_m": chk["rmse_z_m"],
            "check_plan_gsd": chk["rmse_planimetric_m"] / gsd, "check_z_gsd": chk["rmse_z_m"] / gsd,
            "blunders": st["n_blunders"], "match_s": t1 - t0, "adjust_s": t2 - t1}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one seed, 400x600 frames")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--bands", choices=("grey", "mixed"), default="grey", help="frames' bands (module docstring)")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="comma-separated subset of " + ",".join(VARIANTS))
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "triangulate_ties_bench.json"))
    a = ap.parse_args(argv)
    size = (400, 600) if a.quick else (800, 1200)
    cam = FrameCamera(6.0, (4.0, 6.0), size)  # the same footprints; 800x1200: half the GSD
    rows = []
    for seed in range(1 if a.quick else a.seeds):
        sb = simulate_block(seed=seed + 1, strips=2, frames_per_strip=4, camera=cam, point_spacing=80.0,
                            blunder_fraction=0.0, margin=5.0)
        images = render_block(sb, seed=seed)[0] if a.bands == "grey" else mixed_band_frames(sb, seed)
        with tempfile.TemporaryDirectory() as tmp:
            paths = write_frames(Path(tmp), sb, images)
            for name in a.variants.split(","):
                r = run_variant(sb, paths, name, VARIANTS[name], 0.3)
                r["seed"], r["frame_size"], r["bands"] = seed + 1, list(size), a.bands
                rows.append(r)
                print(f"seed {seed + 1} {name:9s} tracks {r['tracks']:5d} obs {r['observations']:6d} "
                      f"σ0 {r['sigma0']:.3f} image RMS {r['image_rms_px']:.3f} px  check {r['check_n']:2d}: "
                      f"plan {r['check_plan_gsd']:.3f} GSD, Z {r['check_z_gsd']:.3f} GSD  "
                      f"(match {r['match_s']:.1f} s, adjust {r['adjust_s']:.1f} s)", flush=True)
    Path(a.out).write_text(json.dumps({"note": "load-dependent times (2 shared cores)", "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
