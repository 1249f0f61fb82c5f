"""Uniform ground against the texture rule of dense matching (issue 30: a lake, a grey patch, snow).

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_uniform_bench.py [--cases lake,patch,plain,ebee]
      [--label NAME] [--ebee-dir DIR]

* ``lake`` — ``tests/dsm_scenes.py``'s ``nadir_lake`` (the ``nadir`` block, 2 x 4 frames 1000 m above ±40 m, its
  ground a constant grey over a disc of 160 m radius, each frame with its own noise of 2 levels): the cells on the
  disc (and within 2 GSD of it) with a height, those more than 5 m and more than 1 GSD off the truth, and the
  completeness outside it (cells with a height over the cells of the plain ``nadir`` DSM's footprint);
* ``patch`` — ``nadir_grey_patch`` (a rectangle of every other frame a constant grey plus noise): the cells more
  than 5 m and 1 GSD off, completeness over the plain DSM's footprint;
* ``plain`` — ``nadir`` itself: the same counts (what the textured ground gives);
* ``ebee`` — the eBee snow pair IMG_2280/IMG_2281 of ``drone_snowpeak`` (``fotogeo dsm`` at 0.2 m as
  ``dsm_bench.py --cases ebee`` runs it, oriented with IMG_2282 (:func:`_ebee_oriented`); ``--ebee-dir`` keeps
  its orientation): the pair's match density (pixels
  kept of the matchable ones), the cells with a height, and, against ``--ebee-reference`` (a DSM of the same run
  before the change), the cells kept of its cells and the NMAD and largest difference on the common cells.

Each case runs ``fotogeo dsm`` in a child process under ``/usr/bin/time -v`` (user + system CPU). Prints a table
and writes ``benchmarks/results/dsm_uniform_bench.json``: per ``--label`` (e.g. ``before``, run with the tree of
the session's base on ``PYTHONPATH`` through ``--tree``, and ``after``) its rows.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "benchmarks")]
from dsm_bench_run import _time_v  # noqa: E402

DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "benchmarks" / "results" / "dsm_uniform_bench.json"


def _dsm(sc: dict, out: Path, tree: Path, cwd: Path) -> tuple:
    rep = out.with_suffix(".json")
    t = _time_v([sys.executable, "-m", "fotogeo", "dsm", *map(str, sc["images"]), "--camera", str(sc["camera"]),
                 "--eo", str(sc["eo"]), "--crs", sc["crs"], "-o", str(out), "--report", str(rep), "--overwrite"],
                cwd=cwd, tree=tree)
    return t, json.loads(rep.read_text())


def _cells(path):
    """``(heights (NaN: none), X, Y)`` of a DSM's cell centres."""
    import rasterio
    with rasterio.open(path) as ds:
        h = ds.read(1).astype(float)
        t, nod = ds.transform, ds.nodata
    h[h == nod] = np.nan
    rows, cols = np.indices(h.shape)
    return h, t.c + (cols + 0.5) * t.a, t.f + (rows + 0.5) * t.e


def _footprint(plain: Path, X, Y):
    """The cells of the grid ``X, Y`` that lie on a cell with a height in the plain ``nadir`` DSM."""
    import rasterio
    with rasterio.open(plain) as ds:
        h, t, nod = ds.read(1), ds.transform, ds.nodata
    c, r = ((X - t.c) / t.a).astype(int), ((Y - t.f) / t.e).astype(int)
    inside = (r >= 0) & (r < h.shape[0]) & (c >= 0) & (c < h.shape[1])
    out = np.zeros(X.shape, bool)
    out[inside] = h[r[inside], c[inside]] != nod
    return out


def rendered(kind: str, tmp: Path, tree: Path, plain: Path | None) -> dict:
    from dsm_scenes import make_scene
    sc = make_scene(kind, tmp / kind)
    out = tmp / f"{kind}.tif"
    t, rep = _dsm(sc, out, tree, tmp)
    h, X, Y = _cells(out)
    XY = np.column_stack([X.ravel(), Y.ravel()])
    err = np.abs(h.ravel() - sc["surface"](XY)).reshape(h.shape)
    g, ok = sc["gsd"], np.isfinite(h)
    row = {"case": kind, "gsd_m": g, "cpu_s": t["cpu_s"], "report_completeness": rep["completeness"],
           "cells": int(ok.sum()), "off_5m": int((err[ok] > 5).sum()), "off_1gsd": int((err[ok] > g).sum()),
           "max_error_m": float(err[ok].max()), "rmse_m": float(np.sqrt(np.mean(err[ok] ** 2))),
           "match_density": [p.get("match_density") for p in rep["pairs"] if p.get("kept", True)]}
    foot = _footprint(plain, X, Y) if plain is not None else np.ones(h.shape, bool)
    if sc.get("region") is not None:
        on = sc["region"](XY).reshape(h.shape)
        from scipy.ndimage import binary_dilation
        near = binary_dilation(on, iterations=2)
        row.update(region_cells=int(on.sum()), region_with_height=int((ok & on).sum()),
                   region_off_5m=int((ok & near & (err > 5)).sum()), region_off_1gsd=int((ok & near & (err > g)).sum()),
                   completeness_outside=float((ok & ~near & foot).sum() / max(1, (~near & foot).sum())))
    else:
        row["completeness_footprint"] = float((ok & foot).sum() / max(1, foot.sum()))
    return row


