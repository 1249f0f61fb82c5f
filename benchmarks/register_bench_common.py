"""Shared by the parts of benchmarks/register_bench.py: paths (the data, the results, the frozen snapshot of fotogeo/
and tests/ every process of a run imports), constants, the memory probes and the number format of the tables.

Importing it puts the repository, tests/ and (when ``FOTOGEO_BENCH_SNAPSHOT`` is set) the snapshot first on
``sys.path``: import it before anything of fotogeo.
"""
from __future__ import annotations

import os
import resource
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "register_bench.py"  # the entry point the worker and probe subprocesses run
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
OUT = ROOT / "benchmarks" / "results" / "register_bench.json"
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # truth helpers shared with the tests
SNAPSHOT_ENV = "FOTOGEO_BENCH_SNAPSHOT"  # a frozen copy of fotogeo/ (and tests/) the whole run imports
if os.environ.get(SNAPSHOT_ENV):
    sys.path[:0] = [os.environ[SNAPSHOT_ENV], str(Path(os.environ[SNAPSHOT_ENV]) / "tests")]

METHODS = ("surf", "sift", "otb", "otb180")
OTB_EXE = "otbcli_HomologousPointsExtraction"
NGI_FRAMES = {"ngi_0182": ("3324c_2015_1004_05_0182", "ngi_rgb_byte_1.tif"),
              "ngi_0184": ("3324c_2015_1004_05_0184", "ngi_rgb_byte_2.tif")}
BIG_SIZE = 20000
CAPPED_CACHE_MB = 256
CORRECT_TOL_PX = 3.0  # reference pixels, = register's RANSAC threshold


# ------------------------------------------------------------------------------ memory
def _status_mb(key: str) -> float:
    """VmHWM / VmRSS of this process from /proc (MB)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _maxrss_mb(who=resource.RUSAGE_SELF) -> float:
    return resource.getrusage(who).ru_maxrss / 1024.0  # Linux: kilobytes


def fmt(x, spec="{:.2f}", none="-"):
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return none
    return spec.format(x)
