"""Registration benchmark (issue 2): fotogeo SURF vs OpenCV SIFT vs Orfeo ToolBox SURF tie points.

Run:  .venv/bin/python benchmarks/register_bench.py [--quick] [--no-otb] [--no-big] [--cases C,..] [--methods M,..]
      [--output JSON] [--merge]   (--merge: this run's rows replace the same case and method in --output, the
      others are kept; each row names the run that measured it)

Every method goes through the SAME RANSAC, robust fit, check-point hold-out, geo step,
resampling and outputs of :func:`fotogeo.tools.register.tool.register` (seed 0, default options unless
the case says otherwise):

- ``surf`` — fotogeo's default pipeline (``register(ref, tgt, out)``);
- ``sift`` — the same with OpenCV SIFT keypoints (``detector="sift"``);
- ``otb``  — ``otbcli_HomologousPointsExtraction -algorithm surf -mode full`` on the very
  single-band images fotogeo matches (the decimated read + PCA fusion + ``adaptive`` contrast
  of ``register``'s own matching step, rounded to uint8, written WITHOUT georeference), with
  ``-threshold`` = fotogeo's ratio (0.8) and ``-backmatching`` = fotogeo's ``mutual`` (on). Its
  pairs are scaled back to full-resolution pixels and given to
  ``register(..., tie_points=(target_xy, reference_xy))``. Why no georeference: with a
  georeferenced input OTB writes map ("physical") coordinates instead of pixels and even
  detects a different set of keypoints (the raw NGI frames carry an approximate, rotated
  georeference). Without one it writes GDAL corner-convention pixel coordinates (checked
  here: a 180-degree self-match gives x1 + x2 = W exactly). OTB gets no validity mask
  (nodata pixels are 0); fotogeo and SIFT get the mask.

Pairs: NGI frames 0182 / 0184 -> orthophoto tiles 1 / 2 (truth = camera + exterior orientation
+ DEM, ``truth_points`` of tests/ngi_truth.py); Sentinel-2 (10 m) -> NGI orthophoto 1
(5 m); s2_pair (two dates, nodata 0, affine); Landsat RGB under the known synthetic warp of
tests/test_register.py (exact truth); the synthetic demo scene (``fotogeo.tools.demo.tool``).

Reported per pair and method: keypoints (reference/target), descriptor matches, inliers,
check-point RMSE (m and reference px), for cases with truth the dense-grid RMSE of the fitted
model against the truth, the best homography's RMSE on the same grid and their ratio (target
of issue 2: <= 1.3x), the share of raw matches within 3 reference pixels of the truth
("correct"), time per stage (``timings_s`` of the report, plus fusion and the OTB call for
OTB), and the peak memory (max RSS) of the process that ran the case: each case runs in its
own fresh Python subprocess; OTB's own peak is reported separately (its process is a child).

Big image: a 20000x20000 3-band uint8 tiled DEFLATE GeoTIFF (the central 640x640 of NGI frame
0182 upsampled 31.25x by ``gdal_translate``, which streams, so the generator stays small) is
registered to orthophoto tile 1 in a subprocess; peak RSS and the peak reached by each stage
(VmHWM read from /proc at every progress message) are reported. Requirement: well under 2 GB.

Writes benchmarks/results/register_bench.json (``--output``) and prints tables.

This file is the entry point (the command line, the snapshot, the run); its parts: ``register_bench_common.py``
(paths, constants, memory probes), ``register_bench_cases.py`` (the pairs and their truth), ``register_bench_worker.py``
(one case x method in a fresh process; OTB's tie points), ``register_bench_tables.py`` (summaries, merging, tables)
and ``register_bench_big.py`` (the 20000 x 20000 memory check).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from register_bench_common import CORRECT_TOL_PX, DATA, METHODS, OTB_EXE, OUT, ROOT, SNAPSHOT_ENV  # sys.path first
from register_bench_big import big_image, print_big, probe_read  # noqa: E402
from register_bench_cases import Truth, build_cases  # noqa: E402
from register_bench_tables import merge_rows, print_ratios, print_table, ratios, summarise  # noqa: E402
from register_bench_worker import run_case, worker  # noqa: E402


# ------------------------------------------------------------------------------ main
def source_state(root: Path = ROOT) -> dict:
    """git HEAD, uncommitted fotogeo files and a hash of fotogeo's sources under ``root``."""
    import hashlib
    h = hashlib.sha256()
    for f in sorted((root / "fotogeo").rglob("*.py")):
        h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes())

    def git(*args):
        p = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)
        return p.stdout.strip() if p.returncode == 0 else None
    status = git("status", "--porcelain", "--", "fotogeo")
    return {"git_head": git("rev-parse", "--short", "HEAD"), "fotogeo_sha256": h.hexdigest()[:16],
            "fotogeo_uncommitted": status.splitlines() if status else []}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="only the NGI frames and the demo scene, no big image")
    ap.add_argument("--no-otb", action="store_true", help="skip Orfeo ToolBox")
    ap.add_argument("--no-big", action="store_true", help="skip the 20000x20000 memory check")
    ap.add_argument("--big-only", action="store_true",
                    help="only the 20000x20000 memory check (prints, writes no JSON)")
    ap.add_argument("--cases", help="comma-separated case names to run (default: all)")
    ap.add_argument("--methods", help=f"comma-separated methods to run, of {','.join(METHODS)} (default: all)")
    ap.add_argument("--output", type=Path, default=OUT, help=f"the JSON to write (default {OUT.relative_to(ROOT)})")
    ap.add_argument("--merge", action="store_true",
                    help="keep the rows of --output this run does not measure (same case and method: replaced)")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--probe-read", nargs=2, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        return worker(a.worker)
    if a.probe_read:
        return probe_read(*a.probe_read)
    if not DATA.is_dir():
        sys.exit(f"real data not found at {DATA} (set FOTOGEO_DATA)")
    methods = [m for m in METHODS if not (m.startswith("otb") and a.no_otb)
               and (not a.methods or m in a.methods.split(","))]
    if a.merge and not a.output.is_file():
        sys.exit(f"--merge: {a.output} does not exist (run without --merge first)")
    if "otb" in methods and shutil.which(OTB_EXE) is None:
        print(f"note: {OTB_EXE} not on PATH (apt-get install otb-bin); OTB skipped")
        methods = [m for m in methods if not m.startswith("otb")]
    t_start = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="register_bench_") as td:
        tmp = Path(td)
        # Several engineers share the tree: the whole run (this process and every worker) imports
        # one frozen copy of fotogeo/ and tests/, taken now; its hash is recorded.
        snap = tmp / "snapshot"
        for d in ("fotogeo", "tests"):
            shutil.copytree(ROOT / d, snap / d, ignore=shutil.ignore_patterns("__pycache__"))
        state = source_state()
        state["snapshot_sha256"] = source_state(snap)["fotogeo_sha256"]
        os.environ[SNAPSHOT_ENV] = str(snap)
        sys.path[:0] = [str(snap), str(snap / "tests")]
        import fotogeo
        assert Path(fotogeo.__file__).resolve().is_relative_to(snap.resolve()), fotogeo.__file__
        print(f"fotogeo source: git {state['git_head']}, snapshot sha256 {state['snapshot_sha256']}, "
              f"uncommitted: {', '.join(state['fotogeo_uncommitted']) or 'none'}", flush=True)
        cases = [] if a.big_only else build_cases(tmp, a.quick)
        if a.cases:
            cases = [c for c in cases if c["name"] in a.cases.split(",")]
        for case in cases:
            truth = Truth(case, tmp) if case["truth"] else None
            for m in [m for m in methods if m != "otb180" or case.get("otb180")]:
                res = run_case(case, m, tmp, raw_matches=truth is not None)
                s = summarise(res, truth, case)
                rows.append({"case": case["name"], "method": m, "summary": s,
                             "timings_s": res.get("timings_s"), "stage_peak_mb": res.get("stage_peak_mb"),
                             "otb": {k: v for k, v in res.get("otb", {}).items()} or None,
                             "options": case["options"], "fotogeo_imported_from": res.get("fotogeo_imported_from")})
                if res.get("fotogeo_imported_from") and not res["fotogeo_imported_from"].startswith(str(snap)):
                    print(f"WARNING: the worker imported fotogeo from {res['fotogeo_imported_from']}, not the snapshot")
                status = "ok" if s["ok"] else "FAILED"
                print(f"  {case['name']:<13}{m:<5} {status} ({res['process_s']:.1f} s)", flush=True)
        big = None if ((a.quick or a.no_big) and not a.big_only) else big_image(tmp)
    print()
    print_table(rows)
    rat = ratios(rows)
    print_ratios(rat)
    if big:
        print_big(big)
    total = time.perf_counter() - t_start
    state["tree_changed_during_run"] = source_state()["fotogeo_sha256"] != state["fotogeo_sha256"]
    if state["tree_changed_during_run"]:
        print(f"\nnote: fotogeo/ in the tree changed during the run; all rows used the snapshot "
              f"{state['snapshot_sha256']} taken at the start")
    print(f"\nbenchmark wall time {total:.0f} s")
    if a.big_only:  # a development aid: the JSON always holds a whole run
        return
    a.output.parent.mkdir(parents=True, exist_ok=True)
    if big:
        big["result"].pop("raw", None)
    command = " ".join([Path(sys.executable).name] + sys.argv)
    date = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    runs = None
    if a.merge:
        rows, runs = merge_rows(a.output, rows, {"command": command, "date": date, "source": state})
        big = big or json.loads(a.output.read_text()).get("big_image")
        rat = ratios(rows)
    a.output.write_text(json.dumps({
        "quick": a.quick, "methods": methods, "rows": rows, "ratios_fotogeo_surf_over_peer": rat, "big_image": big,
        "runs": runs,
        "notes": {"peak_rss_mb": "max RSS of the fresh Python process that ran the case (includes imports: "
                                 "base_rss_mb); for otb '+N' is the OTB process's own peak",
                  "raw_correct_share": f"share of raw matches within {CORRECT_TOL_PX} reference px of the truth "
                                       "(s2 cases, '~' in the table: of the target's own georeference, approximate)",
                  "georef_rmse_m": "s2 cases: RMSE of the fitted model against the target's own georeference on "
                                   "a 50 px grid (not a truth; the s2_pair target is known to be within ~1 px)",
                  "time_s.total": "register's timings_s.total; for otb: fusion + OTB call + register(tie_points)",
                  "weak_fit": "register's weak-fit check: None when the feature fit was strong; else the corner "
                              "standard error, the fit kept and both fits' RMSE at the windows' check points",
                  "runs": "with --merge: every run whose rows the file holds; each row's 'measured' names its run"},
        "source": state,
        "command": command,
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count(), "platform": platform.platform()},
        "date": date, "wall_s": total,
    }, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
