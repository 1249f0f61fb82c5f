"""Per-frame σ of ``fotogeo triangulate``'s report.json against the observed errors, on cases it was not tuned on.

Issue 32 ("per-frame σ not below the observed errors"). For every frame, the report's σ of ``X0 Y0 Z0`` (m) and of
the rotation about the camera axes ``rx ry rz`` (°, the bundle's increment ``R ← R·exp([δθ]×)``) is set beside the
observed error against the truth: ``e_p = C_adjusted − C_true`` and ``δθ = log(R_adjustedᵀ R_true)`` (OpenCV camera
axes). Per case, pooled over frames and axes: the RMS of ``e/σ`` (1 for an honest σ; above 1.5–2 the σ is
optimistic), the largest per-frame ``|e|/|σ|`` (norms of the three axes) and the fraction of axes with ``|e| > 2σ``
(about 5 % for a normal error).

Cases (``--cases``, labels below):

* ``ngi no EO`` — the real NGI pair (frames 0182/0184) through ``fotogeo triangulate --reference ORTHO... --dem DEM``
  with no orientation given; the truth is the published ``exterior_orientation.txt`` (a professional
  triangulation). ``ngi EO sN`` — the same with ``--eo`` the published EO perturbed (20 m, 0.5° per axis, seed N).
  For ``ngi no EO`` also ``ortho --uncertainty`` (``--dem-sigma 0.001``: the orientation's term alone) against the
  ground errors of a dense grid of the frames' pixels (true ray on the DEM vs the adjusted one).
* ``ebee …`` — three consecutive frames of the eBee flight (``drone_snowpeak``) triangulated from their files
  alone against the run of all 8 frames (its GPS and attitude priors are the same, so this checks the ties' share
  of the σ only).
* ``rendered …`` — blocks rendered from a known truth (:mod:`fotogeo.orientation.block_render`, other cameras,
  heights, overlaps, strip counts, control settings than the tests'), tie points matched by triangulate's own
  matcher, adjusted with their simulated control or GNSS priors and written as triangulate writes them
  (``tests/rendered_block_uncertainty.py``); with ``--ortho`` also their ``ortho --uncertainty`` rasters against the
  check points' ground errors (exact DEM: the orientation's term alone).

``--control-draws N``: for each rendered case, its last seed's block adjusted again ``N`` times with only its
control points' noise drawn anew (:func:`control_draws`): whether one seed's ``e/σ`` is one draw of a datum that
rests on a few GCPs. Per case also the RMS of the errors themselves (m, °): whether re-weighting moves the frames
closer to the truth. ``--ebee-reference DIR`` keeps the all-frame eBee run, to compare two trees against one.

Rows go to ``benchmarks/results/triangulate_sigma_bench.json`` (``--out``), CPU seconds (user + sys, this process
and its children) per case.

    PYTHONPATH=. .venv/bin/python benchmarks/triangulate_sigma_bench.py [--cases 'ngi no EO' ...] [--ortho]
        [--seeds 2] [--control-draws 30] [--ebee-reference DIR]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from fotogeo.geometry.camera import FrameCamera
from fotogeo.io.camera import read_exterior_orientation

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))  # as --data sets it
PY = [sys.executable, "-m", "fotogeo"]
KEYS = ("X0", "Y0", "Z0", "rx_deg", "ry_deg", "rz_deg")

#: rendered cases: simulate_block's shape, the BundleOptions' GNSS priors (None: control points only), the seed
RENDERED = {
    "rendered 1 x 5 strip, 8 GCP": ({"strips": 1, "frames_per_strip": 5}, None, 3),
    "rendered 2 x 4, 4 GCP, 80 % forward": ({"n_control": 4, "forward_overlap": 0.8}, None, 4),
    "rendered 3 x 3, wide lens 600 m": ({"strips": 3, "frames_per_strip": 3, "flying_height": 600.0,
                                         "camera": FrameCamera(3.5, (6.0, 4.0), (600, 400))}, None, 5),
    "rendered 2 x 4, control 1 m": ({"control_sigma": (1.0, 1.5)}, None, 6),
    "rendered 2 x 4, GNSS 2 m no GCP": ({"n_control": 0, "eo_noise": (2.0, 0.3)}, (2.0, 0.3), 7),
    "rendered 2 x 3, relief 120 m": ({"frames_per_strip": 3, "relief": 120.0}, None, 8),
    "rendered 2 x 4, control 0.5 m given 3 cm": ({"control_sigma": (0.5, 0.5), "control_sigma_given": (0.02, 0.03)},
                                                 None, 9),
    "rendered 2 x 4, GNSS 3 m given 0.5 m": ({"n_control": 0, "eo_noise": (3.0, 0.3)}, (0.5, 0.3), 10),
    # held out of the s22 variance-component iteration (not run while it was built)
    "rendered 3 x 4, f 9 mm 700 m, GNSS 2 m given 0.3 m, 4 GCP": (
        {"strips": 3, "n_control": 4, "eo_noise": (2.0, 0.2), "flying_height": 700.0, "side_overlap": 0.4,
         "camera": FrameCamera(9.0, (4.8, 6.4), (480, 640))}, (0.3, 0.2), 21),
    "rendered 2 x 5, 70 % forward 500 m, relief 80 m, GNSS 1.5 m given 0.2 m": (
        {"frames_per_strip": 5, "n_control": 0, "eo_noise": (1.5, 0.2), "forward_overlap": 0.7,
         "flying_height": 500.0, "relief": 80.0}, (0.2, 0.2), 23),
    "rendered 2 x 4, wide lens 400 m, GNSS 1 m given 1 m, 3 GCP": (
        {"n_control": 3, "eo_noise": (1.0, 0.2), "flying_height": 400.0,
         "camera": FrameCamera(4.0, (4.0, 6.0), (400, 600))}, (1.0, 0.2), 25),
}
EBEE_SUBSETS = {"ebee triple 2186/2188/2189": ["IMG_2186", "IMG_2188", "IMG_2189"],
                "ebee triple 2280/2281/2282": ["IMG_2280", "IMG_2281", "IMG_2282"]}
CASES = ["ngi no EO", "ngi EO s0", "ngi EO s1", *RENDERED, *EBEE_SUBSETS]


def ngi() -> Path:
    return DATA / "ngi"


def ebee() -> Path:
    return DATA / "drone_snowpeak" / "img"


def frame_errors(eo, true) -> np.ndarray:
    """``(6,)``: centre error (m) and the rotation ``log(R_eoᵀ R_true)`` about the camera axes (°)."""
    d = np.array([eo.X - true.X, eo.Y - true.Y, eo.Z - true.Z])
    rot = Rotation.from_matrix(eo.rotation_cv.T @ true.rotation_cv).as_rotvec()
    return np.concatenate([d, np.degrees(rot)])


def frame_rows(report: dict, adjusted: dict, truth: dict) -> list:
    """One row per adjusted frame: its report σ (6), observed error (6) and ``|e|/|σ|`` of positions and angles."""
    rows = []
    for f in report["frames"]:
        n = f["name"]
        if n not in adjusted or n not in truth:
            continue
        s = np.array([f.get("sigma", {}).get(k, np.nan) for k in KEYS], float)
        e = frame_errors(adjusted[n], truth[n])
        rows.append({"frame": n, "sigma": s.tolist(), "error": e.tolist(),
                     "position_ratio": float(np.linalg.norm(e[:3]) / np.linalg.norm(s[:3])),
                     "angle_ratio": float(np.linalg.norm(e[3:]) / np.linalg.norm(s[3:]))})
    return rows


def pooled(rows: list) -> dict:
    """RMS of ``e/σ``, the worst frame's ``|e|/|σ|`` and the fraction of axes with ``|e| > 2σ``, per kind."""
    out = {"frames": len(rows)}
    if not rows:
        return out
    e = np.array([r["error"] for r in rows])
    z = e / np.array([r["sigma"] for r in rows])
    out["position_rms_error_m"] = float(np.sqrt(np.mean(e[:, :3] ** 2)))  # per axis: whether the errors fall
    out["angle_rms_error_deg"] = float(np.sqrt(np.mean(e[:, 3:] ** 2)))
    for kind, sl, key in (("position", slice(0, 3), "position_ratio"), ("angle", slice(3, 6), "angle_ratio")):
        zk = z[:, sl][np.isfinite(z[:, sl])]
        out[f"{kind}_rms_e_over_sigma"] = float(np.sqrt(np.mean(zk ** 2))) if zk.size else None
        out[f"{kind}_worst_frame_ratio"] = float(max(r[key] for r in rows))
        out[f"{kind}_beyond_2sigma"] = float(np.mean(np.abs(zk) > 2)) if zk.size else None
    return out


