"""Converging oblique frames (a camera looking east, south, west and north at one place) triangulated from their own
files, with and without guided matching on the ground plane (:mod:`fotogeo.tools.triangulate.guided`).

Cases: the rendered four-frame sets of ``tests/rendered_converging.py`` — two ground textures (``fractal``: the
block renderer's; ``ngi``: a real orthophoto), 30° and 45° off nadir (DJI gimbal pitch −60° and −45°), the files at
full size and resized after capture (EXIF ``PixelXDimension`` and ``DewarpData`` still at full size). Per case and
method (``plain``: guided matching off; ``guided``: the default):

* per pair: descriptor matches, epipolar inliers, and how many of those are right (the true transfer through the
  true orientations and DEM within 3 px of full-size pixels);
* ``fotogeo.triangulate`` from the files alone (GPS with an RTK σ of 2 cm, gimbal angles with 3° of noise):
  exit or refusal, then per frame the centre error (m) and the angle error (°) against the truth — the worst of
  the four.

Printed as a table and written to ``benchmarks/results/oblique_bench.json`` (``--held-out``:
``oblique_bench_held_out.json``).

    PYTHONPATH=. .venv/bin/python benchmarks/oblique_bench.py [--quick | --held-out]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from rendered_converging import DEWARP, converging_block  # noqa: E402
from rendered_oblique import angle_error  # noqa: E402

import fotogeo.tools.triangulate.guided as guided_module  # noqa: E402
from fotogeo.errors import FotogeoError  # noqa: E402
from fotogeo.geometry.camera import FrameCamera, OrientedFrame  # noqa: E402
from fotogeo.io.camera import read_exterior_orientation  # noqa: E402
from fotogeo.orientation import bundle_jacobian as bj  # noqa: E402
from fotogeo.tools.triangulate.sources import block_start  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def true_transfer(cam, truth, dem, xy_i, eo_i, eo_j):
    """Frame pixels of ``xy_i`` carried into frame j through the true orientations and the DEM."""
    k1, k2, p1, p2, k3 = DEWARP
    interior = np.array([cam.focal_length, *cam.principal_point, k1, k2, k3, p1, p2])
    scale = bj.pixel_scale(cam)
    rays = bj.undistort_rays(np.asarray(xy_i, float).reshape(-1, 2), interior, scale)
    ideal = np.column_stack([cam.principal_point[0] + cam.fx * rays[:, 0], cam.principal_point[1] + cam.fy * rays[:, 1]])
    pin = FrameCamera(cam.focal_length, cam.sensor_size, cam.image_size, cam.principal_point)
    P = OrientedFrame(pin, eo_i).pixel_to_world(ideal, dem)
    return bj.project_camera(OrientedFrame(pin, eo_j).world_to_camera(P), interior, scale)


def pair_rows(frames, block, scale: float):
    """Per method (``plain``: no ground-plane matching; ``guided``: the default; ``guided-below-50``: only the pairs
    with fewer than 50 plain inliers) and pair ``{pair, inliers, right}``: the epipolar inliers kept and how many of
    them are right."""
    from fotogeo.io.raster import open_raster
    from fotogeo.options import RegisterOptions
    from fotogeo.progress import as_progress
    from fotogeo.tools.triangulate.match import _pair_matches
    from fotogeo.tools.triangulate.start import provisional_height
    st = block_start(frames, None, None, None, None, None, None, None, None, "auto")
    eos = tuple(st.eos[n] for n in st.names)
    cam, dem, truth = block["camera"], block["dem"], [block["truth"][n] for n in st.names]
    infos = [open_raster(f, "frame") for f in frames]
    pairs = [(i, j) for i in range(len(frames)) for j in range(i + 1, len(frames))]
    h0 = provisional_height(eos, st.camera)
    out, saved = {}, (guided_module.GUIDED_BELOW, guided_module.CONVERGING_DEG)
    for method, setting in (("plain", None), ("guided-below-50", (50, 360.0)), ("guided", saved)):
        guided_module.GUIDED_BELOW, guided_module.CONVERGING_DEG = setting or saved
        try:
            *_, kept, measured = _pair_matches(infos, pairs, RegisterOptions(), 1, 1.0, as_progress(None), st.camera,
                                               st.distortion, None, guide=None if setting is None else (eos, h0))
        finally:
            guided_module.GUIDED_BELOW, guided_module.CONVERGING_DEG = saved
        rows = []
        for i, j, xy_i, xy_j in kept:
            err = np.hypot(*(true_transfer(cam, truth, dem, xy_i / scale, truth[i], truth[j]) - xy_j / scale).T)
            rows.append({"pair": st.names[i][-1] + st.names[j][-1], "inliers": int(len(xy_i)),
                         "right": int(np.sum(err < 3.0))})
        out[method] = {"pairs": rows, "height_m": measured}
    return out


def triangulated(frames, block, folder: Path):
    """``{"exit": "ok"|message, "centre_m", "angle_deg", "pairs"}`` of ``fotogeo.triangulate`` on the files."""
    from fotogeo.tools.triangulate import triangulate
    try:
        rep = triangulate(frames, None, None, None, folder)
    except FotogeoError as e:
        report = folder / "report.json"
        pairs = json.loads(report.read_text())["matching"]["pairs"] if report.exists() else None
        return {"exit": str(e)[:160], "pairs": pairs}
    adj = read_exterior_orientation(folder / "exterior_orientation.txt")
    d = [float(np.linalg.norm(np.subtract(adj[n].centre, block["truth"][n].centre))) for n in adj]
    a = [angle_error(adj[n], block["truth"][n]) for n in adj]
    return {"exit": "ok", "frames": len(adj), "centre_m": max(d), "angle_deg": max(a),
            "sigma0": rep.get("sigma0")}


def run(cases, tmp: Path) -> list:
    results = []
    for kind, off, size, resize, *more in cases:
        seed = more[0] if more else (1 if kind == "ngi" else 0)
        views = more[1] if len(more) > 1 else 4
        block = converging_block(tmp / f"{kind}{off}_{size[0]}_{seed}", off_nadir=off, size=size, kind=kind,
                                 resize=resize, seed=seed)
        for variant, frames, scale in (("full", block["full"][:views], 1.0),
                                       (f"resized/{resize}", block["resized"][:views], 1.0 / resize)):
            if not frames:
                continue
            variant += "" if views == 4 else f", {views} views"
            row = {"texture": kind, "off_nadir": off, "size": list(size), "files": variant, "seed": seed,
                   "pairs": pair_rows(frames, block, scale)}
            saved = guided_module.GUIDED_BELOW, guided_module.CONVERGING_DEG
            for method, setting in (("plain", (0, 360.0)), ("guided", saved)):
                guided_module.GUIDED_BELOW, guided_module.CONVERGING_DEG = setting
                try:
                    row[method] = triangulated(frames, block, tmp / f"out_{kind}{off}_{size[0]}_{seed}_"
                                                                    f"{variant.replace('/', '').replace(', ', '_')}"
                                                                    f"_{method}")
                finally:
                    guided_module.GUIDED_BELOW, guided_module.CONVERGING_DEG = saved
            results.append(row)
            print_row(row)
    return results


def print_row(row):
    def pairs(rows):
        return " ".join(f"{r['pair']}:{r['inliers']}/{r['right']}" for r in rows["pairs"])

    def tri(t):
        return (f"ok {t['centre_m']:.3f} m {t['angle_deg']:.3f}°" if t["exit"] == "ok" else "refused")
    print(f"{row['texture']:7s} {row['off_nadir']:3.0f}° {row['size'][0]}x{row['size'][1]} {row['files']:10s} | "
          f"plain {pairs(row['pairs']['plain'])} -> {tri(row['plain'])} | guided {pairs(row['pairs']['guided'])} -> "
          f"{tri(row['guided'])} | below-50 only {pairs(row['pairs']['guided-below-50'])}", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="600 x 400, the fractal texture only")
    ap.add_argument("--held-out", action="store_true", help="only the cases the method was not built with: a "
                    "QuickBird ground (qb2), 38° off nadir, three views")
    args = ap.parse_args(argv)
    cases = [("fractal", off, (600, 400), 2) for off in (30.0, 45.0)]
    if not args.quick:
        cases += [("fractal", 30.0, (1200, 800), 4)] + [("ngi", off, (600, 400), 2) for off in (30.0, 45.0)]
    if args.held_out:
        cases = [("qb2", off, (600, 400), 2, 2) for off in (30.0, 45.0)] + [("fractal", 38.0, (800, 600), 3, 3),
                                                                           ("ngi", 38.0, (600, 400), 2, 4, 3)]
    print("per pair: epipolar inliers / of them right (< 3 px from the true transfer); triangulate: worst frame's "
          "centre and angle error vs the truth")
    with tempfile.TemporaryDirectory() as tmp:
        results = run(cases, Path(tmp))
    out = RESULTS / ("oblique_bench_held_out.json" if args.held_out else "oblique_bench.json")
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"cases": results}, indent=1))
    print(f"written {out}")


if __name__ == "__main__":
    main()
