"""fotogeo dsm with and without --dem, the DEM as users bring one: coarse, smoothed, offset, with voids (issue 30).

Each case runs once without a DEM and once per DEM of ``DEMS``, made from the case's reference surface (the rendered
scenes' truth; NGI's 24 m DEM, read only; ventoux: the DSM of its own run without a DEM averaged to 20 m): ``true``
the reference itself (rendered: 20 m cells), ``srtm`` 30 m cells (NGI: its 24 m) smoothed by a Gaussian of 1.5
cells, 10 m too high and with a void over the middle ninth, ``smooth-20`` smoothed by 3 cells and 20 m too low,
``+50`` 50 m too high (another vertical reference: named).
Rows: RMSE, NMAD and median of DSM − truth (rendered; NGI: DSM − its 24 m DEM, the issue's done-when: within 3 m
median and 5 m NMAD), completeness, CPU (``time.process_time`` of the run in this process), the DEM's fit of the
first pair (``dem`` of the report: offset, NMAD, margin) and the DEM warnings. ``--tree`` runs another checkout
(e.g. main, the run's "before")::

    PYTHONPATH=. .venv/bin/python benchmarks/dsm_dem_bench.py [--cases rendered,oblique_set,ngi,ventoux,block] \\
        [--dems none,true,srtm,smooth-20,+50] [--rendered nadir,oblique] [--tree ../main] [--ties 25]

``--ties N``: each ``--rpc`` pair (ventoux) keeps N of its tie points (``MIN_TIES`` or more), a random subset
(seed 0). ``block``: a rendered frame pair with a block standing on the ground (``tests/dsm_scenes.py``'s
``nadir_block``; ``narrow_block``: its ``nadir_narrow_block``, 12 m a side), each DEM made from the ground without the
block; rows add the roof's cells within 1.5 m of its height and 1.5 m or more off it, and the ground's RMSE, NMAD and
completeness (:func:`_block_rows`).
"""
from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks")]
import dsm_bench  # noqa: E402  (puts the checkout and its tests on sys.path)

#: name -> (cell m or None: the reference's, Gaussian sigma in cells, offset m, void over the middle ninth)
DEMS = {"true": (None, 0.0, 0.0, False), "srtm": (30.0, 1.5, 10.0, True), "smooth-20": (None, 3.0, -20.0, False),
        "+50": (None, 0.0, 50.0, False)}
#: the rendered scenes' reference DEM reaches this far (m) beyond the projection centres (its middle ninth, the
#: ``srtm`` DEM's void, then covers part of the images, not all)
REF_MARGIN = 300.0
#: the cases (``--cases``)
CASES = ("rendered", "oblique_set", "ngi", "ventoux", "block", "narrow_block")
#: ``--ties``: at least this many (a pair with fewer is refused by ``rpc_pairs.pointing`` itself)
MIN_TIES = 10
#: the oblique set: two frames of ``tests/dsm_oblique_sets.py``'s "1280x960 full" from strips 90 degrees apart
OBLIQUE = ("1280x960 full", ["S1_01", "S2_01"])