def cpu_seconds() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def run_cli(args, tree: Path, log: Path) -> int:
    env = dict(os.environ, PYTHONPATH=str(tree), GDAL_PAM_ENABLED="NO")
    with open(log, "w") as fh:
        return subprocess.run(PY + [str(a) for a in args], cwd="/", env=env, stdout=fh,
                              stderr=subprocess.STDOUT).returncode


def ngi_case(label: str, work: Path, tree: Path) -> dict:
    """The NGI pair through ``fotogeo triangulate`` (module docstring)."""
    from ngi_triangulation import NAMES, perturbed
    from fotogeo.io.block import write_exterior_orientation
    truth = read_exterior_orientation(ngi() / "exterior_orientation.txt")
    d = ngi()
    args = ["triangulate", *[d / "frames" / f"{n}.tif" for n in NAMES], "--camera", d / "interior_orientation.yaml",
            "--reference", d / "ortho" / "ngi_rgb_byte_1.tif", "--reference", d / "ortho" / "ngi_rgb_byte_2.tif",
            "--dem", ngi() / "dem.tif", "-o", work / "out", "--overwrite", "-q"]
    if label.startswith("ngi EO s"):
        rng = np.random.default_rng(int(label.rsplit("s", 1)[1]))
        write_exterior_orientation(work / "eo.txt", NAMES, [perturbed(truth[n], rng, 20.0, 0.5) for n in NAMES])
        args += ["--eo", work / "eo.txt"]
    code = run_cli(args, tree, work / "triangulate.log")
    if code:
        return {"exit": code, "message": (work / "triangulate.log").read_text()[-400:]}
    rep = json.loads((work / "out" / "report.json").read_text())
    rows = frame_rows(rep, read_exterior_orientation(work / "out" / "exterior_orientation.txt"), truth)
    return {"exit": 0, "sigma0": rep["sigma0"], "covariance_scale": rep["covariance_scale"],
            "covariance_rule": rep["statistics"].get("covariance_rule"), "rows": rows,
            "command": " ".join(str(a) for a in args)}


