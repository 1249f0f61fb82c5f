"""The held-out SfM projects' files, written from each tool's documented format (not with fotogeo's writers; the
formats are summarised in tests/sfm_projects.py's docstring): COLMAP models (text or binary; :func:`colmap_model`)
and the world frames ``model_aligner`` leaves them in, OpenSfM and ODM projects (:func:`opensfm_project`) and
orthority's exterior and interior files (:func:`orthority_files`)."""
from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np

from sfm_conventions import (TRUTH_CRS, _jacobian, _t, ecef_to_llh, enu_axes, gps_of, llh_to_ecef, llh_to_map,
                             map_to_llh, pose_cv, to_topo, topo_pose)

COLMAP_IDS = {"SIMPLE_PINHOLE": 0, "PINHOLE": 1, "SIMPLE_RADIAL": 2, "RADIAL": 3, "OPENCV": 4, "OPENCV_FISHEYE": 5,
              "FULL_OPENCV": 6, "FOV": 7, "SIMPLE_RADIAL_FISHEYE": 8, "RADIAL_FISHEYE": 9, "THIN_PRISM_FISHEYE": 10,
              "RAD_TAN_THIN_PRISM_FISHEYE": 11}


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
