"""Rendered frame blocks with a known surface, written as ``fotogeo dsm`` reads them (frames, camera YAML, the
true exterior orientation), and the comparison of a DSM with the truth.

Three renders that differ (:data:`SCENES`): ``nadir`` — the demo's block (2 strips x 4 frames, 400 x 600 px,
1000 m above ±40 m of relief, no distortion); ``oblique`` — the DJI-like block of
:mod:`tests.rendered_oblique` (30° off nadir, Brown distortion, three frames per strip, four headings);
``held_out`` — a block never used while building the pipeline (3 strips x 3 frames, 520 x 390 px, 700 m above
±60 m, 70 % forward overlap, Brown distortion, another seed). ``nadir_block``: two nadir frames (800 x 1200 px,
1000 m above hills of ±:data:`BLOCK_RELIEF` m) with a flat-roofed block (:data:`BLOCK`) standing in their overlap: a
DEM of the ground (:func:`write_dem` of the ``surface``'s ``ground``) lies under its roof; ``nadir_narrow_block``: the
same pair with a block narrower than it is high (:data:`NARROW_BLOCK`). ``nadir_lake``: the ``nadir`` block with its
ground texture a constant grey (:data:`UNIFORM_GREY`) over a disc (:data:`LAKE`; every frame sees it uniform, each
with its own noise: water, a bare grey field); ``nadir_grey_patch``: the ``nadir`` block with a rectangle of every
other frame (:data:`GREY_PATCH`) a constant grey plus the frame's noise (a cloud, a reflection, a saturated roof
in one view only). The scene's ``region`` (XY → bool) is the lake's ground (None for the patch: the cells it
touches depend on the pair).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import rasterio

from fotogeo.geometry.camera import FrameCamera
from fotogeo.io.block import write_exterior_orientation, write_interior_orientation

SCENES = ("nadir", "oblique", "held_out")
#: ``nadir_block``: the block's side and height over the ground (m), and its centre's offset (m, east, north) from
#: the middle of the two frames' centres (:func:`with_block`); the ground's hills are ±``BLOCK_RELIEF`` m
BLOCK = (60.0, 30.0, 150.0, 0.0)
#: ``nadir_narrow_block``: a block as :data:`BLOCK`, 12 m a side
NARROW_BLOCK = (12.0, 30.0, 150.0, 0.0)
BLOCK_RELIEF = 5.0
#: ``nadir_lake``: the disc of uniform ground (m: radius, and its centre's offset east, north from the middle of the
#: frames' centres)
LAKE = (160.0, 60.0, -40.0)
#: ``nadir_grey_patch``: the rectangle (first row, last row, first column, last column) uniform in every other frame
GREY_PATCH = (150, 330, 120, 300)
#: the grey of the uniform areas (before the frames' noise)
UNIFORM_GREY = 120.0


def _write_frames(folder: Path, names, images) -> list:
    paths = []
    for name, img in zip(names, images):
        p = folder / f"{name}.tif"
        with rasterio.open(p, "w", driver="GTiff", width=img.shape[1], height=img.shape[0], count=1,
                           dtype="uint8") as ds:
            ds.write(img[None])
        paths.append(p)
    return paths


def _distortion(t) -> dict:
    k1, k2, k3, p1, p2 = t
    return {"k1": k1, "k2": k2, "k3": k3, "p1": p1, "p2": p2}


def with_block(surface, centre, side: float, height: float):
    """``surface`` (XY → Z) with a flat-roofed block of ``side`` m a side centred on ``centre`` (XY), its roof
    ``height`` m over the ground at the centre; the block's ``roof`` height is an attribute of the result."""
    roof = float(surface(np.asarray(centre, float)[None])[0]) + height

    def blocked(XY):
        XY = np.asarray(XY, float).reshape(-1, 2)
        on = (np.abs(XY - np.asarray(centre, float)) <= side / 2).all(axis=1)
        return np.where(on, roof, surface(XY))
    blocked.roof, blocked.ground, blocked.centre, blocked.side = roof, surface, tuple(centre), side
    return blocked


