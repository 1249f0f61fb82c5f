"""A rendered oblique drone block with known truth, written as a DJI camera would write it (issue 20).

Four strips cross one area, flown north, east, south and west, the gimbal at −60° (30° off nadir)
looking along the flight, ~80 m above a terrain of ±8 m relief. Every frame is rendered through its
true camera, with Brown distortion (:func:`fotogeo.orientation.block_render.render_block`), and saved as
a GeoTIFF without georeference carrying what a DJI drone writes: EXIF GPS (the true centre plus
``gps_sigma`` m of noise, in WGS 84 from UTM 33N), and in its XMP packet the calibration
(``drone-dji:DewarpData``: fx, fy, principal-point offset, k1, k2, p1, p2, k3) and — in the ``gimbal`` copy —
the gimbal yaw/pitch/roll (the true ones plus ``attitude_sigma`` degrees of noise).

The truth: the frames' PATB orientations in EPSG:32633 (on the zone's central meridian, so the grid
is true north: no meridian convergence); the DEM the frames were rendered on is returned too.
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import rasterio

from fotogeo.geometry.attitude import patb_in_map, rotation_from_ypr
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from fotogeo.orientation.block_render import render_block
from fotogeo.orientation.block_simulation import terrain

CRS = "EPSG:32633"
ORIGIN = (500000.0, 4420000.0)  # on UTM 33N's central meridian (15° E)
GROUND = 300.0
SIZE = (640, 480)
FOCAL_PX = 520.0
PP_OFFSET = (1.5, -2.0)  # principal point − image centre (px), as DewarpData writes it
#: Brown's k1, k2, p1, p2, k3 (DJI's DewarpData order)
DEWARP = (-0.06, 0.02, 0.0004, -0.0003, 0.0)
HEADINGS = (0.0, 90.0, 180.0, 270.0)


def _camera(pp_offset=PP_OFFSET, size=SIZE, focal=FOCAL_PX) -> FrameCamera:
    w, h = size
    return FrameCamera(focal, (float(w), float(h)), tuple(size), (w / 2 + pp_offset[0], h / 2 + pp_offset[1]))


def flight(rng, per_strip: int = 5, base: float = 28.0, height: float = 80.0, pitch: float = -60.0, origin=ORIGIN):
    """``[(name, heading, centre (3,), (yaw, pitch, roll))]``: each strip passes the area's centre, its frames
    looking ahead; the true gimbal angles deviate from the nominal by 1–2°."""
    shots = []
    lead = height * math.tan(math.radians(90 + pitch))  # the camera looks this far ahead
    for s, heading in enumerate(HEADINGS):
        d = np.array([math.sin(math.radians(heading)), math.cos(math.radians(heading))])
        side = np.array([d[1], -d[0]]) * 12.0
        for k in range(per_strip):
            along = (k - (per_strip - 1) / 2) * base - lead
            xy = np.array(origin) + side + d * along + rng.normal(0, 1.0, 2)
            ypr = (heading + rng.normal(0, 2.0), pitch + rng.normal(0, 1.5), rng.normal(0, 1.0))
            shots.append((f"DJI_{s + 1}{k + 1:02d}", heading, np.array([*xy, GROUND + height + rng.normal(0, 1.0)]),
                          ypr))
    return shots


def _lonlat(xy, crs=CRS):
    from pyproj import Transformer
    return Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(*xy)


def _dms(value: float) -> str:
    v = abs(value)
    d = int(v)
    m = int((v - d) * 60)
    return f"({d}) ({m}) ({(v - d - m / 60) * 3600:.6f})"


def _xmp(body: str) -> str:
    return ("<?xpacket begin='\ufeff' id='W5M0MpCehiHzreSzNTczkc9d'?>\n<x:xmpmeta xmlns:x='adobe:ns:meta/'>"
            "<rdf:RDF xmlns:rdf='http://www.w3.org/1999/02/22-rdf-syntax-ns#'>"
            "<rdf:Description rdf:about='' xmlns:drone-dji='http://www.dji.com/drone-dji/1.0/'"
            f"{body}</rdf:Description></rdf:RDF></x:xmpmeta>\n<?xpacket end='w'?>")


def _tags(centre, ypr, gimbal: bool, crs=CRS, rtk=None, lens=(PP_OFFSET, DEWARP), calibration=True, focal=FOCAL_PX):
    """EXIF and XMP of one frame; without ``calibration`` what a camera without one writes: the
    ``FocalLengthIn35mmFilm`` (28 mm, rounded as EXIF's integer is) and no ``DewarpData``."""
    lon, lat = _lonlat(centre[:2], crs)
    tags = {"EXIF_Make": "DJI", "EXIF_Model": "FC-render", "EXIF_GPSLatitude": _dms(lat),
            "EXIF_GPSLatitudeRef": "N" if lat >= 0 else "S", "EXIF_GPSLongitude": _dms(lon),
            "EXIF_GPSLongitudeRef": "E" if lon >= 0 else "W", "EXIF_GPSAltitude": f"({centre[2]:.3f})",
            "EXIF_GPSAltitudeRef": "0x00"}
    attrs = f" drone-dji:AbsoluteAltitude='{centre[2]:+.3f}'"
    if rtk is not None:  # a DJI RTK aircraft's fix and its standard deviations
        attrs += (f" drone-dji:RtkFlag='50' drone-dji:RtkStdLon='{rtk:.4f}' drone-dji:RtkStdLat='{rtk:.4f}'"
                  f" drone-dji:RtkStdHgt='{1.5 * rtk:.4f}'")
    if gimbal:
        attrs += (f" drone-dji:GimbalYawDegree='{ypr[0]:+.2f}' drone-dji:GimbalPitchDegree='{ypr[1]:+.2f}'"
                  f" drone-dji:GimbalRollDegree='{ypr[2]:+.2f}'")
    if not calibration:
        return {**tags, "EXIF_FocalLengthIn35mmFilm": "28"}, _xmp(f"{attrs}>")
    dewarp = ",".join(f"{v:g}" for v in (focal, focal, *lens[0], *lens[1]))
    return tags, _xmp(f"{attrs}><drone-dji:DewarpData>2024-01-01;{dewarp}</drone-dji:DewarpData>")


def _write(path, img, tags, xmp):
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(path, "w", driver="GTiff", width=img.shape[1], height=img.shape[0], count=1,
                           dtype="uint8") as ds:
            ds.write(img[None])
            ds.update_tags(**tags)
            head, tail = xmp.split("=", 1)  # rasterio writes "key=value": the packet itself
            ds.update_tags(ns="xml:XMP", **{head: tail})


def oblique_block(folder, *, seed: int = 0, gps_sigma: float = 2.0, attitude_sigma: float = 5.0,
                  per_strip: int = 5, place=None, rtk=None, calibration: bool = True, pp_offset=PP_OFFSET,
                  dewarp=DEWARP, size=SIZE, focal=FOCAL_PX):
    """Render the block and write it twice (module docstring): ``folder/gimbal`` with the gimbal angles in the
    XMP, ``folder/nadir`` without (the same pixels, GPS and calibration); returns ``{"gimbal": paths, "nadir":
    paths, "truth": {name: EO}, "names", "gsd", "dem", "camera", "crs"}``. ``place``: ``(CRS, origin)`` elsewhere than
    the default's; ``rtk``: the GPS σ (m) of a DJI RTK fix, written in the XMP (then ``gps_sigma`` is that);
    ``pp_offset`` and ``dewarp``: the lens (principal point − image centre in px; Brown's k1, k2, p1, p2, k3);
    ``calibration`` False: the files carry no calibration, only ``FocalLengthIn35mmFilm`` (:func:`_tags`);
    ``size`` (w, h) and ``focal`` (px): another sensor (a portrait frame: h > w)."""
    crs, origin = place or (CRS, ORIGIN)
    gps_sigma = gps_sigma if rtk is None else rtk
    rng = np.random.default_rng(seed)
    cam = _camera(pp_offset, size, focal)
    shots = flight(rng, per_strip, origin=origin)
    truth = {}
    for name, _, centre, ypr in shots:
        lon, lat = _lonlat(centre[:2], crs)
        truth[name] = ExteriorOrientation(*centre, *patb_in_map(rotation_from_ypr(*ypr), lon, lat, crs))
    surface = terrain(rng, origin, (260.0, 260.0), GROUND, 8.0)
    frames = [OrientedFrame(cam, truth[n]) for n, *_ in shots]
    corners = np.array([[0, 0], [size[0], 0], [size[0], size[1]], [0, size[1]]], dtype=float)
    extent = np.vstack([f.pixel_to_world_at(corners, GROUND) for f in frames])
    gsd = 80.0 / focal
    k1, k2, p1, p2, k3 = dewarp
    sb = SimpleNamespace(true_camera=cam, true_xyz=extent, gsd=gsd, surface=surface,
                         true_eo=tuple(truth[n] for n, *_ in shots), true_distortion=(k1, k2, k3, p1, p2),
                         true_additional=())
    images, dem = render_block(sb, seed=seed, noise=2.0)
    paths = {"gimbal": [], "nadir": []}
    for kind in paths:
        (folder / kind).mkdir(parents=True, exist_ok=True)
    for (name, _, centre, ypr), img in zip(shots, images):
        gps = centre + np.array([*rng.normal(0, gps_sigma, 2), rng.normal(0, gps_sigma)])
        noisy = tuple(np.asarray(ypr) + rng.normal(0, attitude_sigma, 3))
        for kind in paths:
            path = folder / kind / f"{name}.tif"
            _write(path, img, *_tags(gps, noisy, kind == "gimbal", crs, rtk, (pp_offset, dewarp), calibration, focal))
            paths[kind].append(path)
    return {**paths, "truth": truth, "names": [n for n, *_ in shots], "gsd": gsd, "dem": dem, "camera": cam, "sb": sb,
            "seed": seed, "crs": crs}


def write_reference(block, folder, *, factor: int = 4) -> tuple:
    """``(orthophoto, DEM)`` GeoTIFF paths in ``folder`` (EPSG:32633): the ground texture the frames were
    rendered from, averaged over ``factor`` × ``factor`` cells (``factor`` 4: twice the nadir GSD of the
    frames, a reference coarser than the frames as a real one is), and the DEM they were rendered on."""
    import cv2
    from fotogeo.orientation.block_render import ground_texture
    tex, t = ground_texture(block["sb"], seed=block["seed"])
    rows, cols = tex.shape[0] // factor, tex.shape[1] // factor
    img = cv2.resize(tex[:rows * factor, :cols * factor], (cols, rows), interpolation=cv2.INTER_AREA)
    folder.mkdir(parents=True, exist_ok=True)
    ortho, dem_path = folder / "ortho.tif", folder / "dem.tif"
    crs = block.get("crs", CRS)
    with rasterio.open(ortho, "w", driver="GTiff", width=cols, height=rows, count=1, dtype="uint8", crs=crs,
                       transform=t * t.scale(factor)) as ds:
        ds.write(np.clip(np.round(img), 1, 255).astype(np.uint8)[None])
    dem = block["dem"]
    with rasterio.open(dem_path, "w", driver="GTiff", width=dem.data.shape[1], height=dem.data.shape[0], count=1,
                       dtype="float32", crs=crs, transform=dem.transform) as ds:
        ds.write(dem.data.astype(np.float32)[None])
    return ortho, dem_path


def angle_error(a: ExteriorOrientation, b: ExteriorOrientation) -> float:
    """The angle (degrees) of the rotation between two orientations (independent of the Euler angles)."""
    R = a.rotation.T @ b.rotation
    return math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(R) - 1) / 2))))
