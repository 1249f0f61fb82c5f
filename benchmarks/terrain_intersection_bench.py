"""Pixel -> map on a DEM (ray-terrain intersection) through each model direction, timed in-process.

NGI frame 0182 (truth: camera + exterior orientation + DEM, tests/ngi_truth.py): models fitted on
200 truth points, then ``Georeference.pixel_to_map`` of a 25 x 25 pixel grid on the DEM
(``../shared/data/ngi/dem.tif``, sampled in EPSG:32735):

* ``rfm-i2g`` (image -> ground: ``XY = f(col, row, Z)``, ``Z = h(XY)`` by fixed point);
* ``dlt``, ``rfm`` (ground -> image: Newton inverse at ``Z``, ``Z = h(XY)`` by fixed point).

Both run :func:`fotogeo.geometry.georeference.intersect_terrain`. Prints the median of
``--repeat`` runs (ms) and the grid nodes without a ground point. ``--save F.npz`` keeps the
ground points, ``--compare F.npz`` prints the largest change against a saved run, in metres and
in image pixels (through a ground -> image RFM at the DEM's height), to check that a change of
the loop keeps the answers. Run: ``.venv/bin/python benchmarks/terrain_intersection_bench.py``
(a few seconds; timings on a shared machine are noisy).
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from pyproj import CRS

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from ngi_truth import FRAMES, truth_points  # noqa: E402

from fotogeo.geometry.dem import DemSampler  # noqa: E402
from fotogeo.io.raster import read_dem  # noqa: E402
from fotogeo.geometry.georeference import Georeference  # noqa: E402
from fotogeo.models import MODELS  # noqa: E402
from fotogeo.pixels import pixel_centres  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
CASES = [("rfm-i2g", "image-to-ground"), ("dlt", "ground-to-image"), ("rfm", "ground-to-image")]
MAP_CRS = CRS.from_epsg(32735)


def fit(name, direction, px, ground):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the ill-posedness warnings of the RFM on 200 points
        if direction == "image-to-ground":
            return MODELS[name].estimate(np.column_stack([px, ground[:, 2]]), ground[:, :2])
        return MODELS[name].estimate(ground, px)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--save", type=Path)
    ap.add_argument("--compare", type=Path)
    args = ap.parse_args()
    ngi = args.data / "ngi"
    px, ground = truth_points(ngi, FRAMES[0][0], step=10)
    idx = np.random.default_rng(0).choice(len(px), 200, replace=False)
    dem = read_dem(ngi / "dem.tif")
    heights = dem if CRS.from_wkt(dem.crs.to_wkt()) == MAP_CRS else DemSampler(dem, MAP_CRS)
    w, h = px.max(axis=0) + 1
    x, y = pixel_centres(25, 25)
    grid = np.column_stack([x.ravel() * w / 25, y.ravel() * h / 25])
    out = {}
    for name, direction in CASES:
        geo = Georeference(fit(name, direction, px[idx], ground[idx]), heights, MAP_CRS, direction)
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            out[name] = geo.pixel_to_map(grid)
            times.append(time.perf_counter() - t0)
        null = int(np.isnan(out[name]).any(axis=1).sum())
        print(f"{name:8s} {direction:16s} median {1e3 * np.median(times):7.1f} ms   null nodes {null}/{len(grid)}")
    if args.save:
        np.savez(args.save, **out)
    if args.compare:
        old = np.load(args.compare)
        to_pixel = fit("rfm", "ground-to-image", px[idx], ground[idx])
        for name in old.files:
            a, b = old[name], out[name]
            pa, pb = (to_pixel.forward(np.column_stack([p, heights.heights_and_gradient(p)[0]])) for p in (a, b))
            print(f"{name:8s} largest change {np.nanmax(np.abs(a - b)):.2g} m, {np.nanmax(np.abs(pa - pb)):.2g} px")


if __name__ == "__main__":
    main()
