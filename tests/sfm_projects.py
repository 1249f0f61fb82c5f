"""Held-out SfM projects with known truth, written as each tool writes them (issue 32; tests/test_sfm_projects.py,
benchmarks/sfm_projects_bench.py).

The truth is a rendered oblique drone block (``tests/rendered_oblique.py``) placed where the readings of an SfM
local frame part: at 60° N straddling the 18° E edge of UTM zones 33/34 (meridian convergence 2.6°), with DJI RTK
GPS (σ 2 cm) in the images' EXIF/XMP, a consumer copy (GPS 2 m off, no accuracy tags) and a copy without
GPS. The files are written from the documented formats, not with fotogeo's writers:

* COLMAP (``doc/format.rst``, ``scripts/python/read_write_model.py``): ``cameras``/``images``/``points3D`` as text or
  binary; ``x_cam = R·X + t`` with R the Hamilton quaternion (QW first); pixels with the top-left corner at (0, 0).
* OpenSfM (``opensfm/io.py``, ``geo.py``): topocentric poses at ``reference_lla`` (axis-angle world -> camera),
  cameras normalised by ``max(w, h)`` with the centre of the top-left pixel at ``(-(w-1)/2, -(h-1)/2)/max(w, h)``;
  ``gps_position`` the image GPS in the topocentric frame, ``exif/<image>.exif`` its GPS.
* ODM (``opendm/location.py``, ``osfm.py``, ``stages/run_opensfm.py``, OpenSfM's ``export_geocoords``): the UTM zone of
  the first photo, the offset ``floor(mean UTM)`` in ``odm_georeferencing/coords.txt``, ``reference_lla`` imposed at
  that offset (altitude 0); ``reconstruction.json`` holds the poses in UTM minus the offset through the linear map A of
  topocentric -> UTM at the reference (positions ``A·x + b``, rotations ``R·A⁻¹``), ``gps_position`` left topocentric,
  the topocentric file kept as ``reconstruction.topocentric.json``.
* orthority (``docs/file_formats``): GeoJSON exterior parameters (``opk`` radians, PATB), YAML interior parameters.

Each camera is projected here with its tool's own equations (:func:`tool_pixel`), so a reader's convention error shows.

This module renders the truth and measures a reading against it; the conventions are in ``tests/sfm_conventions.py``
and the writers of each tool's files in ``tests/sfm_tool_files.py``, both importable from here as before
(``sfm_projects.colmap_model``, ``sfm_projects.tool_pixel``, ...).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sfm_conventions import (D, TRUTH_CRS, _jacobian, _t, brown, ecef_to_llh, enu_axes, from_topo,  # noqa: F401
                             gps_of, llh_to_ecef, llh_to_map, map_to_llh, pose_cv, to_topo, tool_pixel, topo_pose)
from sfm_tool_files import (COLMAP_IDS, _geocoords, arbitrary_transform, colmap_model, ecef_transform,  # noqa: F401
                            enu_transform, odm_zone, opensfm_camera, opensfm_project, orthority_files,
                            other_zone_transform)

LAT, LON = 60.0, 17.99989  # 6 m west of the 18° E edge of UTM 33: the photos straddle zones 33 and 34
#: a second place, sensor and lens (``scene(place=SOUTH)``): 33° S, 6 m east of the 72° W edge of UTM zones 18/19
#: (southern and western hemispheres, convergence 1.6°), portrait 480 x 640 frames, another focal length and lens
SOUTH = {"lat": -33.0, "lon": -71.99993, "crs": "EPSG:32719", "size": (480, 640), "focal": 575.0,
         "pp_offset": (-2.5, 3.0), "dewarp": (-0.11, 0.05, -0.0006, 0.0002, -0.01)}


# -- the truth -----------------------------------------------------------------------------------------------------
def scene(folder: Path, seed: int = 3, per_strip: int = 4, place: dict | None = None) -> dict:
    """Render the block (module docstring) and its three copies of the images (rtk, consumer, bare); ``place``
    (e.g. :data:`SOUTH`): another ``lat, lon, crs`` and camera ``size, focal, pp_offset, dewarp``. The truth CRS is
    ``sc["crs"]``, the lens ``sc["dewarp"]`` (Brown's k1, k2, p1, p2, k3)."""
    import rendered_oblique as ro
    from pyproj import Transformer
    pl = {"lat": LAT, "lon": LON, "crs": TRUTH_CRS, "size": ro.SIZE, "focal": ro.FOCAL_PX, "pp_offset": ro.PP_OFFSET,
          "dewarp": ro.DEWARP, **(place or {})}
    crs = pl["crs"]
    origin = Transformer.from_crs(4326, crs, always_xy=True).transform(pl["lon"], pl["lat"])
    blk = ro.oblique_block(folder / "render", seed=seed, per_strip=per_strip, place=(crs, origin), rtk=0.02,
                           size=pl["size"], focal=pl["focal"], pp_offset=pl["pp_offset"], dewarp=pl["dewarp"])
    rng = np.random.default_rng(seed + 100)
    out = {"rtk": blk["gimbal"], "consumer": [], "bare": []}
    for kind in ("consumer", "bare"):
        (folder / kind).mkdir(parents=True, exist_ok=True)
    for p in blk["gimbal"]:
        out["consumer"].append(_retag(p, folder / "consumer" / p.name, rng, 2.0, crs))
        out["bare"].append(_retag(p, folder / "bare" / p.name, None, 0.0, crs))
    _, dem = ro.write_reference(blk, folder / "ref")
    return {**blk, **out, "dem": dem, "ground": ro.GROUND, "dewarp": pl["dewarp"], "size": tuple(pl["size"])}


def _retag(src: Path, dst: Path, rng, sigma: float, crs=TRUTH_CRS) -> Path:
    """A copy of ``src`` without RTK tags and with its GPS ``sigma`` m off (a consumer receiver), or without GPS."""
    import re

    import rasterio
    import rendered_oblique as ro
    from pyproj import Transformer
    with rasterio.open(src) as ds:
        img, tags, xmp = ds.read(1), ds.tags(), next(iter(ds.tags(ns="xml:XMP").values()))
    xmp = re.sub(r" drone-dji:Rtk\w+='[^']*'", "", xmp)
    tags = {k: v for k, v in tags.items() if not k.startswith("EXIF_GPS")}
    if rng is not None:
        lon, lat, alt = gps_of(src)
        x, y = Transformer.from_crs(4326, crs, always_xy=True).transform(lon, lat)
        t2, _ = ro._tags(np.array([x + rng.normal(0, sigma), y + rng.normal(0, sigma), alt]), (0, -60, 0), False,
                         crs)
        tags.update({k: v for k, v in t2.items() if k.startswith("EXIF_GPS")})
    ro._write(dst, img, tags, xmp)
    return dst


def shifted_gps(src: Path, dst: Path, dxy, crs=TRUTH_CRS) -> Path:
    """A copy of ``src`` whose EXIF GPS is ``dxy`` metres (east, north) off, its accuracy tags kept (a blunder)."""
    import rasterio
    import rendered_oblique as ro
    from pyproj import Transformer
    with rasterio.open(src) as ds:
        img, tags, xmp = ds.read(1), ds.tags(), next(iter(ds.tags(ns="xml:XMP").values()))
    lon, lat, alt = gps_of(src)
    x, y = Transformer.from_crs(4326, crs, always_xy=True).transform(lon, lat)
    t2, _ = ro._tags(np.array([x + dxy[0], y + dxy[1], alt]), (0, -60, 0), False, crs)
    tags.update({k: v for k, v in t2.items() if k.startswith("EXIF_GPS")})
    dst.parent.mkdir(parents=True, exist_ok=True)
    ro._write(dst, img, tags, xmp)
    return dst


def without_altitude(src: Path, dst: Path) -> Path:
    """A copy of ``src`` with its latitude and longitude but no altitude (no EXIF GPSAltitude, no DJI
    AbsoluteAltitude), as some cameras and converters write them."""
    import re

    import rasterio
    import rendered_oblique as ro
    with rasterio.open(src) as ds:
        img, tags, xmp = ds.read(1), ds.tags(), next(iter(ds.tags(ns="xml:XMP").values()))
    xmp = re.sub(r" drone-dji:\w*Altitude='[^']*'", "", xmp)
    dst.parent.mkdir(parents=True, exist_ok=True)
    ro._write(dst, img, {k: v for k, v in tags.items() if not k.startswith("EXIF_GPSAltitude")}, xmp)
    return dst


def measure(block, sc: dict, cam: dict, scale=1.0, keys=None) -> dict:
    """Orthophoto shift of ``block`` against the truth: ground points in view of every frame (on the ground height)
    are projected by the tool's camera ``cam`` (:func:`tool_pixel`, pixels times ``scale``, a factor or per axis
    ``(sx, sy)``) and the true pose, then back through fotogeo's reading onto the same height; median and p90 of the
    horizontal distances (m), the worst centre error (m) and rotation angle (°). ``keys``: the block's frame key of
    each truth name (images renamed), by default the name."""
    from fotogeo.geometry.camera import OrientedFrame
    from fotogeo.orientation.adjusted_frame import AdjustedFrame
    shifts, centre, angle = [], 0.0, 0.0
    w, h = sc["camera"].image_size
    g = np.stack(np.meshgrid(np.linspace(20, w - 20, 9), np.linspace(20, h - 20, 7)), -1).reshape(-1, 2)
    for n, e in sc["truth"].items():
        k = (keys or {}).get(n, n)
        s = block.shots.get(k)
        if s is None or s.exterior is None:
            continue
        ac = block.camera_of(k)
        read = AdjustedFrame(ac.camera, s.exterior, ac.distortion, k)
        X = OrientedFrame(sc["camera"], e).pixel_to_world_at(g, sc["ground"])
        C, R = pose_cv(e)
        back = read.inverse(tool_pixel(cam, (X - C) @ R.T) * scale, sc["ground"])
        shifts += list(np.hypot(*(back[:, :2] - X[:, :2]).T))
        centre = max(centre, float(np.linalg.norm(np.subtract(s.position, (e.X, e.Y, e.Z)))))
        Rr = s.exterior.rotation.T @ e.rotation
        angle = max(angle, math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(Rr) - 1) / 2)))))
    if not shifts:
        return {}
    sh = np.array(shifts)
    return {"median_m": float(np.median(sh)), "p90_m": float(np.percentile(sh, 90)), "centre_m": centre,
            "angle_deg": angle, "frames": len(block.shots)}


