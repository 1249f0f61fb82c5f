"""``fotogeo dsm`` on data the DSM benchmarks never tuned on: truth (or a reference DSM) against the result.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_heldout_bench.py [--groups rpc,frames,ebee] [--cases NAMES]
      [--work DIR] [--tree OTHER_CHECKOUT] [--rpc-dems none,true,srtm,smooth-20,+50]

Every DSM is made as a user makes it: ``python -m fotogeo dsm ...`` in a child process under ``/usr/bin/time -v``
(``cwd`` outside any checkout, ``PYTHONPATH`` this tree): user + system CPU and peak memory per row; the row keeps
the command (paths relative to the case's folder). ``--tree DIR``: the DSMs made by another checkout (e.g. the
main branch, for a before/after), its rows keyed by its path.

* ``rpc`` — rendered satellite pairs (``tests/rendered_rpc_pair.py``: pushbroom views from 700 km, RPCs fitted to
  the exact geometry) at sizes, base-to-height ratios, relief and seeds the ``rendered_rpc`` rows of
  ``dsm_bench.py`` do not use, and the same pair rescaled to 8 bits (uint8 GeoTIFF, RPC tags copied): ``dsm A B
  --rpc --resolution 0.5``. RMSE, NMAD, median of DSM − truth, completeness (the cells both images see that have a
  height) — :func:`rendered_rpc_pair.compare` —, and ``completeness_visible``: the same over the cells neither
  view sees hidden behind a wall or a hill.
* ``frames`` — rendered frame blocks (``tests/dsm_scenes.py``'s simulator) with cameras unlike the benchmark's: a
  long focal length from high up, a wide angle with strong Brown distortion, a small sensor low over steep relief,
  a 3-strip block: ``dsm IMGS --camera C --eo EO`` against the true surface (RMSE, NMAD, median, share of the
  cells inside the frames' ground footprints that have a height, in GSD units too).
* ``ebee`` — the eBee flight of ``drone_snowpeak`` (8 frames, two strips and a strip turn), triangulated whole
  (``fotogeo triangulate *.JPG -o all``): the DSM of all frames is the reference; DSMs of held-out pairs and triples
  (``--pairs``) on the same orientation and grid, and of copies of the frames resized to 1/2 and 1/4 (as a user
  downsizes: ``cv2.resize`` INTER_AREA, EXIF kept) triangulated and made on their own: NMAD, median of the
  difference from the all-frame DSM and the share of the reference's cells that have a height.

Prints a table and writes benchmarks/results/dsm_heldout_bench.json (a row run now replaces the row of the same
name; each row carries its command and the load average at its start).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "benchmarks")]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "benchmarks" / "results" / "dsm_heldout_bench.json"
PY = [sys.executable, "-m", "fotogeo"]
#: the fotogeo checkout measured (``--tree``): its root goes first on the children's PYTHONPATH
TREE = ROOT
#: rpc cases: name -> render_rpc_pair keywords (+ "uint8": rescaled copies)
RPC = {"700², B/H 0.4": {"size": 700}, "700², B/H 0.25": {"size": 700, "base_height": 0.25},
       "700², B/H 0.6": {"size": 700, "base_height": 0.6}, "700², relief 60 m, seed 3": {"size": 700, "relief": 60.0,
                                                                                         "seed": 3},
       "700², uint8": {"size": 700, "uint8": True}, "1500², B/H 0.4, seed 5": {"size": 1500, "seed": 5}}
#: frame cases: name -> dsm_scenes._simulated keywords (camera as (focal mm, sensor mm, pixels))
FRAMES = {
    "long focal 12 mm, 1500 m": dict(seed=21, strips=1, frames_per_strip=3, camera=(12.0, (4.8, 3.6), (480, 360)),
                                     flying_height=1500.0, relief=50.0, point_spacing=80.0, margin=5.0),
    "wide 3 mm, strong distortion": dict(seed=22, strips=1, frames_per_strip=3, camera=(3.0, (4.8, 3.6), (480, 360)),
                                         flying_height=400.0, relief=30.0, point_spacing=40.0, margin=5.0,
                                         true_distortion=(-0.12, 0.03, 0.0, 0.0005, -0.0004)),
    "small sensor, 150 m, steep": dict(seed=23, strips=1, frames_per_strip=3, camera=(4.3, (3.2, 2.4), (400, 300)),
                                       flying_height=150.0, relief=25.0, point_spacing=20.0, margin=5.0,
                                       true_distortion=(-0.03, 0.0, 0.0, 0.0, 0.0)),
    "3 strips x 3, 80 % overlap": dict(seed=24, strips=3, frames_per_strip=3, forward_overlap=0.8, side_overlap=0.3,
                                       camera=(8.0, (6.4, 4.8), (400, 300)), flying_height=900.0, relief=40.0,
                                       point_spacing=60.0, margin=5.0)}
EBEE = ["IMG_2186", "IMG_2188", "IMG_2189", "IMG_2212", "IMG_2213", "IMG_2280", "IMG_2281", "IMG_2282"]
EBEE_SUBSETS = {"pair 2186/2188": ["IMG_2186", "IMG_2188"], "pair 2281/2282": ["IMG_2281", "IMG_2282"],
                "triple 2186/2188/2189": ["IMG_2186", "IMG_2188", "IMG_2189"],
                "pair 2212/2213 (strip turn)": ["IMG_2212", "IMG_2213"]}
EBEE_CRS, EBEE_RES = "EPSG:32654", 0.25


def time_v(cmd: list, cwd: Path) -> dict:
    """``cmd`` under ``/usr/bin/time -v`` from ``cwd``: user + system CPU (s), peak memory (MiB), exit code, the last
    stderr line (a refusal's message)."""
    r = subprocess.run(["/usr/bin/time", "-v", *map(str, cmd)], capture_output=True, text=True, cwd=cwd,
                       env=dict(os.environ, PYTHONPATH=str(TREE), GDAL_PAM_ENABLED="NO"))
    num = {k: float(re.search(rf"{k}.*: ([\d.]+)", r.stderr).group(1))
           for k in ("User time", "System time", "Maximum resident set size")}
    lines = [s for s in r.stderr.splitlines()
             if s.strip() and not s.startswith(("\t", "Command being", "Command exited"))]
    out = {"cpu_s": round(num["User time"] + num["System time"], 1),
           "peak_rss_mib": round(num["Maximum resident set size"] / 1024), "exit": r.returncode}
    if r.returncode:
        out["message"] = lines[-1][:300] if lines else ""
    return out


def _command(cmd: list, folder: Path) -> str:
    return "python " + " ".join(str(c).replace(str(folder) + "/", "").replace(str(folder.parent) + "/", "../")
                                for c in cmd[1:])


def _uint8_copy(paths: list, folder: Path) -> list:
    """The images rescaled to 8 bits (their 0.1–99.9 % range), RPC tags copied: what a user's 8-bit export is."""
    import rasterio
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for p in paths:
        with rasterio.open(p) as src:
            a, rpc = src.read(1).astype(np.float32), src.tags(ns="RPC")
            lo, hi = np.percentile(a, (0.1, 99.9))
            prof = {**src.profile, "dtype": "uint8", "nbits": 8}
        q = folder / Path(p).name
        with rasterio.open(q, "w", **prof) as dst:
            dst.write(np.clip(np.round(1 + 254 * (a - lo) / (hi - lo)), 1, 255).astype(np.uint8)[None])
            dst.update_tags(ns="RPC", **rpc)
        out.append(str(q))
    return out


def _visible_completeness(dsm_path, sc, step: int = 3) -> float:
    """The share of the cells both images see *unoccluded* that have a height (every ``step``-th cell): a cell is
    seen as :func:`unoccluded` says. :func:`rendered_rpc_pair.compare`'s completeness counts the cells inside both
    images, walls' shadows included."""
    import rasterio
    with rasterio.open(dsm_path) as ds:
        h, dt, nod = ds.read(1)[::step, ::step], ds.transform, ds.nodata
    rr, cc = np.mgrid[0:h.shape[0], 0:h.shape[1]] * step
    x, y = (np.asarray(v).ravel() for v in dt * (cc + 0.5, rr + 0.5))
    return round(float((h.ravel() != nod)[unoccluded(x, y, sc)].mean()), 3)


def unoccluded(x, y, sc) -> np.ndarray:
    """Whether both views of the rendered scene ``sc`` see the map points ``x, y`` (on the truth): inside each image
    and the first surface point on the line of sight of its pixel (the renderer's own ``_first_hit``) within one
    truth cell of it."""
    from rendered_rpc_pair import _first_hit, _sample
    z = _sample(sc["truth"], sc["truth_transform"], x, y)
    seen = np.ones(x.shape, bool)
    for cam in sc["cameras"]:
        c, r = cam.ground_to_image(x, y, z)
        seen &= (c >= 0) & (c < cam.n) & (r >= 0) & (r < cam.n)
        xs, ys, _ = _first_hit(cam, sc["truth"], sc["truth_transform"], c, r)
        seen &= np.hypot(xs - x, ys - y) <= abs(sc["truth_transform"].a)
    return seen


def rpc_rows(work: Path, names, dems=("none",), save=None) -> list:
    """The ``rpc`` group; ``dems`` (``--rpc-dems``): each case once per DEM of ``dsm_dem_bench.DEMS`` made from the
    truth averaged to 20 m (:func:`_rpc_dem`; ``none``: without ``--dem``), its rows named ``NAME, --dem DEM`` with
    the report's fit of the DEM."""
    from rendered_rpc_pair import compare, render_rpc_pair
    rows = []
    for name, kw in RPC.items():
        if names and name not in names:
            continue
        kw = dict(kw)
        u8 = kw.pop("uint8", False)
        folder = work / "rpc" / re.sub(r"[^\w]+", "_", name)
        sc = render_rpc_pair(folder, **kw)
        images = _uint8_copy(sc["images"], folder / "u8") if u8 else sc["images"]
        for dem in dems:
            tail = "" if dem == "none" else "_" + re.sub(r"[^\w]+", "_", dem)
            cmd = PY + ["dsm", *images, "--rpc", "-o", folder / f"dsm{tail}.tif", "--resolution", "0.5",
                        "--overwrite", "--report", folder / f"report{tail}.json"]
            if dem != "none":
                cmd += ["--dem", _rpc_dem(sc, folder, dem), "--dem-heights", "ellipsoid"]
            case = name + ("" if dem == "none" else f", --dem {dem}")
            row = {"group": "rpc", "case": case, "gsd_m": sc["gsd"], **time_v(cmd, folder)}
            if row["exit"] == 0:
                row.update({k: (round(v, 3) if isinstance(v, float) else v)
                            for k, v in compare(folder / f"dsm{tail}.tif", sc).items()})
                row["rmse_gsd"] = round(row["rmse_m"] / sc["gsd"], 2)
                row["completeness_visible"] = _visible_completeness(folder / f"dsm{tail}.tif", sc)
                if dem != "none":
                    row["dem"] = json.loads((folder / f"report{tail}.json").read_text())["pairs"][0].get("dem")
            rows.append({**row, "command": _command(cmd, folder)})
            print(rows[-1], flush=True)
            if save:  # a long run keeps its rows as they come
                save(rows)
    return rows


def _rpc_dem(sc: dict, folder: Path, name: str) -> Path:
    """DEM ``name`` of ``dsm_dem_bench.DEMS`` made from the scene's truth averaged to 20 m cells."""
    import rasterio
    from rasterio.transform import Affine

    from dsm_dem_bench import degraded
    t, z = sc["truth_transform"], sc["truth"]
    k = int(round(20.0 / t.a))
    n = (z.shape[0] // k, z.shape[1] // k)
    z = z[:n[0] * k, :n[1] * k].reshape(n[0], k, n[1], k).mean(axis=(1, 3))
    with rasterio.open(folder / "ref20.tif", "w", driver="GTiff", width=n[1], height=n[0], count=1, dtype="float32",
                       crs=sc["crs"], transform=t * Affine.scale(k)) as ds:
        ds.write(z.astype(np.float32)[None])
    return Path(degraded(folder / "ref20.tif", folder / f"dem_{name}.tif", name, 20.0))


def _footprint_share(dsm_path, sc) -> dict:
    """DSM − truth (:func:`dsm_scenes.compare`) and the share of the cells seen by at least two frames (their
    pinhole geometry at the true heights, 5 % of each side left out for the lens distortion) that have a height."""
    import rasterio

    from dsm_scenes import compare
    from fotogeo.geometry.camera import OrientedFrame
    from fotogeo.io.camera import read_camera_with_distortion, read_exterior_orientation
    cam = read_camera_with_distortion(sc["camera"])[0]
    eos = read_exterior_orientation(sc["eo"])
    with rasterio.open(dsm_path) as ds:
        h, t, nod = ds.read(1), ds.transform, ds.nodata
    rr, cc = np.indices(h.shape)
    X, Y = t.c + (cc + 0.5) * t.a, t.f + (rr + 0.5) * t.e
    Z = sc["surface"](np.column_stack([X.ravel(), Y.ravel()]))
    seen = np.zeros(h.size, int)
    for eo in eos.values():
        px = OrientedFrame(cam, eo).world_to_pixel(np.column_stack([X.ravel(), Y.ravel(), Z]))
        w, hh = cam.image_size
        mw, mh = 0.05 * w, 0.05 * hh  # the pinhole footprint less 5 %: the distortion moves the edges
        seen += (px[:, 0] >= mw) & (px[:, 0] < w - mw) & (px[:, 1] >= mh) & (px[:, 1] < hh - mh)
    both = seen >= 2
    c = compare(dsm_path, sc["surface"])
    return {"rmse_m": round(c["rmse"], 3), "nmad_m": round(c["nmad"], 3), "median_m": round(c["median"], 3),
            "rmse_gsd": round(c["rmse"] / sc["gsd"], 2), "within_1gsd": round(float(np.mean(c["abs"] <= sc["gsd"])), 3),
            "completeness": round(float((h.ravel() != nod)[both].mean()), 3)}


def frame_rows(work: Path, names) -> list:
    from dsm_scenes import _simulated
    from fotogeo.geometry.camera import FrameCamera
    rows = []
    for name, kw in FRAMES.items():
        if names and name not in names:
            continue
        folder = work / "frames" / re.sub(r"[^\w]+", "_", name)
        folder.mkdir(parents=True, exist_ok=True)
        f, s, px = kw["camera"]
        sc = _simulated(folder, **{**kw, "camera": FrameCamera(f, s, px)})
        cmd = PY + ["dsm", *sc["images"], "--camera", sc["camera"], "--eo", sc["eo"], "--crs", sc["crs"], "-o",
                    folder / "dsm.tif", "--overwrite", "--report", folder / "report.json"]
        row = {"group": "frames", "case": name, "gsd_m": round(sc["gsd"], 3), **time_v(cmd, folder)}
        if row["exit"] == 0:
            row.update(_footprint_share(folder / "dsm.tif", sc))
        rows.append({**row, "command": _command(cmd, folder)})
        print(rows[-1], flush=True)
    return rows


def _versus(path, ref) -> dict:
    """``path`` − ``ref`` (the all-frame DSM; ``path`` resampled bilinearly onto its grid when it has another):
    median, NMAD, the share of the reference's cells that have a height here."""
    import rasterio
    from rasterio.warp import Resampling, reproject
    with rasterio.open(ref) as r:
        z0, nod0, t0, crs = r.read(1), r.nodata, r.transform, r.crs
    with rasterio.open(path) as s:
        z = np.full(z0.shape, np.nan, np.float32)
        reproject(rasterio.band(s, 1), z, dst_transform=t0, dst_crs=crs, dst_nodata=np.nan,
                  resampling=Resampling.bilinear)
    v0 = z0 != nod0
    both = v0 & np.isfinite(z)
    d = (z - z0)[both].astype(np.float64)
    med = float(np.median(d)) if d.size else float("nan")
    return {"median_m": round(med, 3), "nmad_m": round(float(1.4826 * np.median(np.abs(d - med))), 3)
            if d.size else None, "share_of_reference": round(float(both.sum() / max(v0.sum(), 1)), 3)}


def _resized(src: Path, folder: Path, factor: int) -> list:
    """Copies of the eBee frames resized by ``1/factor`` (INTER_AREA), their EXIF (GPS, focal length) kept and their
    XMP (attitude) dropped, as PIL's ``save(exif=...)`` leaves them (see ``resized_frames_bench.py``)."""
    import cv2
    from PIL import Image
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for n in EBEE:
        q = folder / f"{n}.JPG"
        if not q.is_file():
            im = Image.open(src / f"{n}.JPG")
            a = cv2.resize(np.asarray(im), (im.width // factor, im.height // factor), interpolation=cv2.INTER_AREA)
            Image.fromarray(a).save(q, quality=92, exif=im.info.get("exif", b""))
        out.append(q)
    return out


def _copied(src: Path, folder: Path) -> list:
    folder.mkdir(parents=True, exist_ok=True)
    return [q if q.is_file() else Path(shutil.copy(src / q.name, q)) for q in (folder / f"{n}.JPG" for n in EBEE)]


def ebee_rows(work: Path, names) -> list:
    src = DATA / "drone_snowpeak" / "img"
    if not src.is_dir():
        print("ebee: skipped, no drone_snowpeak in", DATA)
        return []
    rows, sets = [], {"all": (work / "ebee" / "full", 1), "resized 1/2": (work / "ebee" / "half", 2),
                      "resized 1/4": (work / "ebee" / "quarter", 4)}
    ref = None
    for label, (folder, factor) in sets.items():
        if names and label != "all" and not any(n.startswith(label) for n in names):
            continue
        imgs = _resized(src, folder, factor) if factor > 1 else _copied(src, folder)
        ori = folder / "all"
        tri = PY + ["triangulate", *imgs, "-o", ori, "--overwrite"]
        if not (ori / "exterior_orientation.txt").is_file():
            r = time_v(tri, folder)
            rows.append({"group": "ebee", "case": f"triangulate {label}", **r, "command": _command(tri, folder)})
            print(rows[-1], flush=True)
            if r["exit"]:
                continue
        oriented = [n for n in EBEE if any(line.split()[:1] == [n] for line in
                                           (ori / "exterior_orientation.txt").read_text().splitlines())]
        todo = [(f"{label}: all {len(oriented)} oriented frames", oriented, ori)]
        if factor == 1:
            full_ori = ori
            todo += [(f"{k} (held out)", v, ori) for k, v in EBEE_SUBSETS.items()]
        elif ref is not None:  # the resized copies with the full-size frames' orientation folder
            todo += [(f"{label}: all {len(oriented)} frames, the full-size orientation", oriented, full_ori)]
        for case, subset, orientation in todo:
            tag = re.sub(r"[^\w]+", "_", case)
            out = folder / f"dsm_{tag}.tif"
            cmd = PY + ["dsm", *[folder / f"{n}.JPG" for n in subset], "--orientation", orientation, "--crs",
                        EBEE_CRS, "--resolution", str(EBEE_RES), "-o", out, "--overwrite", "--report",
                        folder / f"{tag}.json"]
            if ref is not None:
                cmd += ["--bounds", ",".join(f"{v:.3f}" for v in ref_bounds)]
            elif names and case not in names and out.is_file():  # the reference made before, not asked for again
                import rasterio
                ref = out
                with rasterio.open(ref) as ds:
                    ref_bounds = tuple(ds.bounds)
                continue
            if names and case not in names and ref != out:
                continue
            row = {"group": "ebee", "case": case, **time_v(cmd, folder)}
            if row["exit"] == 0:
                if ref is None:
                    import rasterio
                    ref = out
                    with rasterio.open(ref) as ds:
                        ref_bounds = tuple(ds.bounds)
                        z = ds.read(1)
                        row["cells_with_height"] = int((z != ds.nodata).sum())
                        row["report_completeness"] = json.loads((folder / f"{tag}.json").read_text()).get(
                            "completeness")
                else:
                    row.update(_versus(out, ref))
            rows.append({**row, "command": _command(cmd, folder)})
            print(rows[-1], flush=True)
    return rows


def _save(rows: list, load0) -> None:
    old = json.loads(OUT.read_text()) if OUT.is_file() else {"rows": []}
    stamp = {"load_average": round(load0, 1), "date": time.strftime("%Y-%m-%d"),
             **({} if TREE == ROOT else {"tree": str(TREE)})}
    key = lambda r: (r["group"], r["case"], r.get("tree", "this checkout"))  # noqa: E731
    new = {key({**r, **stamp}) for r in rows}
    kept = [r for r in old["rows"] if key(r) not in new]
    OUT.write_text(json.dumps({"rows": kept + [{**r, **stamp} for r in rows]}, indent=1, ensure_ascii=False))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--groups", default="rpc,frames,ebee")
    ap.add_argument("--cases", default=None, help="case names separated by ';' [all of each group]")
    ap.add_argument("--work", default="/tmp/dsm_heldout_bench", help="renders and DSMs go here (reused)")
    ap.add_argument("--tree", default=str(ROOT), help="the fotogeo checkout measured (its rows carry its path)")
    ap.add_argument("--rpc-dems", default="none", help="rpc: also with these DEMs (dsm_dem_bench.DEMS), e.g. none,srtm")
    a = ap.parse_args()
    global TREE
    TREE = Path(a.tree).resolve()
    work = Path(a.work).resolve()
    names = set(a.cases.split(";")) if a.cases else None
    load0, rows = os.getloadavg()[0], []
    groups = {"rpc": lambda w, n: rpc_rows(w, n, a.rpc_dems.split(","), lambda r: _save(rows + r, load0)),
              "frames": frame_rows, "ebee": ebee_rows}
    for g in a.groups.split(","):
        rows += groups[g](work, names)
        _save(rows, load0)
    head = ("group", "case", "exit", "rmse_m", "nmad_m", "median_m", "completeness", "share_of_reference", "cpu_s",
            "peak_rss_mib")
    print(" | ".join(head))
    for r in rows:
        print(" | ".join(str(r.get(k, "")) for k in head))


if __name__ == "__main__":
    main()
