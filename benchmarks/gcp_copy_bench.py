"""GCP pixel positions read on another copy of the image: what ``orient`` (camera, collinearity) and ``rpc-bias``
(shift) do with them (:mod:`fotogeo.orientation.copy_reading`).

* ``orient``: NGI frame 0182's true geometry (camera + published exterior orientation + DEM,
  :func:`fotogeo.orientation.simulation.make_gcps`), 30 control + 10 check points, Gaussian noise on the control
  pixels (default 0.3 px), a numbers-only resection. Cases: as measured; read on a copy 1.2x, 1.3x, 1.45x, 2x, 0.5x
  this image's size; on the frame turned 90° clockwise, 180°, 90° counter-clockwise; two typos outside (+700 px in
  col); one typo inside (+40, −25 px); the whole frame's GCPs on a top-left crop half its size whose camera is the
  crop's (principal point where the frame's falls).
* ``orient`` over flat terrain: 40 pixels drawn uniformly on frame 0182, their ground points at one height
  (the camera's height − 3000 m) by the same geometry, 0.3 px noise; read on a 2x copy (frame camera) and on a
  top-left crop half the size (the crop's camera), where the collinearity equations trade the copy's scale for the
  flying height; "off" is the fitted model's median distance from the true pixels (this image's). The NGI GCPs
  without heights (``auto`` and ``collinearity``, with the camera).
* ``rpc-bias``: the ventoux Pleiades crop (500x500) and its OSSIM ``.geom`` RPC; GCPs = the rigorous model's
  location-grid nodes inside it, moved by a known bias (2.3, −1.7) px; read on 1.3x / 0.5x / turned copies; two
  typos; the nodes of a product twice the crop's size (the crop its top-left quarter).

Per case: refused (the first words of the message) or the fit (GCPs skipped, control RMS, check RMS or the
shift's residual). Run from outside the checkout: ``cd /tmp/x && PYTHONPATH=<tree> python
<tree>/benchmarks/gcp_copy_bench.py [--seed 7] [--noise 0.3]``.
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import rasterio
import shapely

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
NAME = "3324c_2015_1004_05_0182"
W, H = 640, 1152


def _layer(path, ids, pixel, ground, crs, role=None, with_z=True):
    cols = {"id": ids, "col": pixel[:, 0], "row": pixel[:, 1]} | ({"z": ground[:, 2]} if with_z else {})
    if role is not None:
        cols["role"] = role
    gpd.GeoDataFrame(cols, geometry=shapely.points(ground[:, :2]), crs=crs).to_file(path, driver="GPKG")
    return path


def _run(name, call, said):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            print(f"{name:14s} {said(call())}")
        except Exception as e:  # noqa: BLE001 - the refusal is the result
            print(f"{name:14s} REFUSED {type(e).__name__}: {str(e).split(': ', 1)[-1][:110]}")


def orient_cases(data: Path, tmp: Path, seed: int, noise: float):
    from fotogeo.geometry.camera import FrameCamera
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.simulation import make_gcps
    from fotogeo.tools.orient.tool import orient
    ngi = data / "ngi"
    frame, dem = load_ngi_frame(ngi, NAME), read_dem(ngi / "dem.tif")
    s = make_gcps(frame, dem, 30, 10, "homogeneous", noise=noise, seed=seed)
    ground, pixel = np.vstack([s.gcp_ground, s.check_ground]), np.vstack([s.gcp_pixel, s.check_pixel])
    role, ids = ["control"] * 30 + ["check"] * 10, [f"P{i}" for i in range(40)]
    camera = str(ngi / "interior_orientation.yaml")
    crop = FrameCamera(120.0, (46.08, 82.944), (W // 2, H // 2), principal_point=(W / 2, H / 2))
    c, r = pixel[:, 0], pixel[:, 1]
    typos, blunder = pixel.copy(), pixel.copy()
    typos[[0, 5], 0] += 700
    blunder[3] += (40, -25)
    cases = {"as measured": pixel, "x1.2": pixel * 1.2, "x1.3": pixel * 1.3, "x1.45": pixel * 1.45, "x2": pixel * 2,
             "x0.5": pixel * 0.5, "turned 90 cw": np.column_stack([H - r, c]),
             "turned 180": np.column_stack([W - c, H - r]), "turned 90 ccw": np.column_stack([r, W - c]),
             "2 typos out": typos, "1 typo in": blunder, "crop (camera)": pixel}

    def said(rep):
        return (f"exit 0  skipped {len(rep['skipped']):2d}  control n {rep['control']['n']:2d} RMS "
                f"{rep['control']['rms_xy_px']:.2f} px  check n {rep['check']['n']:2d} RMS "
                f"{rep['check'].get('rms_xy_px', float('nan')):.2f} px")
    print(f"orient, NGI {NAME}, seed {seed}, noise {noise} px")
    for name, pix in cases.items():
        path = _layer(tmp / "g.gpkg", ids, pix, ground, dem.crs.to_wkt(), role)
        cam = crop if name.startswith("crop") else camera
        _run(name, lambda: orient(None, path, model="collinearity", camera=cam), said)


def flat_cases(data: Path, tmp: Path, seed: int, noise: float):
    from fotogeo.geometry.camera import FrameCamera
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.simulation import make_gcps
    from fotogeo.tools.orient.tool import orient
    ngi = data / "ngi"
    frame, dem = load_ngi_frame(ngi, NAME), read_dem(ngi / "dem.tif")
    rng = np.random.default_rng(seed)
    ground = frame.pixel_to_world_at(rng.uniform([5, 5], [W - 5, H - 5], (40, 2)), frame.eo.centre[2] - 3000.0)
    true = frame.world_to_pixel(ground)
    pixel = true + rng.normal(0, noise, (40, 2))
    role, ids = ["control"] * 30 + ["check"] * 10, [f"P{i}" for i in range(40)]
    crop = FrameCamera(120.0, (46.08, 82.944), (W // 2, H // 2), principal_point=(W / 2, H / 2))

    def said(fit):
        off = np.median(np.hypot(*(fit.model.forward(ground) - true).T))
        return (f"exit 0  skipped {len(fit['skipped']):2d}  control n {fit['control']['n']:2d} RMS "
                f"{fit['control']['rms_xy_px']:.2f} px  off {off:.0f} px")
    print(f"orient over flat terrain, NGI {NAME} geometry, seed {seed}, noise {noise} px")
    for name, pix, cam in (("flat x2", pixel * 2, frame.camera), ("flat crop", pixel, crop)):
        path = _layer(tmp / "f.gpkg", ids, pix, ground, dem.crs.to_wkt(), role)
        _run(name, lambda: orient(None, path, model="collinearity", camera=cam), said)
    s = make_gcps(frame, dem, 30, 10, "homogeneous", noise=noise, seed=seed)
    ground, pixel = np.vstack([s.gcp_ground, s.check_ground]), np.vstack([s.gcp_pixel, s.check_pixel])
    path = _layer(tmp / "nz.gpkg", ids, pixel, ground, dem.crs.to_wkt(), role, with_z=False)
    camera = str(ngi / "interior_orientation.yaml")
    for model in ("auto", "collinearity"):
        _run(f"no z, {model}"[:14], lambda: orient(None, path, model=model, camera=camera),
             lambda fit: f"exit 0  model {fit.model_name}  check n {fit['check']['n']:2d} RMS "
                         f"{fit['check']['rms_xy_px']:.2f} px")


def rpc_cases(data: Path, tmp: Path):
    from fotogeo import rpc_bias
    v = data / "rpc" / "ventoux"
    for f in ("left_image.tif", "left_image.geom"):
        shutil.copy(v / f, tmp)
    with rasterio.open(v / "GRID_PHR1B_P_201308051042194_SEN_690908101-001.tif") as ds:
        a, t = ds.read(), ds.transform
    with rasterio.open(v / "left_image.tif") as ds:
        w = ds.transform
    r, c = np.mgrid[0:a.shape[1], 0:a.shape[2]]
    x, y = t * (c.ravel(), r.ravel())
    px = np.column_stack([x - w.c, y - w.f]) + (2.3, -1.7)

    def layer(within, read=lambda p: p, typo=False):
        ids, pixel, ground = [], [], []
        for k, h in ((1, 485.0), (2, 1000.0)):
            for i in np.flatnonzero(np.all((px > 0) & (px < within), axis=1)):
                ids.append(f"n{i}_{int(h)}")
                pixel.append(read(px[i:i + 1])[0])
                ground.append((a[2 * k].ravel()[i], a[2 * k + 1].ravel()[i], h))
        pixel = np.array(pixel)
        if typo:
            pixel[[0, 3], 0] += 800
        return _layer(tmp / "r.gpkg", ids, pixel, np.array(ground), "EPSG:4326")
    cases = {"as measured": lambda: layer(500), "x1.3": lambda: layer(500, lambda p: p * 1.3),
             "x0.5": lambda: layer(500, lambda p: p * 0.5),
             "turned 90 cw": lambda: layer(500, lambda p: np.column_stack([500 - p[:, 1], p[:, 0]])),
             "2 typos out": lambda: layer(500, typo=True), "crop (of 2x)": lambda: layer(1000)}

    def said(rep):
        return (f"exit 0  skipped {len(rep['skipped']):2d}  control n {rep['control']['after']['n']:2d} "
                f"RMS after {rep['control']['after']['rms_xy']:.2f} px  shift "
                f"{np.round(rep['correction']['shift_px'], 2).tolist()}")
    print("rpc-bias (shift), ventoux left crop")
    for name, make in cases.items():
        path = make()
        _run(name, lambda: rpc_bias(tmp / "left_image.tif", path, tmp / "o.tif", overwrite=True), said)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--noise", type=float, default=0.3)
    ap.add_argument("--data", type=Path, default=DATA)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        orient_cases(args.data, Path(tmp), args.seed, args.noise)
        flat_cases(args.data, Path(tmp), args.seed, args.noise)
        rpc_cases(args.data, Path(tmp))


if __name__ == "__main__":
    main()
