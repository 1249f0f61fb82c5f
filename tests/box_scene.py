"""A rendered scene with box-shaped buildings on flat ground, for orthorectification tests (issue 21).

Ground at height ``GROUND`` with a texture ``T(X, Y)`` (values 20..200), boxes with roofs of value
``ROOF`` and walls of value ``WALL``; one nadir frame camera (PATB ω = φ = κ = 0) ``FLY`` metres above the
ground. Every image pixel is rendered exactly: its ray (through the pixel centre) meets the ground plane
or the nearest box (slab test), and takes the value of what it meets. :func:`hidden_from_camera` says, for
ground points, whether the segment to the projection centre passes through a box (the truth of occlusion).
Written files: ``frame.tif`` (no georeference), ``camera.yaml``, ``eo.txt``, ``dsm.tif`` (``CELL`` m,
EPSG:32635, boxes included) and ``dem.tif`` (the bare ground).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame

GROUND, FLY, ROOF, WALL = 100.0, 500.0, 250, 230
ORIGIN = (500000.0, 4400000.0)  # ground point under the camera (EPSG:32635)
#: boxes: (x0, x1, y0, y1, top) in metres relative to ORIGIN
BOXES = ((60.0, 80.0, -10.0, 10.0, GROUND + 60.0), (-30.0, -15.0, 50.0, 75.0, GROUND + 40.0))
SIZE, FOCAL_PX, CELL, HALF_EXTENT = 400, 1000.0, 0.5, 120.0


def texture(X, Y):
    """Ground grey values 20..200: a smooth pattern without repeats over the scene."""
    x, y = X - ORIGIN[0], Y - ORIGIN[1]
    return 110 + 45 * np.sin(x / 7.0) * np.cos(y / 9.0) + 35 * np.sin((x + 2 * y) / 13.0)


def frame() -> OrientedFrame:
    cam = FrameCamera(FOCAL_PX / 100.0, (SIZE / 100.0, SIZE / 100.0), (SIZE, SIZE))
    return OrientedFrame(cam, ExteriorOrientation(ORIGIN[0], ORIGIN[1], GROUND + FLY, 0.0, 0.0, 0.0), "frame")


def _box_entry(C, d, box):
    """Ray parameter where rays ``C + λ d`` enter ``box`` (inf when they miss)."""
    x0, x1, y0, y1, top = box
    lo = np.array([ORIGIN[0] + x0, ORIGIN[1] + y0, GROUND - 1.0])
    hi = np.array([ORIGIN[0] + x1, ORIGIN[1] + y1, top])
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - C) / d, (hi - C) / d
    enter = np.nanmax(np.minimum(t1, t2), axis=1)
    leave = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((leave >= enter) & (leave > 0), enter, np.inf)


def render() -> np.ndarray:
    """The frame's grey values ``(SIZE, SIZE)`` uint8 (module docstring)."""
    f = frame()
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    C, d = f._rays(np.column_stack([cols.ravel() + 0.5, rows.ravel() + 0.5]))
    t_ground = (GROUND - C[2]) / d[:, 2]
    value = texture(C[0] + t_ground * d[:, 0], C[1] + t_ground * d[:, 1])
    best = t_ground.copy()
    for box in BOXES:
        t = _box_entry(C, d, box)
        hit = t < best
        P = C + t[:, None] * d
        roof = np.abs(P[:, 2] - box[4]) < 1e-6
        value = np.where(hit, np.where(roof, ROOF, WALL), value)
        best = np.minimum(best, t)
    return np.clip(np.round(value), 0, 255).astype(np.uint8).reshape(SIZE, SIZE)


def hidden_from_camera(XY, margin: float = 0.0) -> np.ndarray:
    """True where the ground point ``(X, Y, GROUND)`` cannot see the projection centre: the segment to it
    passes through a box grown by ``margin`` metres (``margin < 0`` shrinks the boxes)."""
    P = np.column_stack([XY, np.full(len(XY), GROUND + 1e-3)])
    C = frame().eo.centre
    d = C - P
    out = np.zeros(len(P), bool)
    for x0, x1, y0, y1, top in BOXES:
        box = (x0 - margin, x1 + margin, y0 - margin, y1 + margin, top + margin)
        t = _box_entry(P, d, box)
        inside = ((XY[:, 0] - ORIGIN[0] > box[0]) & (XY[:, 0] - ORIGIN[0] < box[1]) &
                  (XY[:, 1] - ORIGIN[1] > box[2]) & (XY[:, 1] - ORIGIN[1] < box[3]))
        out |= (t < 1.0) & ~inside
    return out


def on_a_box(XY, margin: float = 0.0) -> np.ndarray:
    """True where ``XY`` lies on a box's footprint grown by ``margin``."""
    x, y = XY[:, 0] - ORIGIN[0], XY[:, 1] - ORIGIN[1]
    out = np.zeros(len(XY), bool)
    for x0, x1, y0, y1, _ in BOXES:
        out |= (x > x0 - margin) & (x < x1 + margin) & (y > y0 - margin) & (y < y1 + margin)
    return out


def write_scene(folder) -> dict:
    """Write the scene's files into ``folder`` (module docstring); their paths by name."""
    import rasterio
    from affine import Affine
    d = Path(folder)
    img = render()
    paths = {k: d / n for k, n in (("frame", "frame.tif"), ("camera", "camera.yaml"), ("eo", "eo.txt"),
                                   ("dsm", "dsm.tif"), ("dem", "dem.tif"))}
    with rasterio.open(paths["frame"], "w", driver="GTiff", width=SIZE, height=SIZE, count=1, dtype="uint8") as ds:
        ds.write(img, 1)
    f = frame()
    paths["camera"].write_text(f"cam:\n  type: pinhole\n  im_size: [{SIZE}, {SIZE}]\n  focal_len: {FOCAL_PX / 100.0}\n"
                               f"  sensor_size: [{SIZE / 100.0}, {SIZE / 100.0}]\n")
    e = f.eo
    paths["eo"].write_text(f"frame {e.X} {e.Y} {e.Z} 0 0 0\n")
    n = int(2 * HALF_EXTENT / CELL)
    t = Affine(CELL, 0, ORIGIN[0] - HALF_EXTENT, 0, -CELL, ORIGIN[1] + HALF_EXTENT)
    cols, rows = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5)
    X, Y = t * (cols, rows)
    dem = np.full((n, n), GROUND, np.float32)
    dsm = dem.copy()
    for x0, x1, y0, y1, top in BOXES:
        on = ((X - ORIGIN[0] > x0) & (X - ORIGIN[0] < x1) & (Y - ORIGIN[1] > y0) & (Y - ORIGIN[1] < y1))
        dsm[on] = top
    for key, z in (("dsm", dsm), ("dem", dem)):
        with rasterio.open(paths[key], "w", driver="GTiff", width=n, height=n, count=1, dtype="float32",
                           crs="EPSG:32635", transform=t, nodata=-9999.0) as ds:
            ds.write(z, 1)
    return paths
