"""The demo's aerial block: a small rendered block with known truth, triangulated end to end.

:func:`make_block_scene` flies 2 strips of 4 frames (60 % forward, 30 % side overlap, alternate
strips in opposite directions) over a terrain with about ±40 m of relief
(:func:`fotogeo.orientation.block_simulation.simulate_block`, 1000 m above ground, a
400 × 600 px frame camera: about 1.7 m ground pixels) and renders every frame through its true
camera (:func:`fotogeo.orientation.block_render.render_block`: a fractal texture with patches
draped on the terrain). It writes what a user of ``fotogeo triangulate`` has: the frames (no
georeference), the camera (orthority's YAML), an approximate exterior orientation (the truth
plus 5 m and 0.5° of noise, as from a navigation system) and a GeoPackage of ground points
measured in the frames with 0.3 px noise: 5 control points (the block's corners and one edge)
and 12 check points (role ``check``), in UTM zone 35N.

:func:`triangulate_block` runs :func:`fotogeo.tools.triangulate.triangulate` on them — tie
points found by matching the overlapping frames, the bundle adjustment, its outputs — and
compares the result with the truth: the check points' RMSE (the report's, whose check
coordinates are the true ones) and the adjusted orientations' errors.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...geometry.camera import FrameCamera
from ...io.block import write_exterior_orientation, write_interior_orientation
from ...io.raster import ropen
from ...io.tables import write_table

CRS = "EPSG:32635"
CAMERA = FrameCamera(6.0, (4.0, 6.0), (400, 600))  # fx = fy = 600 px
FRAMES_DIR = "block"  # the folder of the block's inputs, inside the demo folder
OUTPUT_DIR = "block_triangulation"  # the folder of triangulate's outputs
INPUT_FILES = ("camera.yaml", "eo.txt", "control.gpkg")


def block_files() -> tuple:
    """The files :func:`triangulate_block` makes, relative to the demo folder."""
    from ..triangulate import FILES
    frames = tuple(f"{FRAMES_DIR}/{name}.tif" for name in simulate(0).block.frames)
    return frames + tuple(f"{FRAMES_DIR}/{f}" for f in INPUT_FILES) + tuple(f"{OUTPUT_DIR}/{f}" for f in FILES)


def simulate(seed: int = 7):
    """The block's :class:`~fotogeo.orientation.block_simulation.SyntheticBlock` (module docstring)."""
    from ...orientation.block_simulation import simulate_block
    return simulate_block(seed=seed, strips=2, frames_per_strip=4, camera=CAMERA, point_spacing=80.0, relief=40.0,
                          blunder_fraction=0.0, n_control=5, n_check=12, margin=5.0)


def make_block_scene(folder, *, seed: int = 7):
    """Write the frames and :data:`INPUT_FILES` into ``folder``; return ``(frame paths, synthetic block)``."""
    from ...orientation.block_render import render_block
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    sb = simulate(seed)
    b = sb.block
    images, _ = render_block(sb, seed=seed)
    frames = []
    for name, img in zip(b.frames, images):
        path = folder / f"{name}.tif"
        with ropen(path, "w", driver="GTiff", width=img.shape[1], height=img.shape[0], count=1, dtype="uint8") as ds:
            ds.write(img[None])
        frames.append(path)
    write_interior_orientation(folder / "camera.yaml", "demo-camera", CAMERA)
    write_exterior_orientation(folder / "eo.txt", b.frames, b.eo, header="approximate exterior orientation "
                               "(truth + 5 m, 0.5 deg of noise); name X Y Z omega phi kappa (PATB, degrees)")
    known = np.flatnonzero(b.role[b.obs_point] != "tie")  # measurements of control and check points
    p = b.obs_point[known]
    write_table(folder / "control.gpkg", {"id": [b.point_ids[i] for i in p],
                                          "frame": [b.frames[f] for f in b.obs_frame[known]],
                                          "col": b.obs_pixel[known, 0], "row": b.obs_pixel[known, 1],
                                          "z": b.point_xyz[p, 2], "role": b.role[p].astype(str)},
                crs=CRS, xy=b.point_xyz[p, :2])
    return frames, sb


def triangulate_block(folder, out, *, seed: int = 7, progress=None) -> dict:
    """Make the block in ``folder``, triangulate it into ``out`` and compare with the truth:
    ``{"report": triangulate's report, "truth": {...}}``."""
    from ..triangulate import triangulate
    from ...progress import as_progress
    prog = as_progress(progress)
    frames, sb = make_block_scene(folder, seed=seed)
    prog(0.3, "block rendered")
    Path(out).mkdir(parents=True, exist_ok=True)
    rep = triangulate(frames, Path(folder) / "camera.yaml", Path(folder) / "eo.txt", None, out,
                      gcps=Path(folder) / "control.gpkg", image_sigma=0.3, progress=prog.stage(0.3, 1.0, "triangulate"))
    return {"report": rep, "truth": truth_comparison(sb, rep)}


def truth_comparison(sb, rep) -> dict:
    """Errors of the adjusted block against the truth: check points (in m and ground pixels) and
    projection centres (m) and angles (°) of the adjusted orientations."""
    true = {n: e for n, e in zip(sb.block.frames, sb.true_eo)}
    d = np.array([[f["X"] - true[f["name"]].X, f["Y"] - true[f["name"]].Y, f["Z"] - true[f["name"]].Z,
                   f["omega"] - true[f["name"]].omega, f["phi"] - true[f["name"]].phi,
                   (f["kappa"] - true[f["name"]].kappa + 180) % 360 - 180] for f in rep["frames"]])
    check = rep["statistics"]["check"]
    return {"gsd_m": sb.gsd, "check_n": check.get("n", 0),
            "check_planimetric_m": check.get("rmse_planimetric_m"), "check_z_m": check.get("rmse_z_m"),
            "check_planimetric_gsd": check.get("rmse_planimetric_m", np.nan) / sb.gsd,
            "check_z_gsd": check.get("rmse_z_m", np.nan) / sb.gsd,
            "centre_rmse_m": float(np.sqrt(np.mean(np.sum(d[:, :3] ** 2, axis=1)))),
            "angle_rmse_deg": float(np.sqrt(np.mean(d[:, 3:] ** 2)))}