def undistorted_images(sc, folder: Path, tags: bool = False, n: int | None = None) -> list:
    """The first ``n`` RTK images undistorted to a distortion-free camera (the lens's focal length,
    the principal point at the centre), as SfM tools resample them for dense matching: written without EXIF/XMP
    (OpenSfM, ODM, COLMAP), or (``tags``) with the originals' tags and DJI ``DewarpFlag`` 1 (a camera's own)."""
    import cv2
    import rasterio
    import rendered_oblique as ro
    folder.mkdir(parents=True, exist_ok=True)
    c, (w, h) = sc["camera"], sc["size"]
    k = np.array([[c.fx, 0, c.principal_point[0] - 0.5], [0, c.fy, c.principal_point[1] - 0.5], [0, 0, 1]])
    new = np.array([[c.fx, 0, w / 2 - 0.5], [0, c.fx, h / 2 - 0.5], [0, 0, 1]])
    out = []
    for p in sc["rtk"][:n]:
        with rasterio.open(p) as ds:
            img, t, xmp = ds.read(1), ds.tags(), next(iter(ds.tags(ns="xml:XMP").values()))
        flat = cv2.undistort(img, k, np.array(sc["dewarp"], float), None, new)
        if tags:
            ro._write(folder / p.name, flat, t, xmp.replace("><drone-dji:DewarpData>",
                                                            " drone-dji:DewarpFlag='1'><drone-dji:DewarpData>"))
        else:
            with rasterio.open(folder / p.name, "w", driver="GTiff", width=w, height=h, count=1, dtype="uint8") as ds:
                ds.write(flat[None])
        out.append(folder / p.name)
    return out
