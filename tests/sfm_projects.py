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
"""
from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np


LAT, LON = 60.0, 17.99989  # 6 m west of the 18° E edge of UTM 33: the photos straddle zones 33 and 34
TRUTH_CRS = "EPSG:32633"
D = np.diag([1.0, -1.0, -1.0])
COLMAP_IDS = {"SIMPLE_PINHOLE": 0, "PINHOLE": 1, "SIMPLE_RADIAL": 2, "RADIAL": 3, "OPENCV": 4, "OPENCV_FISHEYE": 5,
              "FULL_OPENCV": 6, "FOV": 7, "SIMPLE_RADIAL_FISHEYE": 8, "RADIAL_FISHEYE": 9, "THIN_PRISM_FISHEYE": 10,
              "RAD_TAN_THIN_PRISM_FISHEYE": 11}
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


def gps_of(path) -> tuple:
    from fotogeo.io.exif import read_image_metadata
    m = read_image_metadata(str(path))
    assert m.altitude is not None, f"{path} carries no GPS altitude: a test project needs one (never taken as 0)"
    return float(m.lon), float(m.lat), float(m.altitude)


def pose_cv(eo) -> tuple:
    """``(C, R_wc)``: centre and world -> OpenCV-camera rotation in the map CRS of a PATB orientation."""
    return np.array([eo.X, eo.Y, eo.Z]), (eo.rotation @ D).T


# -- the cameras, each with its tool's equations -------------------------------------------------------------------
def brown(u, v, k1=0.0, k2=0.0, k3=0.0, p1=0.0, p2=0.0, k4=0.0, k5=0.0, k6=0.0):
    """OpenCV's distortion (COLMAP OPENCV/FULL_OPENCV, OpenSfM brown, orthority brown/opencv) of
    ``(u, v) = (x/z, y/z)``."""
    r2 = u * u + v * v
    rad = (1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3) / (1 + k4 * r2 + k5 * r2 ** 2 + k6 * r2 ** 3)
    return u * rad + 2 * p1 * u * v + p2 * (r2 + 2 * u * u), v * rad + p1 * (r2 + 2 * v * v) + 2 * p2 * u * v


def tool_pixel(cam: dict, xc: np.ndarray) -> np.ndarray:
    """Pixels (top-left corner at (0, 0)) of camera points ``xc`` (OpenCV axes) through ``cam`` as its tool defines it:
    ``{"tool": "colmap", "model", "params"}``, ``{"tool": "opensfm", ...camera dict}`` or
    ``{"tool": "orthority", ...}``."""
    u, v = xc[:, 0] / xc[:, 2], xc[:, 1] / xc[:, 2]
    if cam["tool"] == "colmap":
        p = cam["params"]
        m = cam["model"]
        if m in ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL"):
            f, cx, cy = p[:3]
            k = list(p[3:]) + [0.0, 0.0]
            r2 = u * u + v * v
            rad = 1 + k[0] * r2 + k[1] * r2 ** 2
            return np.column_stack([f * u * rad + cx, f * v * rad + cy])
        fx, fy, cx, cy = p[:4]
        names = {"PINHOLE": (), "OPENCV": ("k1", "k2", "p1", "p2"),
                 "FULL_OPENCV": ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")}[m]
        du, dv = brown(u, v, **dict(zip(names, p[4:])))
        return np.column_stack([fx * du + cx, fy * dv + cy])
    w, h = cam["width"], cam["height"]
    m = max(w, h)
    if cam["tool"] == "opensfm":  # normalised coordinates, (0, 0) at the centre, pixel centres at (i - (w-1)/2)/m
        fx = cam.get("focal_x", cam.get("focal"))
        fy = cam.get("focal_y", fx)
        du, dv = brown(u, v, *(cam.get(k, 0.0) for k in ("k1", "k2", "k3", "p1", "p2")))
        xn, yn = fx * du + cam.get("c_x", 0.0), fy * dv + cam.get("c_y", 0.0)
        return np.column_stack([xn * m + (w - 1) / 2 + 0.5, yn * m + (h - 1) / 2 + 0.5])
    # orthority: focal_len over max(w, h) without sensor_size; principal point w/2 + cx·max(w, h)
    f = cam["focal_len"] * m
    du, dv = brown(u, v, *(cam.get(k, 0.0) for k in ("k1", "k2", "k3", "p1", "p2")))
    return np.column_stack([f * du + w / 2 + cam.get("cx", 0.0) * m, f * dv + h / 2 + cam.get("cy", 0.0) * m])


# -- COLMAP --------------------------------------------------------------------------------------------------------
def colmap_model(folder: Path, sc: dict, cameras: dict, *, binary=False, transform=None, names=None,
                 shots=None) -> Path:
    """A COLMAP model of the truth: ``cameras`` ``{id: (model, w, h, params)}``; the shots use camera ids cyclically;
    ``transform(C, R_wc) -> (C', R_wc')`` moves the model into another world frame (arbitrary, ECEF)."""
    from scipy.spatial.transform import Rotation
    folder.mkdir(parents=True, exist_ok=True)
    ids = list(cameras)
    imgs = []
    for k, n in enumerate(shots or sc["names"]):
        C, R = pose_cv(sc["truth"][n])
        if transform is not None:
            C, R = transform(C, R)
        x, y, z, w = Rotation.from_matrix(R).as_quat()
        imgs.append((k + 1, (w, x, y, z), -R @ C, ids[k % len(ids)], (names or {}).get(n, n + ".tif")))
    if binary:
        with open(folder / "cameras.bin", "wb") as f:
            f.write(struct.pack("<Q", len(cameras)))
            for cid, (model, w, h, params) in cameras.items():
                f.write(struct.pack("<iiQQ", cid, COLMAP_IDS[model], w, h) + struct.pack(f"<{len(params)}d", *params))
        with open(folder / "images.bin", "wb") as f:
            f.write(struct.pack("<Q", len(imgs)))
            for iid, q, t, cid, name in imgs:
                f.write(struct.pack("<i7di", iid, *q, *t, cid) + name.encode() + b"\x00")
                f.write(struct.pack("<Q", 1) + struct.pack("<ddq", 10.5, 20.5, -1))
        (folder / "points3D.bin").write_bytes(struct.pack("<Q", 0))
        return folder
    cams = ["# Camera list", *(f"{cid} {m} {w} {h} " + " ".join(repr(float(v)) for v in p)
                                for cid, (m, w, h, p) in cameras.items())]
    lines = ["# Image list with two lines of data per image:"]
    for iid, q, t, cid, name in imgs:
        lines += [f"{iid} " + " ".join(repr(float(v)) for v in (*q, *t)) + f" {cid} {name}", "10.5 20.5 -1"]
    (folder / "cameras.txt").write_text("\n".join(cams) + "\n")
    (folder / "images.txt").write_text("\n".join(lines) + "\n")
    (folder / "points3D.txt").write_text("# 3D point list\n")
    return folder


def ecef_transform(C, R, crs=TRUTH_CRS):
    """The map pose as ``model_aligner --alignment_type ecef`` leaves it: ECEF positions, ECEF -> camera rotations."""
    llh = map_to_llh(C[None], crs)[0]
    X = llh_to_ecef(llh[None])[0]
    J = _jacobian(lambda P: llh_to_ecef(map_to_llh(P, crs)), C)  # map vectors -> ECEF vectors
    return X, R @ J.T


def enu_transform(C, R, ref, crs=TRUTH_CRS):
    """The map pose as ``model_aligner --alignment_type enu`` leaves it: east, north, up (m) at ``ref = (lat, lon,
    alt)`` on WGS 84, ENU -> camera rotations (OpenSfM's topocentric frame, :func:`topo_pose`)."""
    return topo_pose(C, R, ref, crs)


def other_zone_transform(C, R, src=TRUTH_CRS, dst="EPSG:32634"):
    """The map pose in another projected CRS ``dst`` (``model_aligner`` given positions in the neighbouring UTM
    zone): positions through lon/lat, rotations by the Jacobian's rotation."""
    J = _jacobian(lambda P: llh_to_map(map_to_llh(P, src), dst), C)
    return llh_to_map(map_to_llh(C[None], src), dst)[0], R @ J.T


def arbitrary_transform(C, R, s=0.05, angle=37.0, shift=(3.0, -2.0, 1.0)):
    """A similarity away from the map (what COLMAP's mapper leaves without model_aligner)."""
    from scipy.spatial.transform import Rotation
    Q = Rotation.from_euler("zyx", [angle, 10.0, -5.0], degrees=True).as_matrix()
    C0 = np.array([500000.0, 6650000.0, 300.0])
    return s * Q @ (C - C0) + np.array(shift), R @ Q.T


# -- geodesy (pyproj only) -----------------------------------------------------------------------------------------
def _t(src, dst):
    from pyproj import Transformer
    return Transformer.from_crs(src, dst, always_xy=True)


def map_to_llh(P, crs=TRUTH_CRS):
    lon, lat = _t(crs, 4326).transform(P[:, 0], P[:, 1])
    return np.column_stack([lon, lat, P[:, 2]])


def llh_to_map(L, crs=TRUTH_CRS):
    x, y = _t(4326, crs).transform(L[:, 0], L[:, 1])
    return np.column_stack([x, y, L[:, 2]])


def llh_to_ecef(L):
    return np.column_stack(_t(4979, 4978).transform(L[:, 0], L[:, 1], L[:, 2]))


def ecef_to_llh(X):
    return np.column_stack(_t(4978, 4979).transform(X[:, 0], X[:, 1], X[:, 2]))


def enu_axes(lat, lon) -> np.ndarray:
    """Rows: east, north, up unit vectors in ECEF at ``lat, lon``."""
    la, lo = math.radians(lat), math.radians(lon)
    return np.array([[-math.sin(lo), math.cos(lo), 0], [-math.sin(la) * math.cos(lo), -math.sin(la) * math.sin(lo),
                                                          math.cos(la)],
                     [math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la)]])