def _lake(sb, lake):
    """``(region, texture maker)``: the disc ``lake`` (:data:`LAKE`) around the middle of ``sb``'s frame centres
    (XY → bool) and a replacement of :mod:`~fotogeo.orientation.block_render`'s ``_texture`` that paints it
    :data:`UNIFORM_GREY`."""
    from fotogeo.orientation import block_render
    c = np.mean([[e.X, e.Y] for e in sb.true_eo], axis=0) + lake[1:]

    def region(XY):
        return np.hypot(*(np.asarray(XY, float).reshape(-1, 2) - c).T) <= lake[0]

    original = block_render._texture

    def painted(sb_, rng, texture_pixel):
        tex, t = original(sb_, rng, texture_pixel)
        rows, cols = np.indices(tex.shape)
        tex[region(np.column_stack([t.c + (cols.ravel() + 0.5) * t.a, t.f + (rows.ravel() + 0.5) * t.e]))
            .reshape(tex.shape)] = UNIFORM_GREY
        return tex, t
    return region, painted


def _simulated(folder: Path, block=None, lake=None, patch=None, **kw) -> dict:
    """A simulated block rendered into ``folder``; ``block`` (:data:`BLOCK`): a block (:func:`with_block`) near the
    middle of the first two frames' overlap; ``lake`` (:data:`LAKE`): uniform ground (:func:`_lake`); ``patch``
    (:data:`GREY_PATCH`): a rectangle of every other frame uniform grey plus noise (the render's 2 levels)."""
    import dataclasses
    from unittest import mock

    from fotogeo.orientation import block_render
    from fotogeo.orientation.block_simulation import simulate_block
    sb = simulate_block(blunder_fraction=0.0, n_control=4, n_check=4, **kw)
    if block is not None:
        c = np.mean([[e.X, e.Y] for e in sb.true_eo[:2]], axis=0) + block[2:]
        sb = dataclasses.replace(sb, surface=with_block(sb.surface, c, *block[:2]))
    region = None
    if lake is not None:
        region, painted = _lake(sb, lake)
        with mock.patch.object(block_render, "_texture", painted):
            images, _ = block_render.render_block(sb, seed=kw.get("seed", 0))
    else:
        images, _ = block_render.render_block(sb, seed=kw.get("seed", 0))
    if patch is not None:
        rng = np.random.default_rng(99)
        r0, r1, c0, c1 = patch
        for img in images[::2]:
            grey = UNIFORM_GREY + rng.normal(0, 2.0, (r1 - r0, c1 - c0))
            img[r0:r1, c0:c1] = np.clip(np.round(grey), 1, 255).astype(np.uint8)
    names = sb.block.frames
    paths = _write_frames(folder, names, images)
    cam, eo = folder / "camera.yaml", folder / "eo.txt"
    write_interior_orientation(cam, "cam", sb.true_camera, _distortion(sb.true_distortion))
    write_exterior_orientation(eo, names, sb.true_eo)
    return {"images": paths, "camera": cam, "eo": eo, "surface": sb.surface, "gsd": sb.gsd, "crs": "EPSG:32635",
            "region": region}


def _oblique(folder: Path) -> dict:
    from tests.rendered_oblique import CRS, DEWARP, oblique_block
    b = oblique_block(folder, seed=0, per_strip=3)
    cam, eo = folder / "camera.yaml", folder / "eo.txt"
    k1, k2, p1, p2, k3 = DEWARP
    write_interior_orientation(cam, "dji", b["camera"], {"k1": k1, "k2": k2, "k3": k3, "p1": p1, "p2": p2})
    write_exterior_orientation(eo, b["names"], [b["truth"][n] for n in b["names"]])
    return {"images": b["nadir"], "camera": cam, "eo": eo, "surface": b["sb"].surface, "gsd": b["gsd"], "crs": CRS}


