"""DJI flights as users bring them, rendered with known truth: the real sensor sizes resized after capture, more
frames than four, relief with steps, GPS with and without RTK (issues 30 and 32, held out from the building of
:mod:`fotogeo.tools.triangulate.guided` on ``tests/rendered_converging.py``).

Sensors (:data:`SENSORS`): ``p4p`` — 5472 × 3648 (3:2), focal 3648 px (8.8 mm on 13.2 mm, a Phantom 4 Pro/RTK);
``mavic`` — 4000 × 3000 (4:3), focal 2930 px (a Mavic 2/Air style ~69° field). The frames are rendered directly at the
size the user's files have (``file_size``, e.g. 1368 × 912 = 5472 / 4): the same pixels an area-averaging resize of
the full frame gives, since a pixel edge at ``x`` full-size pixels lies at ``x / factor`` (corner convention). The EXIF
``PixelXDimension``/``PixelYDimension``, the XMP ``DewarpData``, ``CalibratedFocalLength`` and
``CalibratedOpticalCenterX/Y`` (the full frame's centre, as DJI writes them) stay at full resolution.

Patterns (:func:`shots`): ``ring`` — eight obliques 30° off nadir (gimbal pitch −60°) around one place every 45° of
azimuth, looking at it, plus a 3 × 3 nadir grid over it; ``double-grid`` — four lines (two flown east then west, two
north then south) of three frames each, the gimbal at −45° (``grid``) looking along the flight. ~60 m above the ground.

Ground: Gaussian hills of ``relief`` m and ``buildings`` flat-roofed boxes ``storeys`` (5–12) m high (a DEM with
steps, 0.5 m cells; where a wall hides the ground the renderer takes one of the ray's crossings, so the views
disagree there as real occlusions do). The hills overlap: the ground may lie tens of metres below the nominal
300 m, the flight then higher above it and the obliques' axes meeting beyond the place. Each pixel is the mean of
2 × 2 rendered samples (:func:`_supersampled`).

GPS: the true centre plus ``gps_offset`` (common to all frames: a non-RTK fix's datum) plus N(0, ``gps_sigma``);
with ``rtk`` the XMP carries ``RtkFlag`` 50 and the σ, without it no RTK tag. The gimbal: the true yaw/pitch/roll
plus N(0, ``yaw_sigma``) on yaw and N(0, ``attitude_sigma``) on pitch and roll.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fotogeo.geometry.attitude import patb_in_map, rotation_from_ypr
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera
from fotogeo.geometry.dem import Dem
from fotogeo.orientation.block_simulation import terrain
from fotogeo.pixels import pixel_centres
from rendered_converging import CRS, DEWARP, GROUND, TARGET, ground, render_views, write_jpeg
from rendered_oblique import _dms, _lonlat, _xmp

#: sensor -> (full size (w, h), focal (px at full size), principal point − centre (px at full size))
SENSORS = {"p4p": ((5472, 3648), 3648.0, (14.0, -11.0)), "mavic": ((4000, 3000), 2930.0, (-9.0, 7.5))}
#: sensor -> (EXIF Model, FocalLength mm, FocalLengthIn35mmFilm mm) as the camera writes them
MODELS = {"p4p": ("FC6310R", 8.8, 24), "mavic": ("FC3170", 4.5, 24)}
HEIGHT = 60.0


def camera(sensor: str, file_size) -> FrameCamera:
    """The camera of ``sensor`` (:data:`SENSORS`) on files of ``file_size`` (scaled by file / full width)."""
    full, focal, off = SENSORS[sensor]
    s = file_size[0] / full[0]
    w, h = file_size
    return FrameCamera(focal * s, (float(w), float(h)), tuple(file_size), (w / 2 + off[0] * s, h / 2 + off[1] * s))


def shots(pattern: str, rng, off_nadir: float = 30.0, nadir: bool = True, views: int = 8, grid=(45.0, 18.0)):
    """``[(name, centre (3,), (yaw, pitch, roll))]`` of the true flight (module docstring; ``ring``: its obliques
    ``off_nadir`` degrees from the vertical, ``views`` of them evenly around, the nadir grid only with ``nadir``;
    ``double-grid``: ``grid`` = (the gimbal's degrees from the vertical, the frames' spacing along a line in m));
    1° of pitch/roll and 1.5° of yaw off the nominal gimbal, 1 m off the nominal positions."""
    out = []

    def add(name, xy, yaw, pitch):
        c = np.array([*(np.asarray(xy, float) + rng.normal(0, 1.0, 2)), GROUND + HEIGHT + rng.normal(0, 0.5)])
        out.append((name, c, (yaw + rng.normal(0, 1.5), pitch + rng.normal(0, 1.0), rng.normal(0, 1.0))))

    tx, ty = TARGET
    if pattern == "ring":
        lead = HEIGHT * math.tan(math.radians(off_nadir))
        for k in range(views):
            az = 360.0 / views * k
            d = np.array([math.sin(math.radians(az)), math.cos(math.radians(az))])
            add(f"DJI_01{k:02d}", (tx - d[0] * lead, ty - d[1] * lead), az, off_nadir - 90.0)
        for r in range(3 if nadir else 0):
            for c in range(3):
                add(f"DJI_02{3 * r + c:02d}", (tx + (c - 1) * 22.0, ty + (1 - r) * 16.0), 0.0, -90.0)
    elif pattern == "double-grid":
        lead = HEIGHT * math.tan(math.radians(grid[0]))
        k = 0
        for line, (heading, across) in enumerate(((90.0, 15.0), (270.0, -15.0), (0.0, -15.0), (180.0, 15.0))):
            d = np.array([math.sin(math.radians(heading)), math.cos(math.radians(heading))])
            side = np.array([d[1], -d[0]]) * across
            for step in (-1, 0, 1):
                xy = np.array(TARGET) + side + d * (step * grid[1] - lead)
                add(f"DJI_{line + 1}{k:03d}", xy, heading, grid[0] - 90.0)
                k += 1
    else:
        raise ValueError(pattern)
    return out


def surface_dem(rng, extent: float, relief: float, buildings: int, storeys=(5.0, 12.0), cell: float = 0.5) -> Dem:
    """Hills of ``relief`` m plus ``buildings`` boxes (8–20 m sides, ``storeys`` (lowest, highest) m high, within
    40 m of the target)."""
    from affine import Affine
    surface = terrain(rng, TARGET, (2 * extent, 2 * extent), GROUND, relief)
    n = int(2 * extent / cell)
    gx, gy = pixel_centres(n, n)
    t = Affine(cell, 0, TARGET[0] - extent, 0, -cell, TARGET[1] + extent)
    X, Y = t.c + gx * cell, t.f - gy * cell
    z = surface(np.column_stack([X.ravel(), Y.ravel()])).reshape(n, n)
    for _ in range(buildings):
        cx, cy = np.array(TARGET) + rng.uniform(-40, 40, 2)
        a, b = rng.uniform(4, 10, 2)
        inside = (abs(X - cx) < a) & (abs(Y - cy) < b)
        if inside.any():
            z[inside] = z[inside].max() + rng.uniform(*storeys)
    return Dem(z, t)


def _supersampled(sensor, file_size, eos, dem, tex, tex_t, distortion, rng, factor: int = 2) -> list:
    """The views rendered at ``factor`` times the files' size and area-averaged down: each pixel integrates its
    footprint on the ground as a sensor does (a single bilinear sample per pixel aliases the texture where an
    oblique frame's pixels cover several texels, and differently in each view)."""
    import cv2
    big = camera(sensor, (file_size[0] * factor, file_size[1] * factor))
    return [cv2.resize(img, tuple(file_size), interpolation=cv2.INTER_AREA)
            for img in render_views(big, eos, dem, tex, tex_t, distortion, rng)]


def _tags(sensor, centre, ypr, gps_sigma: float, rtk: bool):
    """EXIF and XMP of one frame, the calibration at full resolution (module docstring)."""
    (w, h), focal, off = SENSORS[sensor]
    lon, lat = _lonlat(centre[:2], CRS)
    model, focal_mm, focal_35 = MODELS[sensor]
    tags = {"EXIF_Make": "DJI", "EXIF_Model": model, "EXIF_FocalLength": f"({focal_mm:g})",
            "EXIF_FocalLengthIn35mmFilm": str(focal_35),
            "EXIF_GPSLatitude": _dms(lat), "EXIF_GPSLatitudeRef": "N", "EXIF_GPSLongitude": _dms(lon),
            "EXIF_GPSLongitudeRef": "E", "EXIF_GPSAltitude": f"({centre[2]:.3f})", "EXIF_GPSAltitudeRef": "0x00",
            "EXIF_PixelXDimension": str(w), "EXIF_PixelYDimension": str(h)}
    attrs = (f" drone-dji:AbsoluteAltitude='{centre[2]:+.3f}'"
             f" drone-dji:GimbalYawDegree='{ypr[0]:+.2f}' drone-dji:GimbalPitchDegree='{ypr[1]:+.2f}'"
             f" drone-dji:GimbalRollDegree='{ypr[2]:+.2f}' drone-dji:FlightYawDegree='{ypr[0]:+.2f}'"
             f" drone-dji:CalibratedFocalLength='{focal:.2f}' drone-dji:CalibratedOpticalCenterX='{w / 2:.2f}'"
             f" drone-dji:CalibratedOpticalCenterY='{h / 2:.2f}'")
    if rtk:
        attrs += (f" drone-dji:RtkFlag='50' drone-dji:RtkStdLon='{gps_sigma:.4f}'"
                  f" drone-dji:RtkStdLat='{gps_sigma:.4f}' drone-dji:RtkStdHgt='{1.5 * gps_sigma:.4f}'")
    dewarp = ",".join(f"{v:g}" for v in (focal, focal, *off, *DEWARP))
    return tags, _xmp(f"{attrs}><drone-dji:DewarpData>2024-01-01;{dewarp}</drone-dji:DewarpData>")


def true_orientation(sh) -> dict:
    """``{name: ExteriorOrientation}`` of :func:`shots`' flight (map CRS :data:`CRS`)."""
    truth = {}
    for name, centre, ypr in sh:
        lon, lat = _lonlat(centre[:2], CRS)
        truth[name] = ExteriorOrientation(*centre, *patb_in_map(rotation_from_ypr(*ypr), lon, lat, CRS))
    return truth


def dji_flight(folder, *, pattern: str = "ring", sensor: str = "p4p", file_size=(1368, 912), seed: int = 0,
               kind: str = "fractal", relief: float = 4.0, buildings: int = 4, storeys=(5.0, 12.0),
               off_nadir: float = 30.0, nadir: bool = True, views: int = 8, rtk: bool = True,
               xmp: bool = True, grid=(45.0, 18.0),
               gps_sigma: float = 0.02, gps_offset=(0.0, 0.0, 0.0), yaw_sigma: float = 3.0,
               attitude_sigma: float = 1.0):
    """Render and write the flight (module docstring) in ``folder`` (``xmp`` False: the EXIF only, as a resizing tool
    that drops the XMP packet leaves the files: no gimbal angles, no calibration, no RTK σ); returns
    ``{"frames": paths, "truth": {name: EO}, "names", "camera", "dem"}``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    cam = camera(sensor, file_size)
    sh = shots(pattern, rng, off_nadir, nadir, views, grid)
    truth = true_orientation(sh)
    far = 75.0 if pattern == "double-grid" or off_nadir > 35 else 62.0  # the farthest ray off nadir the frames see
    far = max(far, min(82.0, grid[0] + 27.0)) if pattern == "double-grid" else far  # the gimbal above -45°
    extent = HEIGHT * math.tan(math.radians(far)) + 60.0
    dem = surface_dem(rng, extent, relief, buildings, storeys)
    texel = max(0.1, 0.5 * HEIGHT / cam.fx)
    tex, tex_t = ground(kind, rng, extent, texel)
    k1, k2, p1, p2, k3 = DEWARP
    images = _supersampled(sensor, file_size, [truth[n] for n, *_ in sh], dem, tex, tex_t, (k1, k2, k3, p1, p2), rng)
    paths = []
    offset = np.asarray(gps_offset, float)
    for (name, centre, ypr), img in zip(sh, images):
        gps = centre + offset + rng.normal(0, gps_sigma, 3)
        att = np.asarray(ypr) + rng.normal(0, [yaw_sigma, attitude_sigma, attitude_sigma])
        tags, packet = _tags(sensor, gps, att, gps_sigma, rtk)
        paths.append(write_jpeg(folder / f"{name}.JPG", img, tags, packet if xmp else ""))
    return {"frames": paths, "truth": truth, "names": [n for n, *_ in sh], "camera": cam, "dem": dem}


def _angle(M, N) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(M.T @ N) - 1) / 2, -1.0, 1.0))))


def errors(adj: dict, truth: dict, fit: bool) -> dict:
    """The worst and median frame's centre (m) and angle (°) errors of the orientations ``adj`` against ``truth``;
    ``fit``: after the 7-parameter similarity of the adjusted centres onto the true ones
    (:func:`fotogeo.geometry.similarity3d.fit_similarity`, Umeyama 1991), its rotation applied to the attitudes."""
    from fotogeo.geometry.similarity3d import fit_similarity
    names = sorted(adj)
    C = np.array([adj[n].centre for n in names])
    T = np.array([truth[n].centre for n in names])
    sim = fit_similarity(C, T) if fit else None
    R = sim.rotation if fit else np.eye(3)
    centre = np.linalg.norm((sim.apply(C) if fit else C) - T, axis=1)
    angle = np.array([_angle(R @ adj[n].rotation, truth[n].rotation) for n in names])
    out = {"centre_max_m": float(centre.max()), "centre_median_m": float(np.median(centre)),
           "angle_max_deg": float(angle.max()), "angle_median_deg": float(np.median(angle)),
           "worst_frame": names[int(np.argmax(angle))]}
    if fit:
        out["scale_ppm"] = (sim.scale - 1) * 1e6
    return out
