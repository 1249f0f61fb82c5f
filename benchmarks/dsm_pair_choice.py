"""Which pairs ``fotogeo dsm`` chooses (``tool._choose``) on the benchmark sets, without matching: to check that a
change of the pair choice leaves the choices it should not touch as they were, before any DSM is re-run.

Run:  PYTHONPATH=TREE .venv/bin/python TREE/benchmarks/dsm_pair_choice.py OUT.json [--compare OTHER.json]
      [--work DIR] [--sets NAME,NAME]

* the eight oblique sets of ``tests/dsm_oblique_sets.py`` and the 38° forward set of docs/benchmarks/dsm.md
  (``fwd38``: ``make_set``'s parameters below), rendered, chosen on the ground's plane (``GROUND``);
* the three rendered blocks of ``tests/dsm_scenes.py`` (``dsm_bench.py --cases rendered``): ``fotogeo.tools.dsm.dsm``
  run until the pair choice returns (its own heights from the sparse matches), then stopped;
* the DJI double grids of ``benchmarks/dsm_dji_bench.py`` (``grid45-p4p-684-rtk``, ``grid35-mavic-800-rtk``,
  ``grid55-p4p-684-rtk``): their shots, cameras and true orientation on blank frames (the choice needs the geometry
  only), chosen on the ground's plane.

Per set every candidate pair: kept or not, the reason, overlap, B/H, convergence, view angle, the epipole's margin
(``plan.epipole_margin``, the smaller of the two images') and the rectified images' pixels over the frames'
(``rectified_stretch``, computed here so that a tree without it is measured alike). ``--compare``: the sets whose
kept pairs differ from OTHER.json's, with the pairs.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import fotogeo

TREE = Path(fotogeo.__file__).resolve().parents[1]
sys.path[:0] = [str(TREE / "tests"), str(TREE / "benchmarks")]
from fotogeo.errors import ModelError  # noqa: E402
from fotogeo.stereo.rectify import rectified_extent  # noqa: E402
from fotogeo.tools.dsm import frames, plan, tool  # noqa: E402
from fotogeo.tools.ortho.inputs import image_models  # noqa: E402

FWD38 = dict(strips=[(0, -38.0, 4), (0, -38.0, 4)], base=30.0, side=10.0, seed=41)
DJI = ("grid45-p4p-684-rtk", "grid35-mavic-800-rtk", "grid55-p4p-684-rtk")
SCENES = ("nadir", "oblique", "held_out")


def _rows(out, names, views) -> list:
    rows = []
    for p in out:
        b = views[p.j].centre - views[p.i].centre
        try:
            w, h = rectified_extent(views[p.i], views[p.j], 1.0)[-1]
        except ModelError:  # no common epipolar line
            w = h = 0
        rows.append({"pair": f"{names[p.i]}-{names[p.j]}", "kept": p.kept, "reason": p.reason,
                     "overlap": round(p.overlap, 3), "base_height": round(p.base_height, 3),
                     "convergence_deg": round(p.convergence, 2), "view_angle_deg": round(p.view_angle, 1),
                     "epipole_margin_deg": round(min(plan.epipole_margin(views[p.i], b),
                                                     plan.epipole_margin(views[p.j], b)), 1),
                     "stretch": round(w * h / max(v.size[0] * v.size[1] for v in (views[p.i], views[p.j])), 2)})
    return rows


def _choose(ims, z) -> list:
    views = [frames.frame_view(im) for im in ims]
    names = [im.name for im in ims]
    return _rows(tool._choose(ims, views, names, z, None), names, views)


def oblique(spec, folder) -> list:
    import dsm_oblique_sets as dos
    sc = dos.make_set(spec, folder)
    return _choose(image_models([str(p) for p in sc["images"]], dos.CRS, camera=str(sc["camera"]),
                                eo=str(sc["eo"])), dos.GROUND)


def dji(name, folder) -> list:
    import cv2
    from dsm_dji_bench import CASES
    from rendered_converging import CRS, GROUND
    from rendered_dji_flight import camera, shots, true_orientation

    from fotogeo.io.block import write_exterior_orientation, write_interior_orientation
    kw = CASES[name][0]
    sh = shots(kw["pattern"], np.random.default_rng(kw["seed"]), **({"grid": kw["grid"]} if "grid" in kw else {}))
    truth, names = true_orientation(sh), [n for n, *_ in sh]
    folder.mkdir(parents=True, exist_ok=True)
    cam, eo = folder / "camera.yaml", folder / "eo.txt"
    write_interior_orientation(cam, "dji", camera(kw["sensor"], kw["file_size"]))
    write_exterior_orientation(eo, names, [truth[n] for n in names])
    paths = [str(folder / f"{n}.JPG") for n in names]
    for p in paths:
        cv2.imwrite(p, np.full((kw["file_size"][1], kw["file_size"][0]), 128, np.uint8))
    return _choose(image_models(paths, CRS, camera=str(cam), eo=str(eo)), GROUND)


class _Chosen(Exception):
    pass


def scene(kind, folder) -> list:
    from dsm_scenes import make_scene
    sc, orig, got = make_scene(kind, folder), tool._choose, []

    def spy(ims, views, names, *a, **k):
        got.extend(_rows(orig(ims, views, names, *a, **k), names, views))
        raise _Chosen
    tool._choose = spy
    try:
        tool.dsm(sc["images"], folder / "dsm.tif", camera=sc["camera"], eo=sc["eo"], crs=sc["crs"])
    except _Chosen:
        pass
    finally:
        tool._choose = orig
    return got


def main() -> None:
    import dsm_oblique_sets as dos
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--compare")
    ap.add_argument("--work", default="/tmp/dsm_pair_choice")
    ap.add_argument("--sets", help="only these sets, separated by ';'")
    a = ap.parse_args()
    every = ["fwd38", *dos.SETS, *SCENES, *DJI]
    wrong = [s for s in (a.sets.split(";") if a.sets else []) if s not in every]
    if wrong:
        ap.error(f"--sets: no set {wrong[0]!r}; give names separated by ';' from: " + "; ".join(every))
    res, work = {}, Path(a.work)
    for k, name in enumerate(a.sets.split(";") if a.sets else every):
        folder = work / f"set{k}"
        res[name] = (oblique(FWD38, folder) if name == "fwd38" else oblique(name, folder) if name in dos.SETS
                     else scene(name, folder) if name in SCENES else dji(name, folder))
        print(f"{name}: {sum(r['kept'] for r in res[name])} of {len(res[name])} kept", flush=True)
    Path(a.out).write_text(json.dumps(res, indent=1))
    if a.compare:
        other = json.loads(Path(a.compare).read_text())
        for name, rows in res.items():
            mine, theirs = ({r["pair"] for r in x if r["kept"]} for x in (rows, other.get(name, [])))
            same = "the same pairs" if mine == theirs else (f"only here {sorted(mine - theirs)}, "
                                                            f"only there {sorted(theirs - mine)}")
            print(f"{name}: {same}")


if __name__ == "__main__":
    main()
