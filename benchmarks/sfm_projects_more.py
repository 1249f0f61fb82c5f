"""Cases of ``benchmarks/sfm_projects_bench.py`` beyond its first 52 (issue 32): every COLMAP model beyond fotogeo's
Brown model, model_aligner's ENU frame and a neighbouring UTM zone, a text model saved on Windows, image names with
spaces, in another case or with Windows separators; OpenSfM/ODM shots without GPS, images split over two
reconstructions, ODM without reference_lla, ODM's cameras.json as the camera, renamed images; orthority's CSV; the
models of undistorted images (OpenSfM's/ODM's ``undistorted/``, COLMAP's ``dense/sparse``) with either images.
Each ``build()`` returns what ``run_case`` runs (its docstring), ``stems`` the images' file stems by truth name.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import sfm_projects as sp

#: COLMAP's fisheye and other models beyond fotogeo's Brown model (each must be refused by name)
FISHEYES = ("FOV", "SIMPLE_RADIAL_FISHEYE", "RADIAL_FISHEYE", "THIN_PRISM_FISHEYE", "RAD_TAN_THIN_PRISM_FISHEYE")


def _renamed(sc, folder: Path, rename) -> list:
    """Copies of the RTK images named ``rename(stem) + suffix`` in ``folder`` (a user's copy of the images)."""
    import shutil
    folder.mkdir(parents=True, exist_ok=True)
    return [Path(shutil.copy(p, folder / (rename(p.stem) + p.suffix))) for p in sc["rtk"]]


#: project names -> the names of the files the user gives: (project name of stem N, file stem of stem N)
NAMINGS = {"spaces": (lambda n: f"flight 1/{n.replace('_', ' ')}.JPG", lambda n: n.replace("_", " ")),
           "case": (lambda n: f"{n.lower()}.jpg", lambda n: n),
           "spaces-flat": (lambda n: f"{n.replace('_', ' ')}.JPG", lambda n: n.replace("_", " ")),
           "windows": (lambda n: f"flight1\\{n}.JPG", lambda n: n)}


def colmap_more(sc, work: Path, cams: dict, colmap_frame) -> list:
    """COLMAP cases beyond the models: model_aligner's ENU frame, a neighbouring UTM zone, an unknown binary model
    id, image names with spaces, another case, Windows separators."""
    crs, (W, H) = sc["crs"], sc["size"]
    cam = {"tool": "colmap", "model": "OPENCV", "params": cams["OPENCV"]}
    neighbour = f"EPSG:{int(crs[5:]) + 1}"

    def enu(images):
        def build():
            lon, lat, alt = sp.gps_of(sc["rtk"][0])
            f = sp.colmap_model(work / f"colmap_enu_{images}", sc, {1: ("OPENCV", W, H, cams["OPENCV"])},
                                transform=lambda C, R: sp.enu_transform(C, R, (lat, lon, alt), crs))
            return dict(eo=f, images=sc[images], n=len(sc[images]), camera=cam, args=["--crs", crs])
        return build

    def unknown_id():
        f = sp.colmap_model(work / "colmap_id12", sc, {1: ("OPENCV", W, H, cams["OPENCV"])}, binary=True)
        data = bytearray((f / "cameras.bin").read_bytes())
        data[12:16] = (12).to_bytes(4, "little")  # the model id of camera 1, after the count and its id
        (f / "cameras.bin").write_bytes(bytes(data))
        return dict(eo=f, images=sc["rtk"], camera=cam, args=["--crs", crs])

    def named(kind):
        def build():
            project, stem = NAMINGS[kind]
            f = sp.colmap_model(work / f"colmap_names_{kind}", sc, {1: ("OPENCV", W, H, cams["OPENCV"])},
                                names={n: project(n) for n in sc["names"]})
            imgs = _renamed(sc, work / f"images_{kind}", stem)
            return dict(eo=f, images=imgs, camera=cam, args=["--crs", crs], stems=[stem(n) for n in sc["names"]])
        return build
    def crlf():
        f = sp.colmap_model(work / "colmap_crlf", sc, {1: ("OPENCV", W, H, cams["OPENCV"])})
        for n in ("cameras.txt", "images.txt", "points3D.txt"):
            (f / n).write_bytes(b"\xef\xbb\xbf" + (f / n).read_bytes().replace(b"\n", b"\r\n"))
        return dict(eo=f, images=sc["rtk"], camera=cam, args=["--crs", crs])
    other = lambda C, R: sp.other_zone_transform(C, R, crs, neighbour)  # noqa: E731
    return [("colmap-enu-rtk", "COLMAP model_aligner --alignment_type enu (east, north, up at the first image), all "
                               "RTK images", enu("rtk")),
            ("colmap-enu-bare", "COLMAP model_aligner --alignment_type enu, images without GPS", enu("bare")),
            ("colmap-zone-rtk", f"COLMAP model aligned to positions in the neighbouring zone ({neighbour}), --crs "
                                f"{crs}, RTK images", colmap_frame("zone", other, "rtk", crs)),
            ("colmap-zone-bare", f"COLMAP model aligned in {neighbour}, --crs {crs}, images without GPS",
             colmap_frame("zone", other, "bare", crs)),
            ("colmap-crlf-bom", "COLMAP text model saved on Windows (CRLF line ends, a UTF-8 BOM)", crlf),
            ("colmap-bin-id12", "COLMAP binary model with a camera model id this reader does not know (12)",
             unknown_id),
            ("colmap-names-spaces", "COLMAP image names with a folder and spaces ('flight 1/DJI 101.JPG'), the files "
                                    "'DJI 101.tif'", named("spaces")),
            ("colmap-names-case", "COLMAP image names in lower case ('dji_101.jpg'), the files 'DJI_101.tif'",
             named("case")),
            ("colmap-names-windows", "COLMAP image names with Windows separators ('flight1\\DJI_101.JPG')",
             named("windows"))]


def opensfm_more(sc, work: Path) -> list:
    """OpenSfM/ODM cases beyond the frames: shots without GPS, images in two reconstructions, ODM without
    reference_lla, ODM's cameras.json given as the camera, image names with spaces or another case."""
    cam = {"tool": "opensfm", **sp.opensfm_camera(sc["camera"], sc["dewarp"])}

    def osfm(key, images="rtk", n=2, args=(), **kw):
        def build():
            f = sp.opensfm_project(work / key, sc, sc["rtk"], **kw)
            return dict(eo=f, images=sc[images], n=n, camera=cam, args=list(args))
        return build

    def cameras_json():
        f = sp.opensfm_project(work / "odm_cj", sc, sc["rtk"], odm=True, exif=False, coords=False,
                               topocentric_copy=False)
        rec = json.loads(f.read_text())[0]
        (f.parent.parent / "cameras.json").write_text(json.dumps(rec["cameras"], indent=4))
        return dict(eo=f, images=sc["rtk"], camera=cam, args=["--camera", str(f.parent.parent / "cameras.json")])

    def named(kind, odm):
        def build():
            project, stem = NAMINGS[kind]
            f = sp.opensfm_project(work / f"osfm_names_{kind}_{odm}", sc, sc["rtk"], odm=odm,
                                   names={n: project(n) for n in sc["names"]})
            imgs = _renamed(sc, work / f"images_{kind}", stem)
            return dict(eo=f, images=imgs, camera=cam, args=[], stems=[stem(n) for n in sc["names"]])
        return build
    half = len(sc["names"]) // 2
    return [("opensfm-nogps-rtk", "OpenSfM reconstruction.json + reference_lla.json, shots without gps_position "
                                  "(no GPS priors); RTK images", osfm("osfm_ng", odm=False, exif=False, no_gps=True)),
            ("opensfm-nogps-bare", "OpenSfM reconstruction.json, shots without gps_position; images without GPS",
             osfm("osfm_ngb", "bare", odm=False, exif=False, no_gps=True)),
            ("odm-nogps-bare", "ODM project (coords.txt, topocentric copy), shots without gps_position; images "
                               "without GPS", osfm("odm_ngb", "bare", odm=True, no_gps=True)),
            ("opensfm-two-recs-split", "OpenSfM with two reconstructions, the images given split across them",
             osfm("osfm_2s", odm=False, n=len(sc["names"]),
                  reconstructions=[sc["names"][:half], sc["names"][half:]])),
            ("odm-no-reference", "ODM project (coords.txt) whose reconstruction carries no reference_lla",
             osfm("odm_nr", odm=True, reference=False)),
            ("odm-cameras-json", "ODM opensfm/reconstruction.json with ODM's cameras.json as --camera; RTK images",
             cameras_json),
            ("odm-names-case", "ODM project with image names in lower case ('dji_101.jpg'), the files 'DJI_101.tif'",
             named("case", True)),
            ("opensfm-names-spaces", "OpenSfM project with image names with spaces ('DJI 101.JPG')",
             named("spaces-flat", False))]


def orthority_csv(sc, geojson: Path, prj: bool) -> Path:
    """orthority's CSV exterior parameters (``filename,x,y,z,omega,phi,kappa``, degrees) of ``geojson``'s poses,
    with the CRS as a ``.prj`` (WKT) beside them when ``prj``."""
    from pyproj import CRS
    feats = json.loads(geojson.read_text())["features"]
    lines = ["filename,x,y,z,omega,phi,kappa,camera"]
    for f in feats:
        p = f["properties"]
        lines.append(",".join([p["filename"], *map(repr, p["xyz"]), *(repr(math.degrees(a)) for a in p["opk"]),
                               p["camera"]]))
    out = geojson.with_name("ext_param.csv")
    out.write_text("\n".join(lines) + "\n")
    if prj:
        out.with_suffix(".prj").write_text(CRS.from_user_input(sc["crs"]).to_wkt("WKT1_ESRI"))
    return out


def undistorted_more(sc, work: Path) -> list:
    """The models of the undistorted images (OpenSfM's and ODM's ``opensfm/undistorted/reconstruction.json``, a
    ``perspective`` camera with k1 = k2 = 0; COLMAP ``image_undistorter``'s ``dense/sparse``, ``PINHOLE``) given
    with the original images (to be refused: the images' DewarpData states their lens) and with the undistorted
    images they belong with (to be read right)."""
    import shutil
    (w, h), f = sc["size"], sc["camera"].fx
    persp = {"projection_type": "perspective", "width": w, "height": h, "focal": f / max(w, h), "k1": 0.0, "k2": 0.0}
    lens = {"tool": "opensfm", **sp.opensfm_camera(sc["camera"], sc["dewarp"])}
    flat = {"tool": "opensfm", **persp}

    def osfm(key, odm, images, told=True):
        def build():
            rec = sp.opensfm_project(work / key, sc, sc["rtk"], odm=odm, camera=persp)
            (rec.parent / "undistorted").mkdir(exist_ok=True)
            eo = Path(shutil.copy(rec, rec.parent / "undistorted" / "reconstruction.json"))
            imgs = sc["rtk"] if images == "originals" else sp.undistorted_images(sc, work / f"undist_{images}",
                                                                                  images == "tags", 2)
            frame = ["--sfm-frame", "grid" if odm else "topocentric"] if images == "bare" and told else []
            return dict(eo=eo, images=imgs, camera=lens if images == "originals" else flat, args=frame)
        return build

    def colmap(images):
        def build():
            pin = [f, f, w / 2, h / 2]
            model = sp.colmap_model(work / "colmap_undist" / "dense" / "sparse", sc, {1: ("PINHOLE", w, h, pin)})
            c, (ppx, ppy) = sc["camera"], sc["camera"].principal_point
            k1, k2, p1, p2, _ = sc["dewarp"]
            truth = ({"tool": "colmap", "model": "OPENCV", "params": [c.fx, c.fy, ppx, ppy, k1, k2, p1, p2]}
                     if images == "originals" else {"tool": "colmap", "model": "PINHOLE", "params": pin})
            imgs = sc["rtk"] if images == "originals" else sp.undistorted_images(sc, work / "undist_bare", False, 2)
            return dict(eo=model / "images.txt", images=imgs, camera=truth, args=["--crs", sc["crs"]])
        return build
    return [("undist-osfm-originals", "OpenSfM opensfm/undistorted/reconstruction.json (perspective, k = 0) given the "
                                      "original images (DewarpData)", osfm("undist_osfm_o", False, "originals")),
            ("undist-odm-originals", "ODM opensfm/undistorted/reconstruction.json given the original images",
             osfm("undist_odm_o", True, "originals")),
            ("undist-osfm-undistorted", "OpenSfM undistorted/reconstruction.json given the undistorted images "
                                        "(written without EXIF/XMP)", osfm("undist_osfm_u", False, "bare")),
            ("undist-odm-undistorted", "ODM undistorted/reconstruction.json given the undistorted images",
             osfm("undist_odm_u", True, "bare")),
            ("undist-osfm-undistorted-auto", "OpenSfM undistorted/reconstruction.json given the undistorted images "
                                             "(no GPS), no --sfm-frame", osfm("undist_osfm_ua", False, "bare", False)),
            ("undist-odm-undistorted-auto", "ODM undistorted/reconstruction.json given the undistorted images (no "
                                            "GPS), no --sfm-frame", osfm("undist_odm_ua", True, "bare", False)),
            ("undist-osfm-dewarpflag", "OpenSfM undistorted/reconstruction.json given undistorted images with the "
                                       "originals' tags and DewarpFlag 1", osfm("undist_osfm_t", False, "tags")),
            ("undist-colmap-originals", "COLMAP dense/sparse (image_undistorter, PINHOLE) given the original images",
             colmap("originals")),
            ("undist-colmap-undistorted", "COLMAP dense/sparse (PINHOLE) given the undistorted images",
             colmap("bare"))]