def ebee(tmp: Path, tree: Path, keep, reference) -> dict:
    tmp.mkdir(parents=True, exist_ok=True)
    imgs, strip = _ebee_oriented(tmp, keep)
    out, rep = tmp / "ebee.tif", tmp / "ebee.json"
    t = _time_v([sys.executable, "-m", "fotogeo", "dsm", *map(str, imgs), "--orientation", str(strip), "--crs",
                 "EPSG:32654", "-o", str(out), "--report", str(rep), "--resolution", "0.2", "--overwrite"],
                cwd=tmp, tree=tree)
    r = json.loads(rep.read_text())
    h, _, _ = _cells(out)
    row = {"case": "eBee IMG_2280-IMG_2281 0.2 m", "cpu_s": t["cpu_s"], "completeness": r["completeness"],
           "match_density": r["pairs"][0].get("match_density"), "cells": int(np.isfinite(h).sum())}
    if reference:
        g, _, _ = _cells(reference)
        if g.shape == h.shape:
            both = np.isfinite(g) & np.isfinite(h)
            d = h[both] - g[both]
            row.update(reference=str(reference), cells_kept_of_reference=float(both.sum() / np.isfinite(g).sum()),
                       nmad_vs_reference_m=float(1.4826 * np.median(np.abs(d - np.median(d)))),
                       max_abs_vs_reference_m=float(np.abs(d).max()))
    if keep:
        shutil.copy(out, Path(keep) / f"ebee_{os.getpid()}.tif")
        row["dsm"] = str(Path(keep) / f"ebee_{os.getpid()}.tif")
    return row


def _ebee_oriented(tmp: Path, keep=None) -> tuple:
    """``(the pair's images, orientation folder)`` in ``keep`` (else ``tmp``): ``fotogeo triangulate`` of
    IMG_2280–IMG_2282 when absent (the pair alone is refused since 052c5088: its residuals 6.3 times the matching's
    precision with the EXIF camera; ``dsm_bench.py --cases ebee`` fails there), the DSM of IMG_2280/IMG_2281."""
    keep = Path(keep) if keep else tmp
    keep.mkdir(parents=True, exist_ok=True)
    imgs, strip = [keep / f"{n}.JPG" for n in ("IMG_2280", "IMG_2281", "IMG_2282")], keep / "strip3"
    if not (strip / "exterior_orientation.txt").is_file():
        for p in imgs:
            shutil.copy(DATA / "drone_snowpeak" / "img" / p.name, p)
        _time_v([sys.executable, "-m", "fotogeo", "triangulate", *map(str, imgs), "-o", str(strip), "--overwrite"],
                cwd=tmp)
    return imgs[:2], strip


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="plain,lake,patch,ebee")
    ap.add_argument("--label", default="after")
    ap.add_argument("--tree", default=str(ROOT), help="the checkout whose fotogeo runs (default: this one)")
    ap.add_argument("--ebee-dir", help="keeps the eBee images, their orientation and the DSMs between runs")
    ap.add_argument("--ebee-reference", help="a DSM of the eBee pair to compare with (e.g. the base's)")
    args = ap.parse_args()
    tree, rows = Path(args.tree).resolve(), []
    with tempfile.TemporaryDirectory() as d:
        tmp, plain = Path(d), None
        cases = args.cases.split(",")
        if {"lake", "patch"} & set(cases) and "plain" not in cases:
            cases.insert(0, "plain")
        for case in cases:
            if case == "ebee":
                if not (DATA / "drone_snowpeak").is_dir():
                    print("ebee: skipped (no ../shared/data/drone_snowpeak)")
                    continue
                rows.append(ebee(tmp / "ebee", tree, args.ebee_dir, args.ebee_reference))
            else:
                kind = {"plain": "nadir", "lake": "nadir_lake", "patch": "nadir_grey_patch"}[case]
                rows.append(rendered(kind, tmp, tree, plain))
                if case == "plain":
                    plain = tmp / "nadir.tif"
            print(json.dumps(rows[-1]))
            _write(args.label, tree, rows)


def _write(label: str, tree: Path, rows: list) -> None:
    """The run's rows under ``label`` in ``OUT`` (the other labels kept), after each case."""
    old = json.loads(OUT.read_text()) if OUT.is_file() else {}
    old[label] = {"command": " ".join(sys.argv), "tree": str(tree), "load": os.getloadavg(), "rows": rows}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(old, indent=1))


if __name__ == "__main__":
    main()