def ebee_case(label: str, work: Path, tree: Path, reference: Path) -> dict:
    """A subset of the eBee flight from its files alone against the all-frame run (``reference``, made once)."""
    if not (reference / "exterior_orientation.txt").is_file():
        run_cli(["triangulate", *sorted(ebee().glob("*.JPG")), "-o", reference, "--overwrite", "-q"], tree,
                reference.parent / "ebee_all.log")
    args = ["triangulate", *[ebee() / f"{n}.JPG" for n in EBEE_SUBSETS[label]], "-o", work / "out", "--overwrite", "-q"]
    code = run_cli(args, tree, work / "triangulate.log")
    if code or not (reference / "exterior_orientation.txt").is_file():
        return {"exit": code or 1, "message": (work / "triangulate.log").read_text()[-400:]}
    rep = json.loads((work / "out" / "report.json").read_text())
    rows = frame_rows(rep, read_exterior_orientation(work / "out" / "exterior_orientation.txt"),
                      read_exterior_orientation(reference / "exterior_orientation.txt"))
    return {"exit": 0, "sigma0": rep["sigma0"], "covariance_scale": rep["covariance_scale"],
            "covariance_rule": rep["statistics"].get("covariance_rule"), "rows": rows,
            "command": " ".join(str(a) for a in args), "reference": "the all-frame run (shares the GPS priors)",
            "group_factors": rep["statistics"].get("group_factors"), "variance_components": {
                k: g.get("sigma0") for k, g in (rep["statistics"].get("variance_components") or {}).items()},
            "reference_sigma0": json.loads((reference / "report.json").read_text())["sigma0"]}


