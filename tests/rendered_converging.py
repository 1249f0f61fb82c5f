"""Four converging oblique drone frames with known truth: a camera looking east, south, west and north at one
target point, written as DJI JPEGs (EXIF GPS, XMP gimbal angles and ``DewarpData``), full size and resized.

The common façade/mapping pattern of converging obliques: the four view directions differ by 90° and 180°,
so the ground seen by two frames is scaled, sheared and turned by up to 180° between them. Each frame is
rendered through its true camera (Brown distortion, :func:`render_views`) on a terrain of gentle relief, on one
of two ground textures: ``"fractal"`` (the block renderer's, :func:`fotogeo.orientation.block_render.texture`)
or ``"ngi"`` (a real orthophoto of ``../shared/data/ngi`` stretched to 8 cm texels: other content, other
statistics — the held-out scene). ``off_nadir`` is the camera's angle from the vertical (30°: DJI gimbal
pitch −60°; 45°: −45°).

The truth: PATB orientations in EPSG:32633 on the zone's central meridian (grid north = true north). The GPS
in the files is the true centre plus ``gps_sigma`` (an RTK fix, its σ written in the XMP); the gimbal angles the
true ones plus ``attitude_sigma`` degrees of noise.
"""
from __future__ import annotations

import math
import struct
import warnings
from pathlib import Path

import numpy as np
import rasterio
import rasterio.shutil

from fotogeo.geometry.attitude import patb_in_map, rotation_from_ypr
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from fotogeo.geometry.dem import Dem
from fotogeo.orientation import bundle_jacobian as bj
from fotogeo.orientation.block_render import texture
from fotogeo.orientation.block_simulation import terrain, true_interior
from fotogeo.pixels import pixel_centres, to_centre
from conftest import DATA
from rendered_oblique import _dms, _lonlat, _xmp

CRS = "EPSG:32633"
TARGET = (500000.0, 4420000.0)
GROUND = 300.0
DEWARP = (-0.05, 0.015, 0.0003, -0.0002, 0.0)  # k1, k2, p1, p2, k3
VIEWS = (("E", 90.0), ("S", 180.0), ("W", 270.0), ("N", 0.0))
NGI_ORTHO = DATA / "ngi" / "ortho" / "ngi_rgb_byte_1.tif"
#: the grounds taken from real images (the ``kind`` of :func:`ground`); ``qb2``: a QuickBird chip, another sensor
REAL_GROUNDS = {"ngi": NGI_ORTHO, "qb2": DATA / "qb2" / "qb2_basic1b.tif"}


def camera(size) -> FrameCamera:
    """A DJI-like camera for frames of ``size``: focal 0.75 × width (a ~67° horizontal field)."""
    w, h = size
    f = 0.75 * w
    return FrameCamera(f, (float(w), float(h)), tuple(size), (w / 2 + 0.003 * w, h / 2 - 0.004 * h))


def shots(rng, off_nadir: float, height: float = 60.0):
    """``[(name, centre (3,), (yaw, pitch, roll))]``: one frame per view direction, aimed at the target."""
    out = []
    lead = height * math.tan(math.radians(off_nadir))
    for k, (label, az) in enumerate(VIEWS):
        d = np.array([math.sin(math.radians(az)), math.cos(math.radians(az))])
        xy = np.array(TARGET) - d * lead + rng.normal(0, 1.0, 2)
        ypr = (az + rng.normal(0, 1.5), off_nadir - 90.0 + rng.normal(0, 1.0), rng.normal(0, 1.0))
        out.append((f"DJI_000{k + 1}_{label}", np.array([*xy, GROUND + height + rng.normal(0, 0.5)]), ypr))
    return out


