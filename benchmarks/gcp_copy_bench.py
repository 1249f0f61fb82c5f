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
* The other commands reading GCP pixels (issue 32), cases: the right image; GCPs read on a copy 0.5x and 0.25x the
  size and turned 90° clockwise; a crop with an offset (the frame's pixels from (100, 200), 320x576, with its own
  camera; for the RPC, the grid nodes of a product around the crop, the crop 250 px in from its corner):
  ``compare-models`` with the NGI camera (frame 0182 raster; dlt + collinearity, 6 control points, one trial),
  ``rpc-bias --method affine`` (ventoux), and ``triangulate --gcps`` (the control as the block reads it,
  :func:`fotogeo.tools.triangulate.inputs.read_block_control`: frames 0182 and 0184, 30 control + 10 check points
  each, the first frame's read on the copy).
* An approximate focal length (5–20 % off) is not taken for a copy: :func:`copy_reading` on NGI 0182's GCPs, at the
  frame's flying height and 3500 m lower.

Per case: refused (the first words of the message) or the fit (GCPs skipped, control RMS, check RMS or the
shift's residual). Every line also goes to ``benchmarks/results/gcp_copy_bench.json`` (``--json``). Run from
outside the checkout: ``cd /tmp/x && PYTHONPATH=<tree> python <tree>/benchmarks/gcp_copy_bench.py [--seed 7]
[--noise 0.3]``.
"""
from __future__ import annotations

import argparse
import inspect
import json
import shutil
import tempfile
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import rasterio
import shapely

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
RESULTS = Path(__file__).resolve().parent / "results" / "gcp_copy_bench.json"
#: every printed line as a record: (section, case, outcome)
LINES = []
SECTION = [""]
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
            line = said(call())
        except Exception as e:  # noqa: BLE001 - the refusal is the result
            line = f"REFUSED {type(e).__name__}: {str(e).split(': ', 1)[-1][:110]}"
    print(f"{name:14s} {line}")
    LINES.append({"section": SECTION[0], "case": name, "outcome": line})


def _section(title):
    SECTION[0] = title
    print(title)


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
    _section(f"orient, NGI {NAME}, seed {seed}, noise {noise} px")
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
    _section(f"orient over flat terrain, NGI {NAME} geometry, seed {seed}, noise {noise} px")
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

    def layer(within, read=lambda p: p, typo=False, shift=0):
        ids, pixel, ground = [], [], []
        for k, h in ((1, 485.0), (2, 1000.0)):
            for i in np.flatnonzero(np.all((px + shift > 0) & (px + shift < within), axis=1)):
                ids.append(f"n{i}_{int(h)}")
                pixel.append(read(px[i:i + 1] + shift)[0])
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
    for method in ("shift", "affine"):
        _section(f"rpc-bias ({method}), ventoux left crop")
        todo = dict(cases) if method == "shift" else {
            "right image": cases["as measured"], "x0.5": cases["x0.5"],
            "x0.25": lambda: layer(500, lambda p: p * 0.25), "turned 90 cw": cases["turned 90 cw"],
            "crop w/ offset": lambda: layer(1000, lambda p: p - 250, shift=250)}
        for name, make in todo.items():
            path = make()
            _run(name, lambda: rpc_bias(tmp / "left_image.tif", path, tmp / "o.tif", method=method, overwrite=True),
                 said)


#: the crop with an offset of the other commands' cases: its top-left corner in the frame, its size
OFFSET, CROP = (100, 200), (W // 2, H // 2)


def _copies(pixel, w=W, h=H):
    """The other commands' cases: the GCP pixels as read on each copy (module docstring)."""
    c, r = pixel[:, 0], pixel[:, 1]
    return {"right image": pixel, "x0.5": pixel * 0.5, "x0.25": pixel * 0.25,
            "turned 90 cw": np.column_stack([h - r, c]), "crop w/ offset": pixel - OFFSET}


def _ngi_sets(data: Path, seed: int, noise: float):
    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.simulation import make_gcps
    ngi = data / "ngi"
    dem = read_dem(ngi / "dem.tif")
    out = {}
    for k, name in enumerate((NAME, NAME[:-4] + "0184")):
        s = make_gcps(load_ngi_frame(ngi, name), dem, 30, 10, "homogeneous", noise=noise, seed=seed + k)
        out[name] = (np.vstack([s.gcp_ground, s.check_ground]), np.vstack([s.gcp_pixel, s.check_pixel]))
    return out, dem.crs.to_wkt()


def _crop_camera():
    from fotogeo.geometry.camera import FrameCamera
    return FrameCamera(120.0, (46.08, 82.944), CROP, principal_point=(W / 2 - OFFSET[0], H / 2 - OFFSET[1]))


def compare_cases(data: Path, tmp: Path, seed: int, noise: float):
    from fotogeo import compare_models
    sets, crs = _ngi_sets(data, seed, noise)
    ground, pixel = sets[NAME]
    frame = data / "ngi" / "frames" / f"{NAME}_RGB.tif"
    with rasterio.open(frame) as ds:
        a = ds.read(window=rasterio.windows.Window(*OFFSET, *CROP))
    with rasterio.open(tmp / "crop.tif", "w", driver="GTiff", width=CROP[0], height=CROP[1], count=a.shape[0],
                       dtype=a.dtype) as out:
        out.write(a)
    role = ["control"] * 30 + ["check"] * 10

    def said(rows):
        rms = {m: np.median([r["check_rms_xy_px"] for r in rows if r["model"] == m and r.get("check_rms_xy_px")])
               for m in ("dlt", "collinearity")}
        return f"exit 0  check RMS (median of rows): dlt {rms['dlt']:.2f} px, collinearity {rms['collinearity']:.2f} px"
    _section(f"compare-models with a camera, NGI {NAME}, seed {seed}, noise {noise} px")
    for name, pix in _copies(pixel).items():
        path = _layer(tmp / "c.gpkg", [f"P{i}" for i in range(40)], pix, ground, crs, role)
        crop = name.startswith("crop")
        _run(name, lambda: compare_models(tmp / "crop.tif" if crop else frame, path, models=["dlt", "collinearity"],
                                          counts=(6,), trials=1, camera=_crop_camera() if crop else
                                          str(data / "ngi" / "interior_orientation.yaml")), said)


def triangulate_cases(data: Path, tmp: Path, seed: int, noise: float):
    from fotogeo.tools.triangulate.inputs import read_block_control, read_camera
    sets, crs = _ngi_sets(data, seed, noise)
    cam, dist = read_camera(str(data / "ngi" / "interior_orientation.yaml"))
    # the distortion argument is this branch's; without it (an older tree) the control is read as before
    extra = (dist,) if "distortion" in inspect.signature(read_block_control).parameters else ()
    _section(f"triangulate --gcps (the control as the block reads it), NGI 0182 + 0184, seed {seed}")
    for name in _copies(sets[NAME][1]):
        frames = []
        for k, (frame, (ground, pixel)) in enumerate(sets.items()):
            pix = _copies(pixel)[name] if k == 0 or name.startswith("crop") else pixel
            frames.append(gpd.GeoDataFrame(
                {"id": [f"{'AB'[k]}{i}" for i in range(40)], "frame": f"{frame}_RGB", "col": pix[:, 0],
                 "row": pix[:, 1], "z": ground[:, 2]}, geometry=shapely.points(ground[:, :2]), crs=crs))
        path = tmp / "t.gpkg"
        gpd.GeoDataFrame(np.concatenate([f.values for f in frames]), columns=frames[0].columns, geometry="geometry",
                         crs=crs).to_file(path, driver="GPKG")
        camera = _crop_camera() if name.startswith("crop") else cam
        _run(name, lambda: read_block_control(path, None, None, camera, [f"{f}_RGB" for f in sets], None, *extra),
             lambda r: f"exit 0  measurements kept {len(r[0].name)} of 80")


def focal_cases(data: Path, seed: int, noise: float):
    """An approximate focal length is no copy: NGI 0182's 30 GCPs (the true camera) checked with the camera's focal
    5–20 % off, at the frame's flying height and 3500 m lower (relief a larger share of it)."""
    import dataclasses

    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.copy_reading import collinearity_rms, copy_reading
    from fotogeo.orientation.simulation import make_gcps
    frame, dem = load_ngi_frame(data / "ngi", NAME), read_dem(data / "ngi" / "dem.tif")
    _section(f"an approximate focal length (copy_reading), NGI {NAME}, seed {seed}, noise {noise} px")
    for dz in (0.0, 3500.0):
        low = dataclasses.replace(frame, eo=dataclasses.replace(frame.eo, Z=frame.eo.Z - dz))
        s = make_gcps(low, dem, 30, 0, "homogeneous", noise=noise, seed=seed)
        g, p = s.gcp_ground, s.gcp_pixel
        share = (g[:, 2].max() - g[:, 2].min()) / (low.eo.Z - g[:, 2].mean())
        for k in (1.05, 1.1, 1.2):
            rms = collinearity_rms(dataclasses.replace(frame.camera, focal_length=frame.camera.focal_length * k))

            def said(found, rms=rms, g=g, p=p):
                named = "none named" if found is None else f"NAMED {found['scale']}x, {found['turns']} turns"
                return f"as given {rms(g, p):.2f} px, {named}"
            _run(f"f x{k:g} rel {share:.2f}", lambda: copy_reading(g, p, np.ones(len(p), bool), W, H, rms, 0.5, 4),
                 said)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--noise", type=float, default=0.3)
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--json", type=Path, default=RESULTS)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        orient_cases(args.data, Path(tmp), args.seed, args.noise)
        flat_cases(args.data, Path(tmp), args.seed, args.noise)
        rpc_cases(args.data, Path(tmp))
        compare_cases(args.data, Path(tmp), args.seed, args.noise)
        triangulate_cases(args.data, Path(tmp), args.seed, args.noise)
        focal_cases(args.data, args.seed, args.noise)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"seed": args.seed, "noise_px": args.noise, "lines": LINES}, indent=1) + "\n")


if __name__ == "__main__":
    main()