def ngi_ortho(work: Path, tree: Path) -> dict:
    """``ortho --uncertainty`` of the adjusted NGI pair against a dense grid's ground errors (module docstring)."""
    from ngi_triangulation import NAMES, dense_grid
    from rendered_block_uncertainty import sample_raster
    from fotogeo.geometry.camera import OrientedFrame
    from fotogeo.io.camera import load_camera
    from fotogeo.io.raster import read_dem
    out = work / "out"
    args = ["ortho", *[ngi() / "frames" / f"{n}.tif" for n in NAMES], "--camera", ngi() / "interior_orientation.yaml",
            "--eo", out / "exterior_orientation.txt", "--dem", ngi() / "dem.tif", "--uncertainty",
            "--dem-sigma", "0.001", "--resolution", "10", "-o", work / "ortho", "--overwrite", "-q"]
    if run_cli(args, tree, work / "ortho.log"):
        return {"message": (work / "ortho.log").read_text()[-400:]}
    cam, dem = load_camera(ngi() / "interior_orientation.yaml"), read_dem(ngi() / "dem.tif")
    truth, adj = read_exterior_orientation(ngi() / "exterior_orientation.txt"), read_exterior_orientation(
        out / "exterior_orientation.txt")
    err, sig = [], []
    for n in NAMES:
        px, G = dense_grid(cam, truth[n], dem, step=20)
        moved = OrientedFrame(cam, adj[n]).pixel_to_world(px, dem)
        err.append(moved[:, :2] - G[:, :2])
        sig.append(sample_raster(next((work / "ortho").glob(f"{n}*_sigma.tif")), moved[:, :2]))
    return ortho_summary(err, sig) | {"command": " ".join(str(a) for a in args)}


def ortho_summary(err, sig) -> dict:
    e, s = np.vstack(err), np.concatenate(sig)
    ok = np.isfinite(e).all(axis=1) & np.isfinite(s)
    d = np.hypot(*e[ok].T)
    return {"n": int(ok.sum()), "observed_rms_m": float(np.sqrt(np.mean(d ** 2))),
            "predicted_rms_m": float(np.sqrt(np.mean(s[ok] ** 2))),
            "ratio": float(np.sqrt(np.mean(d ** 2)) / np.sqrt(np.mean(s[ok] ** 2))),
            "beyond_2sigma": float(np.mean(d > 2 * s[ok]))}


def rendered_case(label: str, work: Path, with_ortho: bool, seeds: int) -> dict:
    """A rendered block adjusted and written as triangulate writes it (module docstring), for ``seeds``
    seeds from the case's own; frames pooled over the seeds."""
    from rendered_block_uncertainty import check_points, realisation, sample_raster
    from fotogeo.orientation.bundle import BundleOptions
    shape, prior, first = RENDERED[label]
    out = {"exit": 0, "seeds": [], "sigma0": [], "rows": []}
    err, sig = [], []
    for seed in range(first, first + seeds):
        folder = work / f"s{seed}"
        folder.mkdir()
        r = realisation(folder, seed, 0.0, None if prior is None else BundleOptions(eo_sigma=prior), **shape)
        rep = json.loads((folder / "report.json").read_text())
        names = r["sb"].block.frames
        rows = frame_rows(rep, dict(zip(names, r["result"].eo)), dict(zip(names, r["sb"].true_eo)))
        out["seeds"].append(seed)
        out["sigma0"].append(rep["sigma0"])
        out.setdefault("covariance_rule", []).append(rep["statistics"].get("covariance_rule"))
        out.setdefault("group_factors", []).append(rep["statistics"].get("group_factors"))
        out.setdefault("redundancy", []).append({k: g.get("redundancy") for k, g in
                                                 (rep["statistics"].get("variance_components") or {}).items()})
        out["rows"] += [{"seed": seed, **row} for row in rows]
        if with_ortho:
            from fotogeo.tools.ortho.tool import ortho
            o = ortho(r["images"], folder / "ortho", dem=r["dem_path"], camera=r["camera"], eo=r["eo"],
                      uncertainty=True, dem_sigma=0.001, resolution=3.0)
            for j, (G, exact, _) in enumerate(check_points(r, n=500)):
                err.append(exact[:, :2] - G[:, :2])
                sig.append(sample_raster(o["images"][names[j]]["sigma"]["path"], exact[:, :2]))
    if with_ortho:
        out["ortho"] = ortho_summary(err, sig)
    return out


