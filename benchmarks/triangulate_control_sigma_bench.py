"""What the automatic control's σ model does to the NGI pair started from the reference (issue 20).

``fotogeo triangulate ngi/frames/*.tif --camera ... --reference ngi/ortho/*.tif --dem ngi/dem.tif`` (no
orientation given: every frame registered to the orthophotos, :mod:`fotogeo.tools.triangulate.register`),
adjusted with several σ models of the automatic control, each against the professional triangulation
(``ngi/exterior_orientation.txt``, never given to the tool): projection-centre error (m), largest angle
error (°), and the dense-grid ground RMSE (every 10th frame pixel put on its true height through the
adjusted orientation, plan RMSE in m against the true ground point; ``tests/ngi_triangulation.py``).

Models (``--reference-sigma-xy/-z`` unless stated):

* ``default``: the input-derived ``σ_XY = ½ p_ref``, ``σ_Z = max(½ p_DEM, σ_XY)`` (2.5 m / 12 m);
* ``0.5/1``, ``2.5/5``, ``2.5/24``, ``5/12``: fixed values; ``default, no check points``: ``--check-fraction 0``;
* ``per-point σ_Z``: ``σ_Z² = (Δ²/8·(|h_xx| + |h_yy|))² + (|∇h|·σ_XY)²`` per control point — the bilinear
  interpolation error of a DEM of spacing Δ from its curvature (second differences at Δ) plus the slope
  times the plan σ (the tool's Block wrapped, only here);
* ``control image σ 0.3 px``: the control's image measurements at the 0.3 px their residuals have under the
  published orientation, instead of ``--image-sigma`` 1 px (the tool's Block wrapped, only here).

Prints a table and writes ``benchmarks/results/triangulate_control_sigma_bench.json``.

    .venv/bin/python benchmarks/triangulate_control_sigma_bench.py
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from ngi_triangulation import NAMES, dense_grid, ground_rmse, orientation_errors  # noqa: E402

MODELS = (("default", {}, None), ("0.5/1", {"reference_sigma_xy": 0.5, "reference_sigma_z": 1.0}, None),
          ("2.5/5", {"reference_sigma_xy": 2.5, "reference_sigma_z": 5.0}, None),
          ("2.5/24", {"reference_sigma_xy": 2.5, "reference_sigma_z": 24.0}, None),
          ("5/12", {"reference_sigma_xy": 5.0, "reference_sigma_z": 12.0}, None),
          ("default, no check points", {"check_fraction": 0.0}, None),
          ("per-point σ_Z", {}, "curvature"), ("control image σ 0.3 px", {}, "image"))


def _wrapped_block(kind, dem_path):
    """The tool's Block constructor with the automatic control's σ changed as ``kind`` says (module docstring)."""
    from fotogeo.crs import pixel_size_in
    from fotogeo.geometry.dem import DemSampler
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.bundle import Block
    dem = read_dem(dem_path)
    rows, cols = dem.data.shape
    step = pixel_size_in(dem.transform, dem.crs, dem.crs, cols / 2, rows / 2)
    sampler = DemSampler(dem, dem.crs)

    def block(camera, names, eos, f_obs, p_obs, px, ids, xyz, sig, role, s_obs, **kw):
        auto = np.array([str(i).startswith("auto") for i in ids]) & (role == "control")
        sig, s_obs = sig.copy(), np.asarray(s_obs, dtype=float).copy()
        if kind == "curvature":
            XY = xyz[auto, :2]
            h, gx, gy = sampler.heights_and_gradient(XY)
            curv = sum(np.abs(sampler.heights(XY + d) - 2 * h + sampler.heights(XY - d))
                       for d in ([step, 0], [0, step]))
            sig[auto, 2] = np.hypot(curv / 8.0, np.hypot(gx, gy) * sig[auto, 0])
        else:
            s_obs[np.isin(p_obs, np.flatnonzero(auto))] = 0.3
        return Block(camera, names, eos, f_obs, p_obs, px, ids, xyz, sig, role, s_obs, **kw)
    return block


def run_model(ngi, label, kw, wrap) -> dict:
    import fotogeo.tools.triangulate.tool as tool_module
    from fotogeo.geometry.camera import OrientedFrame
    from fotogeo.io.camera import load_camera, read_exterior_orientation
    from fotogeo.io.raster import read_dem
    true = read_exterior_orientation(ngi / "exterior_orientation.txt")
    cam, dem = load_camera(ngi / "interior_orientation.yaml"), read_dem(ngi / "dem.tif")
    original = tool_module.Block
    if wrap:
        tool_module.Block = _wrapped_block(wrap, ngi / "dem.tif")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            frames = [ngi / "frames" / f"{n}.tif" for n in NAMES]
            rep = tool_module.triangulate(frames, ngi / "interior_orientation.yaml", None, None, Path(tmp) / "out",
                                          reference=sorted((ngi / "ortho").glob("*.tif")), dem=ngi / "dem.tif", **kw)
            seconds = time.perf_counter() - t0
            got = read_exterior_orientation(Path(tmp) / "out" / "exterior_orientation.txt")
    finally:
        tool_module.Block = original
    frames = {}
    for n in NAMES:
        e = orientation_errors(got[n], true[n])
        px, truth = dense_grid(cam, true[n], dem)
        fr = OrientedFrame(cam, got[n])
        frames[n] = {"position_m": e["position_m"], "dX_m": e["dX_m"], "angle_deg": e["angle_deg"], "dphi": e["dphi"],
                     "dense_rmse_m": ground_rmse(lambda p, z, fr=fr: fr.pixel_to_world_at(p, z)[:, :2], px, truth)}
    return {"model": label, "sigma0": rep["statistics"]["sigma0"], "seconds": seconds,
            "control_sigma_m": rep["automatic_control_sigma_m"], "frames": frames}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "ngi"))
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "triangulate_control_sigma_bench.json"))
    a = ap.parse_args(argv)
    ngi = Path(a.data)
    rows = [run_model(ngi, label, kw, wrap) for label, kw, wrap in MODELS]
    print(f"{'model':>26} {'σ0':>6} " + " ".join(f"{n[-8:-4]:>32}" for n in NAMES))
    for r in rows:
        cells = [f"{f['position_m']:6.2f} m {f['angle_deg']:.3f}° ground {f['dense_rmse_m']:.2f} m"
                 for f in r["frames"].values()]
        print(f"{r['model']:>26} {r['sigma0']:6.3f} " + " ".join(f"{c:>32}" for c in cells))
    Path(a.out).write_text(json.dumps({"note": "times load-dependent (2 shared cores)", "rows": rows}, indent=1,
                                      default=float))


if __name__ == "__main__":
    main()
