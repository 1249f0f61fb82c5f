"""Third-party SfM projects read right or refused by name (issue 32): held-out cases with known truth.

Every case writes the files a user gets from COLMAP, OpenSfM, ODM or orthority for the rendered block of
``tests/sfm_projects.py`` — at 60° N on the UTM 33/34 edge (640 x 480 frames) and again, ``S:`` rows, at 33° S on the
UTM 18/19 edge (portrait 480 x 640 frames, another lens; ``sfm_projects.SOUTH``) — then

* runs ``fotogeo ortho IMG1 IMG2 [...] --eo FILE --dem DEM --resolution 1 -o OUT [...]`` as a user runs it (exit
  code, the run's first note or warning or its one-line error; ``-q`` would hide the notes and warnings);
* reads the file as ``ortho`` does (:func:`fotogeo.tools.ortho.inputs.orientation_block`) and measures, for every
  frame, the orthophoto shift: ground points in view are projected by the tool's own camera equations and the true
  pose, then back through fotogeo's reading onto the same height; the shift is the horizontal distance (median and
  p90 over all points of all frames), with the worst centre error (m) and rotation angle (°).

A case passes when it is read within 0.05 m median / 0.10 m p90 or refused naming the option or input to fix; a
model aligned here to consumer GPS is "read, expected error warned" when the run warned with an expected error
(at the cameras plus per 100 m of height, summed) and the measured median shift is within 3x that statement.

    PYTHONPATH=. /work/main/.venv/bin/python benchmarks/sfm_projects_bench.py [--only ID,ID] [--table cases.md]
        [--work DIR] [--place north|south|both]

The cases beyond the first 52 are in ``benchmarks/sfm_projects_more.py``. The JSON is written by a full run
(``--place both``, no ``--only``).

Results: ``benchmarks/results/sfm_projects_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import sfm_projects as sp  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import sfm_projects_more as more  # noqa: E402

MEDIAN_M, P90_M = 0.05, 0.10
#: a run that read the file beyond the done-when shift but warned with an expected error it stays within (3x)
WARNED = "read, expected error warned"


def _colmap_cams(sc):
    c = sc["camera"]
    (ppx, ppy), f = c.principal_point, c.fx
    k1, k2, p1, p2, k3 = sc["dewarp"]
    return {"SIMPLE_PINHOLE": [f, ppx, ppy], "PINHOLE": [f, f * 1.002, ppx, ppy], "SIMPLE_RADIAL": [f, ppx, ppy, k1],
            "RADIAL": [f, ppx, ppy, k1, k2], "OPENCV": [f, f, ppx, ppy, k1, k2, p1, p2],
            "FULL_OPENCV": [f, f, ppx, ppy, k1, k2, p1, p2, 0.003, 0.0, 0.0, 0.0],
            "FULL_OPENCV_k4": [f, f, ppx, ppy, k1, k2, p1, p2, 0.0, 0.01, 0.0, 0.0],
            "OPENCV_FISHEYE": [f, f, ppx, ppy, 0.01, 0.0, 0.0, 0.0], "FOV": [f, f, ppx, ppy, 0.01],
            "SIMPLE_RADIAL_FISHEYE": [f, ppx, ppy, 0.01], "RADIAL_FISHEYE": [f, ppx, ppy, 0.01, 0.0],
            "THIN_PRISM_FISHEYE": [f, f, ppx, ppy, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            "RAD_TAN_THIN_PRISM_FISHEYE": [f, f, ppx, ppy, 0.01] + [0.0] * 11}


def cases(sc, work: Path) -> list:
    """``[(id, description, build)]``; ``build()`` -> ``dict(eo, images, camera (truth, tool's), args, crs, yaml)``."""
    out = []
    cams = _colmap_cams(sc)
    crs, (W, H) = sc["crs"], sc["size"]

    def colmap_case(model, binary=False, **kw):
        name = model.replace("_k4", "")

        def build():
            f = sp.colmap_model(work / f"colmap_{model}_{int(binary)}", sc, {1: (name, W, H, cams[model])},
                                binary=binary, **kw)
            return dict(eo=f / ("images.bin" if binary else "images.txt"), images=sc["rtk"],
                        camera={"tool": "colmap", "model": name, "params": cams[model]}, args=["--crs", crs])
        return build
    for binary in (False, True):
        for model in ("SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV", "FULL_OPENCV",
                      "FULL_OPENCV_k4", "OPENCV_FISHEYE", *more.FISHEYES):
            out.append((f"colmap-{'bin' if binary else 'txt'}-{model}",
                        f"COLMAP {'binary' if binary else 'text'} model, {model}", colmap_case(model, binary)))

    def colmap_frame(key, transform, images, crs):
        def build():
            f = sp.colmap_model(work / f"colmap_{key}_{images}", sc, {1: ("OPENCV", W, H, cams["OPENCV"])},
                                transform=transform)
            return dict(eo=f / "images.txt", images=sc[images], camera={"tool": "colmap", "model": "OPENCV",
                                                                          "params": cams["OPENCV"]},
                        args=["--crs", crs] if crs else [])
        return build
    zone = f"UTM {int(crs[-2:])}"
    ecef = lambda C, R: sp.ecef_transform(C, R, crs)  # noqa: E731
    out += [("colmap-arbitrary-rtk", f"COLMAP model not aligned (arbitrary frame), RTK images, --crs {zone}",
             colmap_frame("arbitrary", sp.arbitrary_transform, "rtk", crs)),
            ("colmap-arbitrary-bare", f"COLMAP model not aligned, images without GPS, --crs {zone}",
             colmap_frame("arbitrary", sp.arbitrary_transform, "bare", crs)),
            ("colmap-ecef-rtk", f"COLMAP model_aligner into ECEF, RTK images, --crs {zone}",
             colmap_frame("ecef", ecef, "rtk", crs)),
            ("colmap-ecef-bare", "COLMAP model_aligner into ECEF, images without GPS, no --crs (the DEM's)",
             colmap_frame("ecef", ecef, "bare", None)),
            ("colmap-utm-consumer", f"COLMAP model_aligner into {zone}, consumer GPS images",
             colmap_frame("utm", lambda C, R: (C, R), "consumer", crs))]
    out += more.colmap_more(sc, work, cams, colmap_frame)

    def colmap_aligned(images, kind="all"):
        def build():
            f = sp.colmap_model(work / f"colmap_own_{images}_{kind}", sc, {1: ("OPENCV", W, H, cams["OPENCV"])},
                                transform=sp.arbitrary_transform)
            imgs = list(sc[images])
            if kind == "strip":  # the first strip alone: its centres lie near a line
                imgs = [p for p in imgs if p.stem.startswith("DJI_1")]
            if kind == "bad":  # one RTK fix 30 m off
                imgs[3] = sp.shifted_gps(imgs[3], work / "bad_gps" / imgs[3].name, (30.0, -10.0), crs)
            if kind == "no-altitude":  # latitude and longitude only
                imgs = [sp.without_altitude(p, work / "no_alt" / p.name) for p in imgs]
            cam = {"tool": "colmap", "model": "OPENCV", "params": cams["OPENCV"]}
            return dict(eo=f, images=imgs, n=len(imgs), camera=cam, args=["--crs", crs])
        return build
    out += [("colmap-own-rtk", "COLMAP model not aligned (its own frame), folder as --eo, all 16 RTK images",
             colmap_aligned("rtk")),
            ("colmap-own-consumer", "COLMAP model not aligned, all 16 consumer GPS images (2 m off, no accuracy tags)",
             colmap_aligned("consumer")),
            ("colmap-own-bad-gps", "COLMAP model not aligned, 16 RTK images, one fix 30 m off",
             colmap_aligned("rtk", "bad")),
            ("colmap-own-strip", "COLMAP model not aligned, the 4 RTK images of one strip (centres near a line)",
             colmap_aligned("rtk", "strip")),
            ("colmap-own-no-altitude", "COLMAP model not aligned, 16 RTK images with latitude and longitude but no "
                                       "altitude", colmap_aligned("rtk", "no-altitude"))]

    def colmap_misc(kind):
        def build():
            names = {n: f"flight1/sub/{n}.JPG" for n in sc["names"]} if kind == "subfolders" else None
            camset = {1: ("OPENCV", W, H, cams["OPENCV"])}
            if kind == "two-cameras":
                camset[2] = ("OPENCV", W, H, cams["OPENCV"])
            shots = sc["names"][2:] if kind == "missing" else None
            f = sp.colmap_model(work / f"colmap_{kind}", sc, camset, names=names, shots=shots)
            imgs = sc["rtk"]
            size = {"resized": (W // 2, H // 2), "resized-4-5": (W * 4 // 5, H * 4 // 5),
                    "resized-1-3": (W // 3, H // 3),
                    "enlarged": (2 * W, 2 * H), "aspect": (W // 2, H * 5 // 12),
                    "cropped": (W * 15 // 16, H * 15 // 16)}.get(kind)
            if size:
                imgs = _resized(sc, work / kind, size)
            eo = {"folder": f, "folder-empty": f.parent}.get(kind, f / "images.txt")
            return dict(eo=eo, images=imgs, camera={"tool": "colmap", "model": "OPENCV", "params": cams["OPENCV"]},
                        args=["--crs", crs], scale=(size[0] / W, size[1] / H) if size else (1.0, 1.0))
        return build
    out += [(f"colmap-{k}", d, colmap_misc(k)) for k, d in (
        ("subfolders", "COLMAP images named with sub-folders and another extension (flight1/sub/X.JPG)"),
        ("two-cameras", "COLMAP model with two camera ids"),
        ("missing", "COLMAP model without the first two images (given on the command line)"),
        ("resized", "COLMAP model of 640x480 images given the images resized to 320x240"),
        ("resized-4-5", "COLMAP model of 640x480 images given the images resized to 512x384 (4/5: a long side of "
                        "512 px)"),
        ("resized-1-3", "COLMAP model of 640x480 images given the images resized to 213x160 (1/3, the width "
                        "floored: 213.33 -> 213)"),
        ("enlarged", "COLMAP model of 640x480 images given the images enlarged to 1280x960 (originals)"),
        ("aspect", "COLMAP model of 640x480 images given the images squeezed to 320x200 (aspect changed)"),
        ("cropped", "COLMAP model of 640x480 images given the images cropped to 600x450 (the size a 15/16 "
                    "reduction would give)"),
        ("folder", "COLMAP model given by its folder (--eo sparse/0/)"),
        ("folder-empty", "the folder above a COLMAP model given as --eo (no model in it)"))]

    def osfm(key, images="rtk", flag=False, **kw):
        def build():
            f = sp.opensfm_project(work / key, sc, sc["rtk"], **kw)
            if flag:  # ODM 2.4.7-2.6.3: reconstruction.json rewritten along the grid in place, no topocentric copy
                (f.parent / "exported_geocoords.txt").write_text("")
            return dict(eo=f, images=sc[images], camera={"tool": "opensfm", **sp.opensfm_camera(sc["camera"],
                                                                                              sc["dewarp"])}, args=[])
        return build
    odm = dict(odm=True)
    out += [("odm-full-rtk", "ODM project as ODM leaves it (geocoords poses, exif/, coords.txt, topocentric copy), RTK",
             osfm("odm_full", **odm)),
            ("odm-full-consumer", "ODM project as ODM leaves it, images with consumer GPS", osfm("odm_fc", "consumer",
                                                                                               **odm)),
            ("odm-full-bare", "ODM project as ODM leaves it, images without GPS", osfm("odm_fb", "bare", **odm)),
            ("odm-json-rtk", "ODM opensfm/ copied without exif/, coords.txt, topocentric copy; RTK images",
             osfm("odm_j", exif=False, coords=False, topocentric_copy=False, **odm)),
            ("odm-json-consumer", "ODM opensfm/ copied alone; consumer GPS images",
             osfm("odm_jc", "consumer", exif=False, coords=False, topocentric_copy=False, **odm)),
            ("odm-json-bare", "ODM opensfm/ copied alone; images without GPS",
             osfm("odm_jb", "bare", exif=False, coords=False, topocentric_copy=False, **odm)),
            ("odm-exif-bare", "ODM opensfm/ with exif/ (no coords.txt, no topocentric copy); images without GPS",
             osfm("odm_eb", "bare", coords=False, topocentric_copy=False, **odm)),
            ("odm-rtkdop-bare", "ODM opensfm/ alone, shots' gps_dop 0.02 (RTK); images without GPS",
             osfm("odm_rb", "bare", exif=False, coords=False, topocentric_copy=False, dop=0.02, **odm)),
            ("odm2021-coords", "ODM of Feb-Jul 2021 (OpenSfM's own reference_lla, UTM offset in coords.txt), "
                               "consumer GPS images", osfm("odm21c", "consumer", imposed=False, **odm)),
            ("odm2021-no-coords", "ODM of Feb-Jul 2021 copied without odm_georeferencing/, consumer GPS images",
             osfm("odm21n", "consumer", imposed=False, coords=False, **odm)),
            ("odm2021-flag-coords", "ODM 2.4.7-2.6.3 (exported_geocoords.txt, no topocentric copy, OpenSfM's "
                                    "reference_lla, coords.txt), consumer GPS images",
             osfm("odm21fc", "consumer", True, imposed=False, topocentric_copy=False, **odm)),
            ("odm2021-flag-no-coords", "ODM 2.4.7-2.6.3 copied without odm_georeferencing/, consumer GPS images",
             osfm("odm21fn", "consumer", True, imposed=False, topocentric_copy=False, coords=False, **odm)),
            ("opensfm-rtk", "OpenSfM project (topocentric, exif/), RTK images", osfm("osfm", odm=False)),
            ("opensfm-consumer", "OpenSfM project with exif/ (OpenSfM's default dop), consumer GPS images",
             osfm("osfm_c", "consumer", odm=False)),
            ("opensfm-json-consumer", "OpenSfM reconstruction.json + reference_lla.json alone; consumer GPS images",
             osfm("osfm_jc", "consumer", odm=False, exif=False)),
            ("opensfm-no-reference", "OpenSfM reconstruction.json without reference_lla",
             osfm("osfm_nr", odm=False, reference=False, exif=False)),
            ("opensfm-two-recs", "OpenSfM with two reconstructions, the images given in the smaller (second) one",
             osfm("osfm_2", odm=False, reconstructions=[sc["names"][2:], sc["names"][:2]])),
            ("opensfm-fisheye", "OpenSfM fisheye camera", osfm("osfm_f", odm=False, camera={
                "projection_type": "fisheye", "width": W, "height": H, "focal": 0.8, "k1": 0.0, "k2": 0.0}))]
    out += more.opensfm_more(sc, work)

    def tortho(key, cam, fmt="geojson"):
        def build():
            ext, yml = sp.orthority_files(work / key, sc, cam, fmt=fmt)
            if fmt.startswith("csv"):
                ext = more.orthority_csv(sc, ext, fmt == "csv")
            return dict(eo=ext, images=sc["rtk"], camera={"tool": "orthority", **cam}, args=["--camera", str(yml)],
                        yaml=yml)
        return build
    c = sc["camera"]
    m = max(W, H)
    base = {"width": W, "height": H, "focal_len": c.fx / m, "cx": (c.principal_point[0] - W / 2) / m,
            "cy": (c.principal_point[1] - H / 2) / m}
    out += [("orthority-brown", "orthority GeoJSON + brown camera", tortho("ot_b", {**base, "type": "brown",
                                                                                     "k1": -0.06, "k2": 0.02,
                                                                                     "p1": 4e-4, "p2": -3e-4,
                                                                                     "k3": 0.001})),
            ("orthority-opencv", "orthority GeoJSON + opencv camera (k1-k3, p1, p2)",
             tortho("ot_o", {**base, "type": "opencv", "k1": -0.06, "k2": 0.02, "p1": 4e-4, "p2": -3e-4})),
            ("orthority-opencv-k4", "orthority opencv camera with k4", tortho("ot_o4", {**base, "type": "opencv",
                                                                                      "k1": -0.06, "k4": 0.01})),
            ("orthority-fisheye", "orthority fisheye camera", tortho("ot_f", {**base, "type": "fisheye",
                                                                             "k1": 0.01})),
            ("orthority-pinhole", "orthority pinhole camera", tortho("ot_p", {**base, "type": "pinhole"})),
            ("orthority-json-brown", "orthority interior parameters in JSON syntax (int_param.json), brown camera",
             tortho("ot_jb", {**base, "type": "brown", "k1": -0.06, "k2": 0.02, "p1": 4e-4, "p2": -3e-4}, "json")),
            ("orthority-json-fisheye", "orthority interior parameters in JSON syntax, fisheye camera",
             tortho("ot_jf", {**base, "type": "fisheye", "k1": 0.01}, "json")),
            ("orthority-csv", "orthority CSV exterior parameters (header, degrees) with a .prj beside them",
             tortho("ot_csv", {**base, "type": "brown", "k1": -0.06, "k2": 0.02}, "csv")),
            ("orthority-csv-noprj", "orthority CSV exterior parameters without a .prj (the CRS not stated)",
             tortho("ot_csvn", {**base, "type": "brown", "k1": -0.06, "k2": 0.02}, "csv-noprj"))]
    return out + more.undistorted_more(sc, work)


def _resized(sc, folder: Path, size) -> list:
    """The RTK images resized to ``size`` (corner to corner, as cv2.resize maps them), or cropped at the top-left
    to ``size`` for "cropped" (folder name)."""
    import cv2
    import rasterio
    import rendered_oblique as ro
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for p in sc["rtk"]:
        with rasterio.open(p) as ds:
            img, tags, xmp = ds.read(1), ds.tags(), next(iter(ds.tags(ns="xml:XMP").values()))
        if folder.name == "cropped":
            small = np.ascontiguousarray(img[:size[1], :size[0]])
        else:
            small = cv2.resize(img, size, interpolation=cv2.INTER_AREA if size[0] < img.shape[1] else
                               cv2.INTER_LINEAR)
        ro._write(folder / p.name, small, tags, xmp)
        out.append(folder / p.name)
    return out


def run_case(cid, what, build, sc, work: Path) -> dict:
    from click.testing import CliRunner

    from fotogeo.cli import main
    from fotogeo.crs import parse_crs
    from fotogeo.errors import FotogeoError
    from fotogeo.tools.ortho.inputs import orientation_block
    b = build()
    n = b.get("n", 2)
    imgs = [str(p) for p in b["images"][:n]]
    cmd = ["ortho", *imgs, "--eo", str(b["eo"]), "--dem", str(sc["dem"]), "--resolution", "1", "-o",
           str(work / "out" / cid), "--overwrite", *b["args"]]
    run = CliRunner().invoke(main, cmd)
    lines = [ln for ln in (run.stderr or run.output).splitlines() if ln.strip()]
    msg = next((ln for ln in lines if ln.startswith("Error") or "error" in ln.lower()[:12]), lines[0] if lines else "")
    row = {"id": cid, "case": what, "command": "fotogeo " + " ".join(cmd).replace(str(work), "$W"),
           "exit": run.exit_code, "message": msg.replace(str(work), "$W")}
    stated = re.search(r"expected error ≈ ([0-9.]+) m horizontally at the cameras plus ([0-9.]+) m per 100 m",
                       run.stderr or run.output)
    if stated:  # the run warned that its georeference is only as good as this (with ~100 m of height)
        row["stated_m"] = float(stated.group(1)) + float(stated.group(2))
    if run.exit_code == 0:
        crs = sc["crs"]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                frame = b["args"][b["args"].index("--sfm-frame") + 1] if "--sfm-frame" in b["args"] else "auto"
                blk = orientation_block(b["eo"], parse_crs(crs), b.get("yaml"), frame, b["images"][:n])
            scale = np.asarray(b.get("scale", (1.0, 1.0)), float)  # per axis (sx, sy)
            if np.any(scale != 1.0):
                blk = _as_ortho_scales(blk, imgs[0])
            try:
                from fotogeo.io.block import match_keys
            except ImportError:  # a fotogeo before it (a run comparing trees): exact names only
                def match_keys(names, keys):
                    return {n: n for n in names if n in keys}
            stems = b.get("stems", sc["names"])
            keys = match_keys(stems, blk.shots)  # as ortho matches the files to the file's names
            row.update(sp.measure(blk, sc, b["camera"], scale, {n: keys.get(k, k) for n, k in zip(sc["names"], stems)}))
        except FotogeoError as exc:
            row["read_error"] = str(exc)
    ok = row["exit"] != 0 and by_name(row["message"])
    warned = False
    if row["exit"] == 0:
        ok = row.get("median_m", 1e9) <= MEDIAN_M and row.get("p90_m", 1e9) <= P90_M
        warned = not ok and "stated_m" in row and row.get("median_m", 1e9) <= 3 * row["stated_m"]
    row["verdict"] = ("read right" if row["exit"] == 0 and ok else WARNED if warned else "WRONG IN SILENCE"
                      if row["exit"] == 0 else "refused by name" if ok else "refused, unclear")
    return row


def by_name(message: str) -> bool:
    """A refusal names its fix: the option to give (``--x``), whole — after any cut ("…": one_line shortens the
    detail before the fix, never the fix); naming the input ("$W/…") alone is no fix."""
    return "--" in message.rpartition("…")[2]


def _as_ortho_scales(block, image):
    """``block`` with its cameras scaled to ``image``'s size as ``ortho`` scales them (resized images)."""
    from dataclasses import replace

    from fotogeo.io.raster import open_raster
    from fotogeo.tools.common.checks import camera_for_image
    info = open_raster(image, "image")
    cams = {k: replace(c, camera=camera_for_image(c.camera, info.width, info.height, image, "bench")[0])
            for k, c in block.cameras.items()}
    return replace(block, cameras=cams)


def table(rows) -> str:
    out = ["| id | case | exit | median / p90 shift (m) | centre (m) / angle (°) | verdict | message |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        sh = f"{r['median_m']:.4f} / {r['p90_m']:.4f}" if "median_m" in r else "–"
        ce = f"{r['centre_m']:.4f} / {r['angle_deg']:.4f}" if "centre_m" in r else "–"
        msg = r["message"].replace("|", "\\|")[:400]
        out.append(f"| {r['id']} | {r['case']} | {r['exit']} | {sh} | {ce} | {r['verdict']} | {msg} |")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="comma-separated case ids (default: all)")
    ap.add_argument("--table", default=None, help="also write the case table (Markdown) here")
    ap.add_argument("--work", default=None, help="scratch folder (default: a temporary one)")
    ap.add_argument("--place", choices=("north", "south", "both"), default="both",
                    help="the block at 60° N on the UTM 33/34 edge (640x480), at 33° S on the 18/19 edge (portrait "
                         "480x640, another lens; ids prefixed 'S:'), or both")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "results" / "sfm_projects_bench.json"))
    a = ap.parse_args(argv)
    warnings.filterwarnings("ignore", message="Dataset has no geotransform")
    work = Path(a.work or tempfile.mkdtemp(prefix="sfm_projects_"))
    wanted = set(filter(None, a.only.split(",")))
    rows, places = [], []
    for place, prefix, spec in (("north", "", None), ("south", "S:", sp.SOUTH)):
        if a.place not in (place, "both"):
            continue
        sc = sp.scene(work / place / "scene", place=spec)
        places.append({"place": place, "crs": sc["crs"], "size": list(sc["size"]),
                       "lat_lon": [spec["lat"], spec["lon"]] if spec else [sp.LAT, sp.LON]})
        for cid, what, build in cases(sc, work / place):
            if wanted and cid not in wanted and prefix + cid not in wanted:
                continue
            r = run_case(prefix + cid, what, build, sc, work / place)
            r["message"], r["command"] = (r[k].replace(f"$W/{place}", "$W") for k in ("message", "command"))
            rows.append(r)
            print(f"{prefix + cid:26s} exit {r['exit']}  {r.get('median_m', float('nan')):.4f}/"
                  f"{r.get('p90_m', float('nan')):.4f} m  {r['verdict']}: {r['message'][:160]}", flush=True)
    if not wanted and a.place == "both":
        Path(a.out).write_text(json.dumps({"places": places, "rows": rows}, indent=1) + "\n")
    if a.table:
        Path(a.table).parent.mkdir(parents=True, exist_ok=True)
        Path(a.table).write_text(table(rows))
    counts = {v: sum(r["verdict"] == v for r in rows) for v in dict.fromkeys(r["verdict"] for r in rows)}
    print(f"{len(rows)} cases: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    return 0 if all(r["verdict"] in ("read right", "refused by name", WARNED) for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