def control_draws(label: str, work: Path, n: int, seed: int) -> dict:
    """The case's block of ``seed`` rendered, matched and adjusted once, then ``n`` times more with only its control
    points' image observations and coordinates drawn again from their simulated noise (σ 0.3 px; the control σ),
    the matched ties kept: the pooled ``e/σ`` of each draw. A datum resting on a few GCPs moves every frame
    alike, so one seed's frames are nearly one sample of it, not eight."""
    from rendered_block_uncertainty import realisation
    from fotogeo.orientation import bundle_jacobian as bj
    from fotogeo.orientation.block_simulation import true_interior
    from fotogeo.orientation.bundle import BundleOptions, adjust_block
    shape, prior, _ = RENDERED[label]
    options = BundleOptions() if prior is None else BundleOptions(eo_sigma=prior)
    (work / "draws").mkdir()
    r = realisation(work / "draws", seed, 0.0, options, **shape)
    sb, block = r["sb"], r["block"]
    ctrl = block.role == "control"
    obs = np.flatnonzero(ctrl[block.obs_point])
    index = {p: k for k, p in enumerate(sb.block.point_ids)}
    true = np.array([sb.true_xyz[index[p]] if c else np.full(3, np.nan) for p, c in zip(block.point_ids, ctrl)])
    R, C = np.stack([e.rotation_cv for e in sb.true_eo]), np.stack([e.centre for e in sb.true_eo])
    px = bj.project(R, C, true, block.obs_frame[obs], block.obs_point[obs],
                    true_interior(sb.true_camera, sb.true_distortion), bj.pixel_scale(block.camera))
    rng = np.random.default_rng(seed + 500)
    names = block.frames

    def draw(result):
        return pooled(frame_rows({"frames": [{"name": nm, "sigma": dict(zip(KEYS, map(float, s)))}
                                             for nm, s in zip(names, result.eo_sigma)]},
                                 dict(zip(names, result.eo)), dict(zip(names, sb.true_eo))))
    first, rows = draw(r["result"]), []
    for _ in range(n):
        pix, xyz = block.obs_pixel.copy(), block.point_xyz.copy()
        pix[obs] = px + rng.normal(0.0, 0.3, px.shape)
        xyz[ctrl] = true[ctrl] + rng.normal(size=(int(ctrl.sum()), 3)) * block.point_sigma[ctrl]
        rows.append(draw(adjust_block(dataclasses.replace(block, obs_pixel=pix, point_xyz=xyz), options)))
    e = np.array([[d["position_rms_e_over_sigma"], d["angle_rms_e_over_sigma"]] for d in rows])
    return {"seed": seed, "draws": n, "as_rendered": first, "per_draw": e.tolist(),
            "position_rms_e_over_sigma": float(np.sqrt(np.mean(e[:, 0] ** 2))),
            "angle_rms_e_over_sigma": float(np.sqrt(np.mean(e[:, 1] ** 2))),
            "position_median": float(np.median(e[:, 0])),
            "share_above_as_rendered": float(np.mean(e[:, 0] >= first["position_rms_e_over_sigma"]))}