def make_scene(kind: str, folder) -> dict:
    """Write the scene ``kind`` into ``folder``: ``{"images", "camera", "eo", "surface" (XY → Z), "gsd", "crs"}``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    if kind in ("nadir", "nadir_lake", "nadir_grey_patch"):
        return _simulated(folder, seed=7, strips=2, frames_per_strip=4, camera=FrameCamera(6.0, (4.0, 6.0), (400, 600)),
                          point_spacing=80.0, relief=40.0, margin=5.0, lake=LAKE if kind == "nadir_lake" else None,
                          patch=GREY_PATCH if kind == "nadir_grey_patch" else None)
    if kind in ("nadir_block", "nadir_narrow_block"):
        return _simulated(folder, block=BLOCK if kind == "nadir_block" else NARROW_BLOCK, seed=7, strips=1,
                          frames_per_strip=2,
                          camera=FrameCamera(12.0, (8.0, 12.0), (800, 1200)), point_spacing=80.0, relief=BLOCK_RELIEF,
                          margin=5.0)
    if kind == "oblique":
        return _oblique(folder)
    if kind == "held_out":
        return _simulated(folder, seed=11, strips=3, frames_per_strip=3, forward_overlap=0.7, side_overlap=0.35,
                          camera=FrameCamera(5.2, (5.2, 3.9), (520, 390)), flying_height=700.0, relief=60.0,
                          point_spacing=60.0, margin=5.0, true_distortion=(-0.04, 0.01, 0.0, 0.0003, -0.0002))
    raise ValueError(kind)


def write_dem(sc: dict, path, *, cell: float = 20.0, margin: float = 1500.0) -> Path:
    """A DEM GeoTIFF of the scene's true surface (``cell`` m) over its projection centres ± ``margin``."""
    from rasterio.transform import from_origin
    xy = np.array([[float(v) for v in line.split()[1:3]] for line in Path(sc["eo"]).read_text().splitlines()
                   if line and not line.startswith("#")])
    x0, y1 = xy.min(axis=0) - margin
    x1, y0 = xy.max(axis=0) + margin
    cols, rows = int((x1 - x0) / cell), int((y0 - y1) / cell)
    X, Y = np.meshgrid(x0 + (np.arange(cols) + 0.5) * cell, y0 - (np.arange(rows) + 0.5) * cell)
    z = sc["surface"](np.column_stack([X.ravel(), Y.ravel()])).reshape(rows, cols)
    with rasterio.open(path, "w", driver="GTiff", width=cols, height=rows, count=1, dtype="float32", crs=sc["crs"],
                       transform=from_origin(x0, y0, cell, cell)) as ds:
        ds.write(z.astype(np.float32)[None])
    return Path(path)


def compare(dsm_path, surface, *, edge: int = 0) -> dict:
    """Heights of the DSM against the true ``surface`` at its cell centres: RMSE, NMAD, median, the share within
    1 and 2 GSD is left to the caller; ``n`` the valid cells, ``cells`` all cells."""
    with rasterio.open(dsm_path) as ds:
        h = ds.read(1).astype(float)
        t, nod = ds.transform, ds.nodata
    rows, cols = np.indices(h.shape)
    X = t.c + (cols + 0.5) * t.a
    Y = t.f + (rows + 0.5) * t.e
    valid = h != nod
    truth = surface(np.column_stack([X[valid], Y[valid]]))
    d = h[valid] - truth
    med = float(np.median(d))
    return {"n": int(valid.sum()), "cells": int(h.size), "rmse": float(np.sqrt(np.mean(d ** 2))),
            "median": med, "nmad": float(1.4826 * np.median(np.abs(d - med))), "abs": np.abs(d)}


def turned_eo(eo: Path, name: str, dk: float, out: Path) -> Path:
    """The orientation file ``eo`` with frame ``name``'s κ (the last column) turned by ``dk`` degrees, written to
    ``out``: its pairs pass the pair choice (the footprints barely move) and are refused when set up."""
    rows = []
    for line in eo.read_text().splitlines():
        f = line.split()
        if f and f[0] == name:
            f[-1] = f"{float(f[-1]) + dk:.8f}"
        rows.append(" ".join(f))
    out.write_text("\n".join(rows) + "\n")
    return out
