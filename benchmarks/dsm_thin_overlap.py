"""The relative pointing correction of ``dsm --rpc`` on the ventoux pair cut to thin overlaps (issue 30).

Run:  PYTHONPATH=. .venv/bin/python benchmarks/dsm_thin_overlap.py [--label TEXT] [--scratch DIR]

The Pleiades pair ``rpc/ventoux`` (right column ≈ left column + 83, right row ≈ left row − 330 + parallax) is cut by
``gdal_translate -srcwin`` (the windows' places kept in their geotransforms, the OSSIM .geom copied beside each cut)
so that the two cuts share ``W`` columns (the left image's columns 250–500, the right's 0 to 250 + W + 83) or a few
rows (``ROW_CUTS``: along the epipolar lines, so the shared rows vary with the parallax). For each cut the correction is computed as ``dsm
--rpc`` does (:func:`fotogeo.tools.dsm.rpc_pairs.pointing`) and compared with the uncut pair's: the table gives the
tie points, those agreeing, ``τ``, its distance from the uncut ``τ`` and the median residual after, or the refusal.
Run it with ``PYTHONPATH`` a checkout before a change (``--label before``) and after to compare. Writes
benchmarks/results/dsm_thin_overlap.json (a row of the same label and case is replaced).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "dsm_thin_overlap.json"
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
#: shared columns W: the left image's columns 250–500, the right's 0–(250 + W + 83)
COLUMN_CUTS = (6, 12, 20, 30, 47, 80, 150)
#: (left srcwin, right srcwin) of cuts along the other axis (about 15, 25 and 40 shared rows)
ROW_CUTS = {"rows 15": ((0, 430, 500, 70), (0, 0, 498, 115)), "rows 25": ((0, 400, 500, 100), (0, 0, 498, 95)),
            "rows 40": ((0, 380, 500, 120), (0, 0, 498, 90))}


def _cut(folder: Path, left, right) -> list:
    from osgeo import gdal
    v = DATA / "rpc" / "ventoux"
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for side, window in (("left", left), ("right", right)):
        if window is None:
            shutil.copy(v / f"{side}_image.tif", folder / f"{side}.tif")
        else:
            gdal.Translate(str(folder / f"{side}.tif"), str(v / f"{side}_image.tif"), srcWin=list(window))
        shutil.copy(v / f"{side}_image.geom", folder / f"{side}.geom")
        out.append(folder / f"{side}.tif")
    return out


def _pointing(images) -> dict:
    from fotogeo.errors import InputError
    from fotogeo.tools.dsm import rpc_pairs as rp
    from fotogeo.tools.dsm import rpc_tool as rt
    from fotogeo.tools.dsm.inputs import SourceImage
    ims, _, _ = rt.rpc_images(images, None, None)
    zlo, zhi = rp.rpc_height_range(ims)
    try:
        pt = rp.pointing(ims[0].model, ims[1].model, [SourceImage(im.path) for im in ims], zlo, zhi)
    except InputError as e:
        return {"refused": str(e)}
    return {"tau_px": [round(float(v), 3) for v in pt["tau"]], "agreeing": pt["n"],
            "after_px": round(pt["after_px"], 3)}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", default="current")
    ap.add_argument("--scratch", type=Path, default=None)
    a = ap.parse_args(argv)
    os.environ.setdefault("GDAL_PAM_ENABLED", "NO")
    scratch = a.scratch or Path(tempfile.mkdtemp(prefix="thin_overlap_"))
    cases = {"uncut": (None, None)}
    cases.update({f"columns {w}": ((250, 0, 250, 500), (0, 0, 250 + w + 83, 495)) for w in COLUMN_CUTS})
    cases.update(ROW_CUTS)
    rows = []
    for i, (name, (left, right)) in enumerate(cases.items()):
        r = {"label": a.label, "case": name, "left_srcwin": left, "right_srcwin": right,
             **_pointing(_cut(scratch / f"c{i}", left, right))}
        rows.append(r)
    ref = np.array(rows[0]["tau_px"])
    print(f"{'case':<12} {'agreeing':>8} {'tau px':>18} {'off uncut':>9} {'after':>6}  refused")
    for r in rows:
        if "tau_px" in r:
            r["off_uncut_px"] = round(float(np.hypot(*(np.array(r["tau_px"]) - ref))), 3)
            print(f"{r['case']:<12} {r['agreeing']:>8} {str(r['tau_px']):>18} {r['off_uncut_px']:>9} "
                  f"{r['after_px']:>6}")
        else:
            print(f"{r['case']:<12} {'':>8} {'':>18} {'':>9} {'':>6}  {r['refused'][:90]}")
    old = json.loads(OUT.read_text()) if OUT.exists() else []
    keep = [o for o in old if (o["label"], o["case"]) not in {(r["label"], r["case"]) for r in rows}]
    OUT.write_text(json.dumps(keep + rows, indent=1) + "\n")
    print(f"-> {OUT}")


if __name__ == "__main__":
    main()