def to_topo(P_map, ref, crs=TRUTH_CRS):
    """Map positions -> OpenSfM topocentric at ``ref = (lat, lon, alt)``."""
    X0 = llh_to_ecef(np.array([[ref[1], ref[0], ref[2]]]))[0]
    return (llh_to_ecef(map_to_llh(P_map, crs)) - X0) @ enu_axes(ref[0], ref[1]).T


def from_topo(T, ref, crs=TRUTH_CRS):
    X0 = llh_to_ecef(np.array([[ref[1], ref[0], ref[2]]]))[0]
    return llh_to_map(ecef_to_llh(X0 + T @ enu_axes(ref[0], ref[1])), crs)


def _jacobian(f, x, h=1.0) -> np.ndarray:
    """Rotation part (polar decomposition) of the Jacobian of ``f`` at ``x`` (3-vector -> 3-vector)."""
    J = np.column_stack([(f((x + h * e)[None])[0] - f((x - h * e)[None])[0]) / (2 * h) for e in np.eye(3)])
    U, _, Vt = np.linalg.svd(J)
    return U @ Vt


def topo_pose(C, R, ref, crs=TRUTH_CRS):
    """A map pose in OpenSfM's topocentric frame at ``ref``: ``(C_topo, R_wc_topo)``."""
    J = _jacobian(lambda P: to_topo(P, ref, crs), C)  # map vectors -> topocentric vectors
    return to_topo(C[None], ref, crs)[0], R @ J.T