def print_row(label: str, r: dict) -> None:
    if r.get("exit"):
        print(f"{label:<38} refused/failed: {r.get('message', '')[-200:]}")
        return
    p = pooled(r["rows"])
    o = r.get("ortho") or {}
    ortho = f" ortho obs/pred {o['ratio']:.2f} (>2σ {100 * o['beyond_2sigma']:.0f} %)" if "ratio" in o else ""
    s0 = "/".join(f"{v:.2f}" for v in np.atleast_1d(r["sigma0"]))
    print(f"{label:<38} σ0 {s0} n {p['frames']:>2}  rms e {p['position_rms_error_m']:.3g} m "
          f"{p['angle_rms_error_deg']:.3g}°  pos e/σ {p['position_rms_e_over_sigma']:.2f} "
          f"worst {p['position_worst_frame_ratio']:.2f} >2σ {100 * p['position_beyond_2sigma']:3.0f} %  "
          f"ang e/σ {p['angle_rms_e_over_sigma']:.2f} worst {p['angle_worst_frame_ratio']:.2f} "
          f">2σ {100 * p['angle_beyond_2sigma']:3.0f} %  cpu {r['cpu_s']:.1f} s{ortho}")
    if len(r.get("seeds", ())) > 2:  # one seed's e/σ rests on its groups' σ̂ of a few redundancies
        z = [pooled([w for w in r["rows"] if w["seed"] == s])["position_rms_e_over_sigma"] for s in r["seeds"]]
        f = [g["position_prior"] for g in r.get("group_factors", ()) if g and "position_prior" in g]
        red = [g["position_prior"] for g in r.get("redundancy", ()) if g.get("position_prior") is not None]
        print(f"{'':<38} per seed: centres e/σ {min(z):.2f}–{max(z):.2f} (median {np.median(z):.2f})"
              + (f", GNSS factor {min(f):.2f}–{max(f):.2f} (RMS {np.sqrt(np.mean(np.square(f))):.2f})" if f else "")
              + (f", GNSS redundancy {min(red):.1f}–{max(red):.1f}" if red else ""))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=CASES, choices=CASES)
    ap.add_argument("--ortho", action="store_true", help="also ortho --uncertainty against ground errors")
    ap.add_argument("--seeds", type=int, default=1, help="seeds per rendered case (from the case's own)")
    ap.add_argument("--control-draws", type=int, default=0, metavar="N",
                    help="rendered cases: N re-draws of the control's noise on the last seed's ties (control_draws)")
    ap.add_argument("--ebee-reference", default=None, metavar="DIR",
                    help="the all-frame eBee run's output folder, made there if missing (default: a temporary one); "
                         "pass one made by the tree before a change to compare two trees against one reference")
    ap.add_argument("--data", default=None, help="the shared data folder (ngi/, drone_snowpeak/)")
    ap.add_argument("--tree", default=str(ROOT), help="the fotogeo tree the CLI cases run (PYTHONPATH)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "triangulate_sigma_bench.json"))
    a = ap.parse_args(argv)
    if a.data:
        os.environ["FOTOGEO_DATA"] = a.data
        globals()["DATA"] = Path(a.data)
    table = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k, label in enumerate(a.cases):
            work = Path(tmp) / f"c{k}"
            work.mkdir()
            t0 = cpu_seconds()
            if label.startswith("ngi"):
                r = ngi_case(label, work, Path(a.tree))
                if a.ortho and label == "ngi no EO" and not r.get("exit"):
                    r["ortho"] = ngi_ortho(work, Path(a.tree))
            elif label.startswith("ebee"):
                r = ebee_case(label, work, Path(a.tree), Path(a.ebee_reference or Path(tmp) / "ebee_all"))
            else:
                r = rendered_case(label, work, a.ortho, a.seeds)
                if a.control_draws:
                    d = r["control_draws"] = control_draws(label, work, a.control_draws, r["seeds"][-1])
                    print(f"{label:<38} seed {d['seed']}: e/σ {d['as_rendered']['position_rms_e_over_sigma']:.2f} "
                          f"as rendered; {d['draws']} draws of the control's noise: e/σ RMS "
                          f"{d['position_rms_e_over_sigma']:.2f} (median {d['position_median']:.2f}, angles "
                          f"{d['angle_rms_e_over_sigma']:.2f}), {100 * d['share_above_as_rendered']:.0f} % of "
                          f"draws at or above the rendered one")
            r["cpu_s"] = cpu_seconds() - t0
            if not r.get("exit"):
                r["pooled"] = pooled(r["rows"])
            table[label] = r
            print_row(label, r)
            write(a.out, table)
    print(f"{'all cases':<38} {json.dumps(write(a.out, table))}")


def write(out: str, table: dict) -> dict:
    """The rows so far into ``out`` (after every case: a long run cut short keeps its cases); the pooled row."""
    rows = [row for r in table.values() if not r.get("exit") for row in r["rows"]]
    note = "CPU s = user + sys of this process and its children; load-dependent"
    Path(out).write_text(json.dumps({"command": " ".join(sys.argv[1:]), "note": note, "load_average": os.getloadavg(),
                                     "pooled": pooled(rows), "cases": table}, indent=1, default=float))
    return pooled(rows)

if __name__ == "__main__":
    main()
