"""The embedded default: a synthetic but realistic scene registered end to end, with known truth.

:func:`make_scene` generates, deterministically from a seed:

* a fractal DEM (sum of up-sampled random octaves, about ±30 m of relief on 800 m);
* a 3-band orthophoto in UTM zone 35N (EPSG:32635), 4 m pixels: a patchwork of fields
  with their own colour and texture, tracks, and hill-shading from the DEM;
* a target image rendered from it through a known perspective frame camera (κ = 160°,
  a few degrees of tilt, 3.5 m ground pixels): every target pixel's ray is intersected with
  the DEM and the orthophoto sampled there, then the bands are mixed and re-scaled as
  another sensor would record them, with noise. No georeference is written to the target.

:func:`run_demo` registers the target to the orthophoto with :func:`fotogeo.tools.register.tool.register`
and compares the fitted model with the true geometry over a dense grid of target pixels,
beside the best homography that exists (least squares to that truth). It then renders a small
aerial block and triangulates it (:mod:`fotogeo.tools.demo.block`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from affine import Affine

from ...geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from ...geometry.dem import Dem
from ...io.raster import ropen
from ...io.report import write_json
from ...models import Projective
from ...models.stats import rmse
from ...pixels import map_to_pixel, pixel_centres, to_centre
from ..common.boundary import tool

CRS = "EPSG:32635"
ORIGIN = (500000.0, 4420000.0)  # top-left corner of the orthophoto


@dataclass(frozen=True)
class Scene:
    reference: Path
    target: Path
    dem_path: Path
    frame: OrientedFrame
    dem: Dem


def _fractal(rng, shape, octaves=6, persistence=0.55):
    out = np.zeros(shape, np.float32)
    amp = 1.0
    for o in range(octaves):
        n = 2 ** (o + 2)
        small = rng.normal(size=(n, n)).astype(np.float32)
        out += amp * cv2.resize(small, shape[::-1], interpolation=cv2.INTER_CUBIC)
        amp *= persistence
    return (out - out.mean()) / out.std()


def _orthophoto(rng, size, dem_up):
    """Fields (Voronoi cells with colour and texture), tracks and hill-shading; (3, size, size) uint8."""
    n_fields = 160
    seeds = rng.uniform(0, size, (n_fields, 2))
    yy, xx = np.mgrid[:size, :size].astype(np.float32)
    label = np.zeros((size, size), np.int32)
    best = np.full((size, size), np.inf, np.float32)
    for k, (sx, sy) in enumerate(seeds):
        d = (xx - sx) ** 2 + (yy - sy) ** 2
        closer = d < best
        label[closer], best[closer] = k, d[closer]
    colours = rng.uniform(60, 200, (n_fields, 3)).astype(np.float32)
    img = colours[label].transpose(2, 0, 1)
    stripes = np.sin((xx * np.cos(label * 0.7) + yy * np.sin(label * 0.7)) * 0.35)
    img += 12 * stripes + 10 * _fractal(rng, (size, size), octaves=8, persistence=0.8)
    edges = cv2.morphologyEx((label * 37 % 251).astype(np.uint8), cv2.MORPH_GRADIENT, np.ones((3, 3)))
    img[:, edges > 0] *= 0.7
    tracks = np.zeros((size, size), np.uint8)
    for _ in range(12):
        p = rng.uniform(0, size, (4, 2)).astype(np.int32)
        cv2.polylines(tracks, [p], False, 255, 3)
    img[:, tracks > 0] = 225
    gy, gx = np.gradient(dem_up)
    shade = np.clip(1.0 - 0.06 * (gx - gy), 0.6, 1.3)
    return np.clip(img * shade, 1, 255).astype(np.uint8)


def make_scene(folder, *, seed: int = 7, size: int = 1000, pixel: float = 4.0) -> Scene:
    """Write ``reference.tif`` and ``target.tif`` into ``folder`` (see the module docstring)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    dem_px = 20.0
    n_dem = int(size * pixel / dem_px)
    heights = 800.0 + 30.0 * _fractal(rng, (n_dem, n_dem))
    dem = Dem(heights.astype(np.float64), Affine(dem_px, 0, ORIGIN[0], 0, -dem_px, ORIGIN[1]), CRS)
    ortho_t = Affine(pixel, 0, ORIGIN[0], 0, -pixel, ORIGIN[1])
    dem_up = cv2.resize(heights.astype(np.float32), (size, size), interpolation=cv2.INTER_CUBIC)
    ortho = _orthophoto(rng, size, dem_up)
    reference = folder / "reference.tif"
    with ropen(reference, "w", driver="GTiff", width=size, height=size, count=3, dtype="uint8",
                       crs=CRS, transform=ortho_t, nodata=0, photometric="RGB") as ds:
        ds.write(ortho)
    centre = (ORIGIN[0] + size * pixel / 2, ORIGIN[1] - size * pixel / 2)
    cam = FrameCamera(12.0, (10.8, 8.4), (900, 700))  # fx = fy = 1000 px
    frame = OrientedFrame(cam, ExteriorOrientation(centre[0] + 60, centre[1] - 40, 800.0 + 3500.0,
                                                   3.0, -2.0, 160.0), "demo")
    x, y = pixel_centres(900, 700)
    ground = frame.pixel_to_world(np.column_stack([x.ravel(), y.ravel()]), dem)
    src = to_centre(map_to_pixel(ortho_t, ground[:, :2]))
    src = np.where(np.isfinite(src), src, -1e6)
    mx = src[:, 0].reshape(700, 900).astype(np.float32)
    my = src[:, 1].reshape(700, 900).astype(np.float32)
    b = [cv2.remap(ortho[i].astype(np.float32), mx, my, cv2.INTER_LINEAR, borderValue=0) for i in range(3)]
    valid = cv2.remap(np.ones((size, size), np.float32), mx, my, cv2.INTER_NEAREST, borderValue=0) > 0
    noise = rng.normal(0, 3.0, (3, 700, 900))
    mixed = np.stack([0.55 * b[1] + 0.25 * b[0] + 30, 1.15 * b[0] - 10, 0.8 * b[2] + 0.1 * b[1] + 25]) + noise
    target_img = np.clip(mixed, 1, 255).astype(np.uint8)
    target_img[:, ~valid] = 0
    target = folder / "target.tif"
    with ropen(target, "w", driver="GTiff", width=900, height=700, count=3, dtype="uint8",
                       nodata=0) as ds:
        ds.write(target_img)
    dem_path = folder / "dem.tif"
    with ropen(dem_path, "w", driver="GTiff", width=n_dem, height=n_dem, count=1, dtype="float32",
               crs=CRS, transform=dem.transform) as ds:
        ds.write(heights.astype(np.float32), 1)
    return Scene(reference, target, dem_path, frame, dem)