# -- OpenSfM / ODM -------------------------------------------------------------------------------------------------
def opensfm_camera(cam, dewarp=None) -> dict:
    """The true camera as OpenSfM's ``brown`` camera (normalised by max(w, h)); ``dewarp`` (k1, k2, p1, p2, k3)
    by default the renderer's."""
    import rendered_oblique as ro
    w, h = (int(v) for v in cam.image_size)
    m = max(w, h)
    c = cam.principal_point
    k1, k2, p1, p2, k3 = dewarp or ro.DEWARP
    return {"projection_type": "brown", "width": w, "height": h, "focal_x": cam.fx / m, "focal_y": cam.fy / m,
            "c_x": (c[0] - w / 2) / m, "c_y": (c[1] - h / 2) / m, "k1": k1, "k2": k2, "k3": k3, "p1": p1, "p2": p2}


def odm_zone(sc: dict, images) -> tuple:
    """``(EPSG, offset)`` as ODM derives them: the zone of the first photo (sorted names), floor(mean UTM)."""
    first = sorted(images, key=lambda p: p.name)[0]
    lon, lat, _ = gps_of(first)
    zone = int(math.floor((lon + 180.0) / 6.0)) % 60 + 1
    epsg = (32600 if lat >= 0 else 32700) + zone
    xy = np.array([_t(4326, epsg).transform(*gps_of(p)[:2]) for p in images])
    return epsg, np.floor(xy.mean(axis=0))


