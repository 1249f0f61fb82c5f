"""``benchmarks/ortho_bench.py --pairs N --baseline-tree OLD``: the exit of ``fotogeo ortho`` (what the process
spends after ``main`` returns), this checkout against ``OLD`` alternating pair by pair (module docstring of
``ortho_bench.py``; ``results/ortho_exit_pairs.json``)."""
from __future__ import annotations

import filecmp
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: ``ortho_bench.FOTOGEO_RUN`` that also prints the process's own CPU time (user + system) at the end of
#: ``main``: what it spends after that is its exit (:func:`exit_pairs`)
FOTOGEO_EXIT_RUN = """
import resource, sys
if sys.path[0] == "":
    del sys.path[0]
from fotogeo.cli import main
try:
    main.main(sys.argv[1:], standalone_mode=False)
finally:
    u = resource.getrusage(resource.RUSAGE_SELF)
    print("CPU_END", u.ru_utime + u.ru_stime)
"""


def _exit_run(cmd, env: dict, cwd: Path) -> dict:
    """Run ``cmd`` (:data:`FOTOGEO_EXIT_RUN`) as a child: its CPU time (user + system, this process's
    ``RUSAGE_CHILDREN``, microseconds) and its exit's, the total less what it had used at the end of ``main``."""
    import resource
    b = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **env}, cwd=cwd)
    a = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))[:200]} failed: {p.stderr.strip()[-600:]}")
    total = a.ru_utime - b.ru_utime + a.ru_stime - b.ru_stime
    end = next(float(ln.split()[1]) for ln in p.stdout.splitlines() if ln.startswith("CPU_END "))
    return {"cpu_s": total, "exit_cpu_s": total - end}


def exit_pairs(work: Path, inp: dict, res: float, n: int, baseline: Path) -> dict:
    """``fotogeo ortho`` of the frames of ``inp`` at ``res`` by this checkout and by ``baseline``, alternating
    (``n`` pairs, the order swapped every pair, no other tool between): median CPU and exit CPU of each, the median of
    the pairs' differences, and whether the two trees' outputs have the same pixels."""
    import rasterio
    trees, runs = {"this": ROOT, "baseline": baseline}, {"this": [], "baseline": []}
    for k in range(n):
        for label in ("this", "baseline") if k % 2 == 0 else ("baseline", "this"):
            out = work / label
            out.mkdir(exist_ok=True)
            args = ["ortho", *inp["frames"], "-o", str(out), "--dem", inp["dem"], "--camera", inp["camera"], "--eo",
                    inp["eo"], "--resolution", str(res), "--resampling", "bilinear", "--overwrite", "-q",
                    *inp.get("fotogeo_args", [])]
            runs[label].append(_exit_run([sys.executable, "-c", FOTOGEO_EXIT_RUN, *args],
                                         {"PYTHONPATH": str(trees[label])}, work))
    same = same_bytes = True
    for f in inp["frames"]:
        a, b = (work / t / f"{Path(f).stem}_ortho.tif" for t in ("this", "baseline"))
        with rasterio.open(a) as x, rasterio.open(b) as y:
            same &= x.shape == y.shape and x.transform == y.transform and x.crs.to_wkt() == y.crs.to_wkt() and \
                bool((x.read() == y.read()).all())
        same_bytes &= filecmp.cmp(a, b, shallow=False)
    med = {label: {k: round(statistics.median(r[k] for r in rs), 4) for k in ("cpu_s", "exit_cpu_s")}
           | {"cpu_s_each": [round(r["cpu_s"], 3) for r in rs]} for label, rs in runs.items()}
    diff = [a["cpu_s"] - b["cpu_s"] for a, b in zip(runs["this"], runs["baseline"])]
    return {**med, "pairs": n, "baseline_tree": str(baseline), "pair_diff_cpu_s": round(statistics.median(diff), 4),
            "same_pixels": same, "same_bytes": same_bytes}
