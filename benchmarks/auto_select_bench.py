"""``orient --model auto`` without check points: which leave-one-out statistic picks the better model?

:func:`fotogeo.orientation.adjustment.select_model` compares the candidates on the check points' RMSE when there
are at least 3, else on the median of the control points' leave-one-out errors. This measures that median against
the leave-one-out RMSE as the criterion (both with the same 5 % parsimony rule,
:func:`fotogeo.orientation.terrain.choose_parsimonious`): on the NGI frames (true geometry: camera + exterior
orientation + DEM, :func:`fotogeo.orientation.simulation.make_gcps`) ``N`` control points with Gaussian click
noise and no check points go to ``select_model``; every candidate is then judged by its RMSE at 40 independent
exact check points, and each rule's pick is compared with the best candidate (the oracle). With heights the
candidates include the 3-D models (DLT, RFMs); without, only the 2-D ones.

Run: ``.venv/bin/python benchmarks/auto_select_bench.py`` (``--counts``, ``--seeds``, ``--noise``). Prints the
summary and writes ``benchmarks/results/auto_select_bench.json``.
"""
from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

from fotogeo.errors import FotogeoError
from fotogeo.io.camera import load_ngi_frame
from fotogeo.io.raster import read_dem
from fotogeo.orientation.adjustment import fit_orientation, select_model
from fotogeo.orientation.simulation import make_gcps
from fotogeo.orientation.terrain import choose_parsimonious

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "ngi"
FRAMES = ("3324c_2015_1004_05_0182", "3324c_2015_1004_05_0184")
RULES = ("loo_median_px", "loo_rmse_px")
N_CHECK = 40


def one_draw(frame, dem, n_control: int, heights: bool, seed: int, noise: float) -> dict:
    """Each rule's pick and every candidate's RMSE at the independent check points (px)."""
    s = make_gcps(frame, dem, n_control, N_CHECK, "homogeneous", noise=noise, seed=seed)
    ground = np.vstack([s.gcp_ground, s.check_ground])
    pixel = np.vstack([s.gcp_pixel, s.check_pixel])
    if not heights:
        ground[:, 2] = np.nan
    ids = np.array([f"P{i}" for i in range(len(pixel))])
    role = np.array(["control"] * n_control + ["check"] * N_CHECK)
    c = role == "control"
    _, sel = select_model(ground[c], pixel[c], role[c], ids[c])
    true = {}
    for cand in sel["candidates"]:
        try:
            true[cand["model"]] = fit_orientation(cand["model"], ground, pixel, role, ids,
                                                  snooping=False).stats["check"]["rms_xy_px"]
        except FotogeoError:
            continue
    picks = {rule: choose_parsimonious(sel["candidates"], rule)[0] for rule in RULES}
    return {"n_control": n_control, "heights": heights, "seed": seed, "check_rmse_px": true,
            "picks": picks, "oracle_px": min(true.values())}


def summary(rows: list) -> dict:
    """Per heights / no heights: mean check RMSE of each rule's pick and of the oracle, wins of the median."""
    out = {}
    for h in (True, False):
        r = [x for x in rows if x["heights"] == h]
        got = {rule: np.array([x["check_rmse_px"].get(x["picks"][rule], np.nan) for x in r]) for rule in RULES}
        med, rms = got["loo_median_px"], got["loo_rmse_px"]
        out["with heights" if h else "without heights"] = {
            "draws": len(r), "oracle_mean_px": float(np.mean([x["oracle_px"] for x in r])),
            **{f"{rule}_mean_px": float(np.nanmean(v)) for rule, v in got.items()},
            "median_better": int(np.sum(med < rms - 1e-9)), "rmse_better": int(np.sum(rms < med - 1e-9))}
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--counts", default="8,10,15,25")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--noise", type=float, default=0.5)
    a = ap.parse_args(argv)
    dem, rows = read_dem(DATA / "dem.tif"), []
    warnings.simplefilter("ignore")
    for name in FRAMES:
        frame = load_ngi_frame(DATA, name)
        for n in (int(v) for v in a.counts.split(",")):
            for heights in (True, False):
                rows += [{"frame": name, **one_draw(frame, dem, n, heights, seed, a.noise)} for seed in range(a.seeds)]
    result = {"noise_px": a.noise, "n_check": N_CHECK, "summary": summary(rows), "draws": rows}
    print(json.dumps(result["summary"], indent=1))
    out = Path(__file__).parent / "results" / "auto_select_bench.json"
    out.write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