def opensfm_project(folder: Path, sc: dict, images, *, odm: bool, exif=True, coords=True, topocentric_copy=True,
                    reconstructions=None, reference=True, camera=None, dop=None, imposed=True, names=None,
                    no_gps=False) -> Path:
    """An OpenSfM (``odm`` False) or ODM project of the truth in ``folder`` (module docstring); returns the path of
    ``opensfm/reconstruction.json``. ``reconstructions``: lists of shot names, one reconstruction each;
    ``imposed`` False: an ODM of February–July 2021, which kept OpenSfM's own reference (the photos' mean GPS)
    while ``export_geocoords`` subtracted its UTM offset; ``names``: the shots' file names by truth name (default
    ``NAME.tif``); ``no_gps``: shots without ``gps_position``/``gps_dop`` (OpenSfM run without GPS priors)."""
    name_of = names or {}
    from scipy.spatial.transform import Rotation
    osfm = folder / "opensfm"
    osfm.mkdir(parents=True, exist_ok=True)
    gps = {p.stem: gps_of(p) for p in images}
    if odm:
        epsg, off = odm_zone(sc, images)
        lon0, lat0 = _t(epsg, 4326).transform(*off)
        g = np.array(list(gps.values()))
        ref = (lat0, lon0, 0.0) if imposed else (float(g[:, 1].mean()), float(g[:, 0].mean()), float(g[:, 2].mean()))
    else:
        g = np.array(list(gps.values()))
        ref = (float(g[:, 1].mean()), float(g[:, 0].mean()), float(g[:, 2].mean()))
    crs = sc.get("crs", TRUTH_CRS)
    cam = camera or opensfm_camera(sc["camera"], sc.get("dewarp"))
    w, h = (int(v) for v in sc["camera"].image_size)
    cid = f"v2 dji fc-render {w} {h} brown 0.8125"
    recs = []
    for group in reconstructions or [sc["names"]]:
        shots = {}
        for n in group:
            Ct, Rt = topo_pose(*pose_cv(sc["truth"][n]), ref, crs)
            lon, lat, alt = gps[n]
            gp = to_topo(llh_to_map(np.array([[lon, lat, alt]]), crs)[None][0], ref, crs)[0]
            shots[name_of.get(n, n + ".tif")] = {"rotation": Rotation.from_matrix(Rt).as_rotvec().tolist(),
                                                 "translation": (-Rt @ Ct).tolist(), "camera": cid,
                                                 **({} if no_gps else {"gps_position": gp.tolist(),
                                                                        "gps_dop": dop or 15.0})}
        rec = {"cameras": {cid: cam}, "shots": shots, "points": {}}
        if reference:
            rec["reference_lla"] = dict(zip(("latitude", "longitude", "altitude"), ref))
        recs.append(rec)
    path = osfm / "reconstruction.json"
    if odm:
        (osfm / "reconstruction.topocentric.json").write_text(json.dumps(recs))
        recs = [_geocoords(r, ref, epsg, off) for r in recs]
        if coords:
            (folder / "odm_georeferencing").mkdir(exist_ok=True)
            zone = epsg % 100
            (folder / "odm_georeferencing" / "coords.txt").write_text(
                f"WGS84 UTM {zone}{'N' if epsg < 32700 else 'S'}\n{int(off[0])} {int(off[1])}\n")
        if not topocentric_copy:
            (osfm / "reconstruction.topocentric.json").unlink()
    path.write_text(json.dumps(recs))
    if reference:
        (osfm / "reference_lla.json").write_text(json.dumps(dict(zip(("latitude", "longitude", "altitude"), ref))))
    if exif:
        (osfm / "exif").mkdir(exist_ok=True)
        for n, (lon, lat, alt) in gps.items():
            (osfm / "exif" / f"{name_of.get(n, n + '.tif')}.exif").write_text(json.dumps(
                {"width": w, "height": h, "gps": {"latitude": lat, "longitude": lon, "altitude": alt,
                                                      "dop": dop or 15.0}}))
    return path