def ground(kind: str, rng, extent: float, texel: float):
    """``(texture float32, Affine)`` centred on the target: ``"fractal"``, or a chip of a real image (``"ngi"``,
    ``"qb2"``: :data:`REAL_GROUNDS`; module docstring)."""
    from affine import Affine
    n = int(2 * extent / texel)
    t = Affine(texel, 0, TARGET[0] - extent, 0, -texel, TARGET[1] + extent)
    if kind == "fractal":
        return texture(rng, (n, n)), t
    import cv2
    with rasterio.open(REAL_GROUNDS[kind]) as ds:
        img = ds.read().astype(np.float32).mean(axis=0)
    r0, c0 = img.shape[0] // 4, img.shape[1] // 8
    chip = img[r0:r0 + 600, c0:c0 + 600]
    chip = cv2.resize(chip, (n, n), interpolation=cv2.INTER_CUBIC)
    chip = (chip - chip.mean()) / (chip.std() + 1e-6) * 45 + 128
    return np.clip(chip, 1, 255).astype(np.float32), t


def render_views(cam, eos, dem, tex, tex_t, distortion, rng, noise: float = 2.0) -> list:
    """One uint8 image per orientation: each pixel's ray (distortion removed) met with the DEM, the texture
    sampled there (as :func:`fotogeo.orientation.block_render.render_block`, on a given texture)."""
    import cv2
    interior = true_interior(cam, distortion, ())
    scale = bj.pixel_scale(cam)
    ideal_cam = FrameCamera(cam.focal_length, cam.sensor_size, cam.image_size, cam.principal_point)
    w, h = cam.image_size
    cx, cy = pixel_centres(w, h)
    rays = bj.undistort_rays(np.column_stack([cx.ravel(), cy.ravel()]), interior, scale)
    ideal = np.column_stack([cam.principal_point[0] + cam.fx * rays[:, 0], cam.principal_point[1] + cam.fy * rays[:, 1]])
    images = []
    for eo in eos:
        g = OrientedFrame(ideal_cam, eo).pixel_to_world(ideal, dem)
        m = to_centre(np.column_stack([(g[:, 0] - tex_t.c) / tex_t.a, (tex_t.f - g[:, 1]) / tex_t.a]))
        m = m.astype(np.float32)
        m[~np.isfinite(m)] = -1.0
        img = cv2.remap(tex, m[:, 0].reshape(h, w), m[:, 1].reshape(h, w), cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        img = img + rng.normal(0, noise, img.shape).astype(np.float32)
        images.append(np.clip(np.round(img), 1, 255).astype(np.uint8))
    return images


def _tags(cam, full, centre, ypr, rtk: float):
    lon, lat = _lonlat(centre[:2], CRS)
    tags = {"EXIF_Make": "DJI", "EXIF_Model": "FC-render", "EXIF_GPSLatitude": _dms(lat),
            "EXIF_GPSLatitudeRef": "N", "EXIF_GPSLongitude": _dms(lon), "EXIF_GPSLongitudeRef": "E",
            "EXIF_GPSAltitude": f"({centre[2]:.3f})", "EXIF_GPSAltitudeRef": "0x00",
            "EXIF_PixelXDimension": str(full[0]), "EXIF_PixelYDimension": str(full[1])}
    attrs = (f" drone-dji:AbsoluteAltitude='{centre[2]:+.3f}' drone-dji:RtkFlag='50'"
             f" drone-dji:RtkStdLon='{rtk:.4f}' drone-dji:RtkStdLat='{rtk:.4f}' drone-dji:RtkStdHgt='{1.5 * rtk:.4f}'"
             f" drone-dji:GimbalYawDegree='{ypr[0]:+.2f}' drone-dji:GimbalPitchDegree='{ypr[1]:+.2f}'"
             f" drone-dji:GimbalRollDegree='{ypr[2]:+.2f}' drone-dji:FlightYawDegree='{ypr[0]:+.2f}'")
    off = (cam.principal_point[0] - full[0] / 2, cam.principal_point[1] - full[1] / 2)
    dewarp = ",".join(f"{v:g}" for v in (cam.fx, cam.fy, *off, *DEWARP))
    return tags, _xmp(f"{attrs}><drone-dji:DewarpData>2024-01-01;{dewarp}</drone-dji:DewarpData>")


def write_jpeg(path: Path, img, tags: dict, xmp: str) -> Path:
    """An RGB JPEG of the grey ``img`` with EXIF (GDAL writes the segment) and the XMP APP1 packet added (none when
    ``xmp`` is empty)."""
    tif = path.with_suffix(".tmp.tif")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(tif, "w", driver="GTiff", width=img.shape[1], height=img.shape[0], count=3,
                           dtype="uint8") as ds:
            ds.write(np.repeat(img[None], 3, axis=0))
            ds.update_tags(**tags)
        rasterio.shutil.copy(tif, path, driver="JPEG", QUALITY=95)
    tif.unlink()
    for aux in path.parent.glob(path.name + ".aux.xml"):
        aux.unlink()
    if not xmp:  # what a tool that keeps the EXIF only leaves (PIL's save(exif=...))
        return path
    data = path.read_bytes()
    payload = b"http://ns.adobe.com/xap/1.0/\x00" + xmp.encode()
    path.write_bytes(data[:2] + b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload + data[2:])
    return path


def converging_block(folder, *, off_nadir: float = 30.0, size=(600, 400), kind: str = "fractal", seed: int = 0,
                     relief: float = 3.0, resize: int = 0, gps_sigma: float = 0.02, attitude_sigma: float = 3.0,
                     unrelated: str | None = None):
    """Render and write the four frames (module docstring) in ``folder``; with ``resize`` > 1 also their copies
    downsampled by that factor (EXIF/XMP kept: ``PixelXDimension`` and ``DewarpData`` at full size) in
    ``folder/resized``. ``unrelated``: the view (``"E"``…) whose pixels are replaced by grey noise (a frame over
    ground no other frame shows: nothing to tie). Returns ``{"full": paths, "resized": paths, "truth": {name: EO}, "names", "camera"}``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    cam = camera(size)
    sh = shots(rng, off_nadir)
    truth = {}
    for name, centre, ypr in sh:
        lon, lat = _lonlat(centre[:2], CRS)
        truth[name] = ExteriorOrientation(*centre, *patb_in_map(rotation_from_ypr(*ypr), lon, lat, CRS))
    extent = 60.0 * math.tan(math.radians(off_nadir)) + 120.0
    surface = terrain(rng, TARGET, (2 * extent, 2 * extent), GROUND, relief)
    cell = 1.0
    n = int(2 * extent / cell)
    gx, gy = pixel_centres(n, n)
    from affine import Affine
    dem_t = Affine(cell, 0, TARGET[0] - extent, 0, -cell, TARGET[1] + extent)
    dem = Dem(surface(np.column_stack([dem_t.c + gx.ravel() * cell, dem_t.f - gy.ravel() * cell])).reshape(n, n),
              dem_t)
    tex, tex_t = ground(kind, rng, extent, 0.1)
    k1, k2, p1, p2, k3 = DEWARP
    images = render_views(cam, [truth[n] for n, *_ in sh], dem, tex, tex_t, (k1, k2, k3, p1, p2), rng)
    full, small = [], []
    for (name, centre, ypr), img in zip(sh, images):
        if unrelated and name.endswith(f"_{unrelated}"):
            img = np.clip(rng.normal(128, 40, img.shape), 1, 255).astype(np.uint8)
        gps = centre + rng.normal(0, gps_sigma, 3)
        att = np.asarray(ypr) + rng.normal(0, attitude_sigma, 3)
        path = write_jpeg(folder / f"{name}.JPG", img, *_tags(cam, size, gps, att, gps_sigma))
        full.append(path)
        if resize and resize > 1:
            from jpeg_metadata import resized_copy
            (folder / "resized").mkdir(exist_ok=True)
            small.append(resized_copy(path, folder / "resized" / f"{name}.JPG", resize))
    return {"full": full, "resized": small, "truth": truth, "names": [n for n, *_ in sh], "camera": cam, "dem": dem}
