"""Oblique drone frame sets with a known surface that differ from :mod:`dsm_scenes` (issue 30's "held-out oblique
frames"): other gimbal pitches, nadir and oblique strips mixed, four frames converging on one point, another focal
length, more relief, frames resized by 1/4 with the camera scaled.

Each set is rendered by :func:`fotogeo.orientation.block_render.render_block` (Brown distortion, 2 DN noise) on
:func:`fotogeo.orientation.block_simulation.terrain` and written as ``fotogeo dsm`` reads it: plain GeoTIFF frames,
``camera.yaml`` (Brown, the true lens) and ``eo.txt`` (the true PATB orientations in EPSG:32633, on the zone's
central meridian: grid north = true north).

Geometry: a strip flown along ``heading`` at ``height`` m above the mean ground, the gimbal at ``pitch`` (−90°
nadir) looking along the flight; in a ``converge`` set each frame looks at the area's centre from ``lead =
height · tan(90° + pitch)`` m away in its direction. Resizing (``shrink`` k): the frame rendered at full size
is averaged over k × k pixels (``cv2.INTER_AREA``) and the camera becomes ``f/k``, principal point ``/k`` in
corner-convention pixels; Brown's coefficients act on ``x/f`` and stay.
"""
from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np

from fotogeo.geometry.attitude import patb_in_map, rotation_from_ypr
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from fotogeo.io.block import write_exterior_orientation, write_interior_orientation
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import terrain
from dsm_scenes import _write_frames
from rendered_oblique import _lonlat

CRS = "EPSG:32633"
ORIGIN = (500000.0, 4420000.0)
GROUND = 300.0
DEWARP = (-0.05, 0.015, 0.0, 0.0003, -0.0002)  # k1, k2, k3, p1, p2

#: name -> the set's parameters: strips [(heading°, pitch°, frames)], base (m between frames), height (m),
#: image size (px), focal (× width), relief (m), converge, shrink, seed; ``frames`` (names, e.g. ``["S1_01",
#: "S2_01"]``): only those frames rendered and written (the others' positions still drawn: the same set otherwise)
SETS = {
    "pitch -45, 4 headings": dict(strips=[(h, -45.0, 2) for h in (0, 90, 180, 270)], base=22.0),
    "pitch -70, 4 headings": dict(strips=[(h, -70.0, 2) for h in (0, 90, 180, 270)], base=22.0, seed=3),
    "nadir + oblique mixed": dict(strips=[(0, -90.0, 3), (90, -60.0, 3), (270, -60.0, 3)], base=22.0, seed=4),
    "converging E/S/W/N, pitch -60": dict(strips=[(h, -60.0, 1) for h in (90, 180, 270, 0)], converge=True,
                                          seed=5),
    "parallel, 2 strips N, pitch -60": dict(strips=[(0, -60.0, 4), (0, -60.0, 4)], base=18.0, side=30.0, seed=6),
    "wide lens f=0.5w, relief 25 m": dict(strips=[(h, -60.0, 3) for h in (0, 180)], base=22.0, focal=0.5,
                                         relief=25.0, seed=7),
    "1280x960 full": dict(strips=[(h, -60.0, 3) for h in (0, 90)], base=22.0, size=(1280, 960), seed=8),
    "1280x960 resized 1/4": dict(strips=[(h, -60.0, 3) for h in (0, 90)], base=22.0, size=(1280, 960), shrink=4,
                                 seed=8),
}


def _shots(rng, p: dict):
    """``[(name, centre, (yaw, pitch, roll))]`` of a set (module docstring); true attitudes 1–2° off nominal."""
    out, height = [], p["height"]
    for s, (heading, pitch, n) in enumerate(p["strips"]):
        d = np.array([math.sin(math.radians(heading)), math.cos(math.radians(heading))])
        lead = height * math.tan(math.radians(90 + pitch))
        across = np.array([d[1], -d[0]]) * p.get("side", 0.0) * (s % 2 - 0.5) * 2 if p.get("side") else 0.0
        for k in range(n):
            along = 0.0 if p.get("converge") else (k - (n - 1) / 2) * p["base"]
            xy = np.array(ORIGIN) + across + d * (along - lead) + rng.normal(0, 1.0, 2)
            ypr = (heading + rng.normal(0, 1.5), pitch + rng.normal(0, 1.0), rng.normal(0, 1.0))
            out.append((f"S{s + 1}_{k + 1:02d}", np.array([*xy, GROUND + height + rng.normal(0, 1.0)]), ypr))
    return out


def make_set(name, folder) -> dict:
    """Render and write set ``name`` of :data:`SETS` (or a dict of parameters as theirs: another set) into
    ``folder``: ``{"images", "camera", "eo", "surface", "gsd" (the nadir-distance GSD of the written frames), "crs",
    "names"}``."""
    p = {"height": 80.0, "size": (640, 480), "focal": 0.8, "relief": 8.0, "shrink": 1, "seed": 0,
         **(name if isinstance(name, dict) else SETS[name])}
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(p["seed"])
    w, h = p["size"]
    f = p["focal"] * w
    cam = FrameCamera(f, (float(w), float(h)), (w, h), (w / 2 + 0.002 * w, h / 2 - 0.003 * h))
    shots = _shots(rng, p)
    eos = [ExteriorOrientation(*c, *patb_in_map(rotation_from_ypr(*ypr), *_lonlat(c[:2], CRS), CRS))
           for _, c, ypr in shots]
    surface = terrain(rng, ORIGIN, (260.0, 260.0), GROUND, p["relief"])
    corners = np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=float)
    extent = np.vstack([OrientedFrame(cam, e).pixel_to_world_at(corners, GROUND) for e in eos])
    extent = extent[np.all(np.abs(extent[:, :2] - ORIGIN) < 400, axis=1)]  # rays near the horizon: a bounded ground
    if p.get("frames"):  # some of the set's frames only: the same shots, terrain and texture, fewer renderings
        keep = [k for k, (n, *_) in enumerate(shots) if n in p["frames"]]
        shots, eos = [shots[k] for k in keep], [eos[k] for k in keep]
    sb = SimpleNamespace(true_camera=cam, true_xyz=extent, gsd=p["height"] / f, surface=surface, true_eo=tuple(eos),
                         true_distortion=DEWARP, true_additional=())
    images, _ = render_block(sb, seed=p["seed"], noise=2.0)
    k = p["shrink"]
    if k > 1:
        images = [cv2.resize(im, (w // k, h // k), interpolation=cv2.INTER_AREA) for im in images]
        cam = FrameCamera(f / k, (w / k, h / k), (w // k, h // k), tuple(c / k for c in cam.principal_point))
    names = [n for n, *_ in shots]
    paths = _write_frames(folder, names, images)
    cam_path, eo_path = folder / "camera.yaml", folder / "eo.txt"
    k1, k2, k3, p1, p2 = DEWARP
    write_interior_orientation(cam_path, "drone", cam, {"k1": k1, "k2": k2, "k3": k3, "p1": p1, "p2": p2})
    write_exterior_orientation(eo_path, names, eos)
    return {"images": paths, "camera": cam_path, "eo": eo_path, "surface": surface, "gsd": p["height"] * k / f,
            "crs": CRS, "names": names}