def _geocoords(rec: dict, ref, epsg, off) -> dict:
    """OpenSfM's ``export_geocoords --reconstruction --proj UTM --offset-x --offset-y`` (module docstring)."""
    from scipy.spatial.transform import Rotation

    def q(p):
        lon, lat, h = ecef_to_llh(llh_to_ecef(np.array([[ref[1], ref[0], ref[2]]]))
                                  + np.array(p, float) @ enu_axes(ref[0], ref[1]))[0]
        return np.array([*_t(4326, epsg).transform(lon, lat), h])
    qs = [q(p) for p in ([1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0])]
    A = np.column_stack([qs[i] - qs[3] for i in range(3)])
    b = qs[3] - np.array([off[0], off[1], 0.0])
    A1 = np.linalg.inv(A)
    out = json.loads(json.dumps(rec))
    for s in out["shots"].values():
        R = Rotation.from_rotvec(s["rotation"]).as_matrix()
        C = -R.T @ np.array(s["translation"])
        R2 = Rotation.from_matrix(R @ A1).as_matrix()  # OpenSfM keeps a rotation: the nearest one
        C2 = A @ C + b
        s["rotation"], s["translation"] = Rotation.from_matrix(R2).as_rotvec().tolist(), (-R2 @ C2).tolist()
    return out


# -- orthority -----------------------------------------------------------------------------------------------------
def orthority_files(folder: Path, sc: dict, cam: dict, *, fmt="geojson") -> tuple:
    """orthority's exterior (GeoJSON, ``opk`` radians) and interior files of the truth with camera ``cam``: YAML, or
    with ``fmt`` "json" the same mapping in JSON syntax (a YAML subset orthority reads alike)."""
    folder.mkdir(parents=True, exist_ok=True)
    feats = []
    for n in sc["names"]:
        e = sc["truth"][n]
        feats.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": [0, 0]},
                      "properties": {"filename": n + ".tif", "camera": "dji", "xyz": [e.X, e.Y, e.Z],
                                     "opk": [math.radians(a) for a in (e.omega, e.phi, e.kappa)]}})
    ext = folder / "exterior.geojson"
    ext.write_text(json.dumps({"type": "FeatureCollection", "world_crs": sc.get("crs", TRUTH_CRS), "features": feats}))
    keys = [k for k in cam if k not in ("tool", "width", "height")]
    if fmt == "json":
        d = {"im_size": [cam["width"], cam["height"]], **{k: cam[k] for k in keys}}
        (folder / "int_param.json").write_text(json.dumps({"dji": d}, indent=4))
        return ext, folder / "int_param.json"
    lines = ["dji:", f"    im_size: [{cam['width']}, {cam['height']}]"] + [f"    {k}: {cam[k]!r}" if k != "type" else
                                                                              f"    type: {cam[k]}" for k in keys]
    (folder / "interior.yaml").write_text("\n".join(lines) + "\n")
    return ext, folder / "interior.yaml"


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
