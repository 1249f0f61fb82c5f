"""``fotogeo orient`` on GCPs without heights: the 2-D fit and its hint, against the same GCPs with ``--dem``.

For each NGI frame, control and check GCPs are generated from the true geometry (camera + exterior orientation
+ DEM; :func:`fotogeo.orientation.simulation.make_gcps`, ``homogeneous`` spread, ``--noise`` px on the pixels,
``--seed``), written as a GeoPackage point layer (fields ``id col row role``) without a ``z`` field, and
``fotogeo orient FRAME GCPS --report r.json`` is run as a user runs it (a child process, working folder outside
any checkout), then again with ``--dem ngi/dem.tif`` (the heights taken from the DEM). Per run: the model
``auto`` keeps, its check RMSE (px), whether the ``--dem`` hint was printed and the report's heights count.
Printed as lines and written to ``benchmarks/results/orient_heights_bench.json``.

    PYTHONPATH=. .venv/bin/python benchmarks/orient_heights_bench.py [--frames 0182,0184] [--seed 3] \\
        [--control 40 --check 20] [--noise 0.3]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))


def _gcps(folder: Path, name: str, n_control: int, n_check: int, noise: float, seed: int) -> Path:
    """The GeoPackage of ``name``'s GCPs without heights (control then check)."""
    import geopandas as gpd
    import shapely

    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.simulation import make_gcps
    frame, dem = load_ngi_frame(DATA / "ngi", name), read_dem(DATA / "ngi" / "dem.tif")
    s = make_gcps(frame, dem, n_control, n_check, "homogeneous", noise=noise, seed=seed)
    ground, pixel = np.vstack([s.gcp_ground, s.check_ground]), np.vstack([s.gcp_pixel, s.check_pixel])
    cols = {"id": [f"P{i}" for i in range(len(pixel))], "col": pixel[:, 0], "row": pixel[:, 1],
            "role": ["control"] * len(s.gcp_pixel) + ["check"] * len(s.check_pixel)}
    path = folder / f"{name}_noz.gpkg"
    gpd.GeoDataFrame(cols, geometry=shapely.points(ground[:, :2]), crs=dem.crs.to_wkt()).to_file(path, driver="GPKG")
    return path


def _orient(folder: Path, image: Path, gcps: Path, dem: Path | None) -> dict:
    rep = folder / f"{gcps.stem}_{'dem' if dem else 'none'}.json"
    cmd = [sys.executable, "-m", "fotogeo", "orient", str(image), str(gcps), "--report", str(rep)]
    cmd += ["--dem", str(dem)] if dem else []
    p = subprocess.run(cmd, env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True,
                       cwd=folder)  # not a checkout: `python -m` puts the working folder first on the path
    if p.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{p.stderr[-2000:]}")
    r = json.loads(rep.read_text())
    return {"dem": dem is not None, "model": r["model_name"], "check_rms_xy_px": round(r["check"]["rms_xy_px"], 3),
            "hint_printed": "--dem" in p.stderr + p.stdout and dem is None, "hints": r.get("hints", []),
            "heights": r.get("heights")}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", default="0182,0184", help="NGI frame numbers of strip 05, ',' separated")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--control", type=int, default=40)
    ap.add_argument("--check", type=int, default=20)
    ap.add_argument("--noise", type=float, default=0.3, help="Gaussian noise on the GCP pixels (px per axis)")
    a = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="orient_heights_") as t:
        folder = Path(t)
        for f in a.frames.split(","):
            name = f"3324c_2015_1004_05_{f.strip()}"
            gcps = _gcps(folder, name, a.control, a.check, a.noise, a.seed)
            for dem in (None, DATA / "ngi" / "dem.tif"):
                r = {"frame": name, "control": a.control, "check": a.check, "noise_px": a.noise, "seed": a.seed,
                     **_orient(folder, DATA / "ngi" / "frames" / f"{name}_RGB.tif", gcps, dem)}
                print(json.dumps(r), flush=True)
                rows.append(r)
    dest = ROOT / "benchmarks" / "results" / "orient_heights_bench.json"
    dest.write_text(json.dumps({"command": " ".join(sys.argv), "rows": rows}, indent=1) + "\n")
    print("->", dest)


if __name__ == "__main__":
    main()