def degraded(ref, out: Path, name: str, cell_ref: float) -> str | None:
    """Write DEM ``name`` (:data:`DEMS`) made from the reference GeoTIFF ``ref`` (its cells ``cell_ref`` m) to
    ``out``; None for ``none``."""
    import rasterio
    from rasterio.enums import Resampling
    from scipy.ndimage import gaussian_filter
    if name == "none":
        return None
    cell, sigma, offset, void = DEMS[name]
    with rasterio.open(ref) as ds:
        k = max(1, round((cell or cell_ref) / cell_ref))
        shape = (max(2, ds.height // k), max(2, ds.width // k))
        z = ds.read(1, out_shape=shape, resampling=Resampling.average, masked=True).filled(np.nan).astype(float)
        profile = dict(driver="GTiff", width=shape[1], height=shape[0], count=1, dtype="float32", crs=ds.crs,
                       transform=ds.transform * ds.transform.scale(ds.width / shape[1], ds.height / shape[0]),
                       nodata=-9999.0)
    if sigma:
        z = gaussian_filter(z, sigma, mode="nearest")
    z = z + offset
    if void:
        h, w = z.shape
        z[h // 3:2 * h // 3, w // 3:2 * w // 3] = np.nan
    with rasterio.open(out, "w", **profile) as ds:
        ds.write(np.where(np.isfinite(z), z, -9999.0).astype(np.float32), 1)
    return str(out)


def _row(case: str, dem: str, rep: dict, cpu: float, said: list, err=None) -> dict:
    fit = next((p.get("dem") for p in rep["pairs"] if p.get("dem")), None)
    row = {"case": f"dem {case}, {dem}", "completeness": rep["completeness"], "cpu_s": cpu, "dem_fit": fit,
           "dem_warnings": [s[:160] for s in said if "DEM" in s]}
    if err is not None:
        s = dsm_bench._stats(err)
        row.update(rmse_m=s["rmse"], nmad_m=s["nmad"], median_m=s["median"])
    return row


def _against_truth(out: Path, sc: dict) -> dict:
    """The DSM ``out`` against the scene's true surface: RMSE, NMAD, median (m, and RMSE in GSDs)."""
    from dsm_scenes import compare
    c = compare(out, sc["surface"])
    return dict(rmse_m=c["rmse"], nmad_m=c["nmad"], median_m=c["median"], gsd_m=sc["gsd"],
                rmse_gsd=c["rmse"] / sc["gsd"])


def _scene_runs(tmp: Path, case: str, sc: dict, dems: list, tag: str, ref=None, measure=_against_truth) -> list:
    """The scene ``sc``'s runs with each DEM of ``dems`` made from ``ref`` (a 20 m GeoTIFF; None: the scene's
    surface ``REF_MARGIN`` beyond its projection centres), each row completed by ``measure(DSM, sc)``."""
    from dsm_scenes import write_dem

    from fotogeo.tools.dsm import dsm
    ref = ref or write_dem(sc, tmp / f"{case}_ref.tif", cell=20.0, margin=REF_MARGIN)
    rows = []
    for name in dems:
        dem = degraded(ref, tmp / f"{case}_{name}.tif", name, 20.0)
        out = tmp / f"{case}_{name}.tif".replace(".tif", "_dsm.tif")
        try:
            rep, cpu, _, said = dsm_bench._timed(dsm, sc["images"], out, camera=sc["camera"], eo=sc["eo"],
                                                 crs=sc["crs"], dem=dem)
        except Exception as e:  # a refusal is a row
            rows.append({"case": f"dem {case}, {name}{tag}", "refused": str(e)[:300]})
            continue
        rows.append({**_row(case, name + tag, rep, cpu, said), **measure(out, sc)})
    return rows


def rendered(tmp: Path, dems: list, tag: str, kinds=("nadir", "oblique")) -> list:
    from dsm_scenes import make_scene
    return [r for kind in kinds for r in _scene_runs(tmp, f"rendered {kind}", make_scene(kind, tmp / kind), dems, tag)]


def oblique_set(tmp: Path, dems: list, tag: str) -> list:
    from dsm_oblique_sets import SETS, make_set
    name, frames = OBLIQUE
    sc = make_set({**SETS[name], "frames": frames}, tmp / "set")
    return _scene_runs(tmp, f"oblique set {name} {'-'.join(frames)}", sc, dems, tag)


#: ``block``: roof cells lie this far (m) inside the block's walls; ground cells this far outside them
ROOF_INSET_M, GROUND_OUTSET_M = 2.0, 20.0


def _block_rows(out: Path, sc: dict) -> dict:
    """The DSM ``out`` on the block of the scene ``sc`` (its ``surface``, :func:`dsm_scenes.with_block`): the share
    of its roof's cells (``ROOF_INSET_M`` inside the walls) with a height within 1.5 m of the roof's, with one 1.5 m
    or more off it (a wrong height, not a hole), and RMSE, NMAD and completeness on the ground ``GROUND_OUTSET_M``
    or more outside the walls."""
    import rasterio
    with rasterio.open(out) as ds:
        h, t, nod = ds.read(1).astype(float), ds.transform, ds.nodata
    surface = sc["surface"]
    rows, cols = np.indices(h.shape)
    XY = np.column_stack([(t.c + (cols + 0.5) * t.a).ravel(), (t.f + (rows + 0.5) * t.e).ravel()])
    far = np.abs(XY - np.asarray(surface.centre)).max(axis=1)
    z = np.where(h.ravel() == nod, np.nan, h.ravel())
    roof, ground = far <= surface.side / 2 - ROOF_INSET_M, far >= surface.side / 2 + GROUND_OUTSET_M
    d = z[ground] - surface(XY[ground])
    ok = np.isfinite(d)
    med = float(np.median(d[ok]))
    off = np.abs(z[roof] - surface.roof)
    return {"roof_cells": int(roof.sum()), "roof_within_1_5m": float(np.mean(off < 1.5)),
            "roof_with_height": float(np.mean(np.isfinite(z[roof]))), "roof_off_1_5m": float(np.mean(off >= 1.5)),
            "ground_completeness": float(ok.mean()),
            "ground_rmse_m": float(np.sqrt(np.mean(d[ok] ** 2))), "ground_median_m": med,
            "ground_nmad_m": float(1.4826 * np.median(np.abs(d[ok] - med)))}


def block(tmp: Path, dems: list, tag: str, kind: str = "nadir_block") -> list:
    """The rendered frame pair with a block (``tests/dsm_scenes.py``'s ``kind``: ``nadir_block`` with
    :data:`dsm_scenes.BLOCK`, ``nadir_narrow_block`` with :data:`dsm_scenes.NARROW_BLOCK`, over the ground in their
    overlap) and each DEM made from the ground without the block (covering the images): the roof's cells near its
    height, the roof's cells with a height off it, the ground's error and completeness (:func:`_block_rows`)."""
    from dsm_scenes import make_scene, write_dem
    sc = make_scene(kind, tmp / "scene")
    ref = write_dem({**sc, "surface": sc["surface"].ground}, tmp / "ground_ref.tif", cell=20.0)  # covers the images
    return _scene_runs(tmp, f"rendered nadir with a {sc['surface'].side:g} m block, {len(sc['images'])} frames", sc,
                       dems, tag, ref, _block_rows)


def ngi(tmp: Path, dems: list, tag: str) -> list:
    from fotogeo.tools.dsm import dsm
    d = dsm_bench.DATA / "ngi"
    frames = [d / "frames" / f"3324c_2015_1004_05_{n}_RGB.tif" for n in ("0182", "0184")]
    rows = []
    for name in dems:
        dem = degraded(d / "dem.tif", tmp / f"ngi_{name}.tif", name, 24.0)
        out = tmp / f"ngi_{name}_dsm.tif"
        try:
            rep, cpu, _, said = dsm_bench._timed(dsm, frames, out, camera=d / "interior_orientation.yaml",
                                                 eo=d / "exterior_orientation.txt", crs=dsm_bench.NGI_CRS, dem=dem)
        except Exception as e:
            rows.append({"case": f"dem NGI 0182/0184, {name}{tag}", "refused": str(e)[:300]})
            continue
        rows.append(_row("NGI 0182/0184 vs the 24 m DEM", name + tag, rep, cpu, said,
                         dsm_bench._against(out, d / "dem.tif")))
    return rows


def _averaged(src, out: Path, cell: float, pad: int = 10) -> str:
    """The DSM ``src`` averaged (its nodata left out) onto cells of ``cell`` m, ``pad`` cells wider on every side,
    the cells without a height given the nearest one's (a DEM as users bring one covers the images), written to
    ``out``."""
    import rasterio
    from rasterio.enums import Resampling
    from scipy.ndimage import distance_transform_edt
    with rasterio.open(src) as ds:
        k = max(1, round(cell / abs(ds.transform.a)))
        shape = (max(2, ds.height // k), max(2, ds.width // k))
        z = ds.read(1, out_shape=shape, resampling=Resampling.average, masked=True).filled(np.nan).astype(float)
        t = ds.transform * ds.transform.scale(ds.width / shape[1], ds.height / shape[0])
        crs = ds.crs
    z = np.pad(z, pad, constant_values=np.nan)
    t = t * t.translation(-pad, -pad)
    near = distance_transform_edt(~np.isfinite(z), return_distances=False, return_indices=True)
    z = z[tuple(near)]
    profile = dict(driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype="float32", crs=crs,
                   transform=t, nodata=-9999.0)
    with rasterio.open(out, "w", **profile) as ds:
        ds.write(z.astype(np.float32), 1)
    return str(out)


def ventoux(tmp: Path, dems: list, tag: str) -> list:
    """The Pleiades pair (``--rpc``, 0.5 m; its images and .geom copied as ``dsm_bench.py`` does) with each DEM,
    made from the run without one (the only surface covering the pair here: CARS's covers 42 % of the overlap)
    averaged to 20 m cells; rows: fotogeo − CARS (the recorded run, ``results/peers_cars.json``) where both have a
    height (``peers_cars.compare_dsms``: median, NMAD, share of CARS's cells with a fotogeo height)."""
    import shutil

    from peers_cars import compare_dsms

    from fotogeo.tools.dsm import dsm
    v = dsm_bench.DATA / "rpc" / "ventoux"
    for name, src in (("left.tif", "left_image.tif"), ("left.geom", "left_image.geom"),
                      ("right.tif", "right_image.tif"), ("right.geom", "right_image.geom")):
        shutil.copy(v / src, tmp / name)
    rec = ROOT / "benchmarks" / "results" / "peers_cars.json"
    cars = json.loads(rec.read_text()).get("cars_ventoux_m100", {}).get("dsm") if rec.is_file() else None
    rows, ref = [], None
    for name in ["none"] + [d for d in dems if d != "none"]:
        dem = degraded(ref, tmp / f"dem_{name}.tif", name, 20.0) if ref else None
        out = tmp / f"dsm_{name}.tif"
        try:
            rep, cpu, _, said = dsm_bench._timed(dsm, [tmp / "left.tif", tmp / "right.tif"], out, rpc=True,
                                                 resolution=0.5, dem=dem)
        except Exception as e:
            rows.append({"case": f"dem ventoux, {name}{tag}", "refused": str(e)[:300]})
            continue
        if ref is None:
            ref = _averaged(out, tmp / "ref20.tif", 20.0)
        row = _row("ventoux (--rpc, 0.5 m) vs CARS", name + tag, rep, cpu, said)
        row["height_range_m"] = rep["pairs"][0].get("height_range")
        if cars and Path(cars).is_file():
            row["fotogeo_minus_cars"] = compare_dsms(out, cars)
        if name in dems:
            rows.append(row)
    return rows


def _thin_ties(n: int) -> None:
    """``dsm --rpc`` pairs keep ``n`` of their tie points (a random subset, seed 0), as a pair with few of them."""
    from fotogeo.tools.dsm import rpc_pairs
    pointing = rpc_pairs.pointing

    def thinned(*a, **k):
        pt = pointing(*a, **k)
        keep = np.sort(np.random.default_rng(0).choice(len(pt["z"]), min(n, len(pt["z"])), replace=False))
        return {**pt, "z": pt["z"][keep], "p1": pt["p1"][keep], "n": len(keep)}
    rpc_pairs.pointing = thinned


def use_tree(tree) -> str:
    """Put the checkout ``tree`` (None: this one) first on ``sys.path``, before fotogeo is imported; the rows' tag
    naming it."""
    if not tree:
        return ""
    sys.path.insert(0, str(Path(tree).resolve()))
    return f" ({Path(tree).resolve().name})"


def main():
    import tempfile
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="rendered,oblique_set,ngi")
    ap.add_argument("--dems", default="none,true,srtm,smooth-20,+50")
    ap.add_argument("--rendered", default="nadir,oblique", help="rendered: these scenes of tests/dsm_scenes.py")
    ap.add_argument("--tree", help="run this checkout's fotogeo (e.g. ../main: the before); rows name it")
    ap.add_argument("--ties", type=int, help="ventoux: keep this many of the pair's tie points (random, seed 0)")
    args = ap.parse_args()
    bad = [c for c in args.cases.split(",") if c not in CASES]
    if bad:
        ap.error(f"--cases {','.join(bad)}: not a case; give some of {','.join(CASES)}")
    if args.ties is not None and args.ties < MIN_TIES:
        ap.error(f"--ties {args.ties}: a pair with fewer than {MIN_TIES} tie points is refused when set up; give "
                 f"--ties {MIN_TIES} or more, or leave it out for all of them")
    tag = use_tree(args.tree)
    import fotogeo
    if args.ties is not None:
        tag += f", {args.ties} tie points"
        _thin_ties(args.ties)
    os.environ.setdefault("GDAL_PAM_ENABLED", "NO")
    dems, load0 = args.dems.split(","), os.getloadavg()
    out = ROOT / "benchmarks" / "results" / "dsm_dem_bench.json"
    run = {"command": " ".join(sys.argv), "fotogeo": str(Path(fotogeo.__file__).parent),
           "started": time.strftime("%Y-%m-%dT%H:%M:%S"), "rows": []}
    with tempfile.TemporaryDirectory(prefix="dsm_dem_bench_") as t:
        for case in args.cases.split(","):
            (Path(t) / case).mkdir()
            new = {"rendered": functools.partial(rendered, kinds=args.rendered.split(",")), "oblique_set": oblique_set,
                   "ngi": ngi, "ventoux": ventoux,
                   "block": block, "narrow_block": functools.partial(block, kind="nadir_narrow_block")}[case](
                       Path(t) / case, dems, tag)
            for r in new:
                print(json.dumps(r, default=str), flush=True)
            run["rows"] += new
            run["load_average"] = [load0, os.getloadavg()]
            runs = json.loads(out.read_text()).get("runs", []) if out.is_file() else []
            runs = [r for r in runs if r.get("started") != run["started"]]  # this run's rows so far: once
            out.write_text(json.dumps({"runs": runs + [run]}, indent=1, default=str) + "\n")
    print(f"-> {out}")


if __name__ == "__main__":
    main()