def truth_comparison(scene: Scene, georeference, step: int = 10) -> dict:
    """RMSE (m) of a registration's ``georeference`` against the true geometry on a dense target
    grid (3-D models at the true heights), and the best homography's."""
    x, y = pixel_centres(900 // step, 700 // step)
    grid = np.column_stack([x.ravel(), y.ravel()]) * step
    truth3 = scene.frame.pixel_to_world(grid, scene.dem)
    ok = np.isfinite(truth3).all(axis=1)
    grid, truth3 = grid[ok], truth3[ok]
    truth = truth3[:, :2]
    err = georeference.with_heights(truth3[:, 2]).pixel_to_map(grid) - truth
    best = Projective.estimate(grid, truth)
    return {"n": int(len(grid)), "dense_rmse_m": rmse(err), "dense_max_m": float(np.hypot(*err.T).max()),
            "best_homography_rmse_m": rmse(best.forward(grid) - truth)}


#: the files of the registration part of :func:`run_demo` (the block's are :func:`demo_block.block_files`)
DEMO_FILES = ("reference.tif", "target.tif", "dem.tif", "registered.tif", "registered.gpkg", "registered.json",
              "orthorectified.tif", "orthorectified.gpkg", "orthorectified.json")


@tool("DEMO", "REGISTER", outputs=("folder",))
def run_demo(folder, *, progress=None, seed: int = 7, overwrite: bool = False, **options) -> dict:
    """Make the scene in ``folder``, register it twice — with the paper's homography and
    terrain-aware with the scene's DEM — and return both reports with their truth comparisons;
    then render a small aerial block and triangulate it (:mod:`fotogeo.tools.demo.block`):
    ``res["block"]`` holds triangulate's report and its comparison with the truth.

    All of :data:`DEMO_FILES` and the block's files are made in a hidden working folder inside
    ``folder`` and committed together (:class:`~fotogeo.io.raster.AtomicOutputs`): an error or a
    cancel leaves ``folder`` as it was, and existing files are replaced only with ``overwrite``.
    """
    import shutil
    import tempfile
    from dataclasses import replace

    from ...io.output_checks import check_output

    from ...io.raster import AtomicOutputs
    from ...progress import as_progress
    from . import block as demo_block
    from ..register.tool import register
    prog = as_progress(progress)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    files = DEMO_FILES + demo_block.block_files()
    for name in files:
        if (folder / name).parent.is_dir():  # the block's subfolders are made at the commit
            check_output(folder / name, [], overwrite, "demo output")
    work = Path(tempfile.mkdtemp(prefix=".fotogeo-demo.", dir=folder))
    made = [d for d in (folder / demo_block.FRAMES_DIR, folder / demo_block.OUTPUT_DIR) if not d.exists()]
    try:
        with AtomicOutputs(overwrite) as out:
            scene = make_scene(work, seed=seed)
            prog(0.05, "scene generated")
            r2 = register(scene.reference, scene.target, work / "registered.tif",
                          progress=prog.stage(0.05, 0.3, "homography"), **options)
            r3 = register(scene.reference, scene.target, work / "orthorectified.tif", dem=scene.dem_path,
                          progress=prog.stage(0.3, 0.5, "terrain-aware"), **options)
            res = {"truth": truth_comparison(scene, r2.georeference),
                   "terrain_truth": truth_comparison(scene, r3.georeference)}
            for key, r in (("registration", r2), ("terrain", r3)):
                report = _moved(r.report, work, folder)
                write_json(r.report_path, report)
                res[key] = replace(r, output=folder / r.output.name, vectors=folder / r.vectors.name,
                                   report_path=folder / r.report_path.name, report=report)
            block = demo_block.triangulate_block(work / demo_block.FRAMES_DIR, work / demo_block.OUTPUT_DIR,
                                                 seed=seed, progress=prog.stage(0.5, 1.0, "aerial triangulation"))
            res["block"] = {"report": _moved(block["report"], work, folder), "truth": block["truth"]}
            write_json(work / demo_block.OUTPUT_DIR / "report.json", res["block"]["report"])
            html = work / demo_block.OUTPUT_DIR / "report.html"  # its paths too: to the final folder
            html.write_text(html.read_text(encoding="utf-8").replace(str(work), str(folder)), encoding="utf-8")
            for d in made:
                d.mkdir()
            for name in files:
                (work / name).replace(out.temp(folder / name))
            out.commit()
    finally:
        shutil.rmtree(work, ignore_errors=True)
        for d in made:
            if d.is_dir() and not any(d.iterdir()):
                d.rmdir()
    return res


def _moved(value, old: Path, new: Path):
    """``value`` (a report) with every path string under ``old`` moved to ``new``."""
    if isinstance(value, dict):
        return {k: _moved(v, old, new) for k, v in value.items()}
    if isinstance(value, list):
        return [_moved(v, old, new) for v in value]
    if isinstance(value, str) and value.startswith(str(old)):
        return str(new) + value[len(str(old)):]
    return value
