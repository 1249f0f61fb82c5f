"""How ``benchmarks/dsm_bench.py`` and its case modules (:mod:`dsm_oblique_cases`) run and time ``fotogeo``: in
this process (:func:`_timed`) or as a child process under ``/usr/bin/time -v`` (:func:`_time_v`), with the
automatic pair choice's limits changed in the child (``--view-angle-limit``, ``--pair-limits``: :func:`set_limits`,
:func:`python`)."""
from __future__ import annotations

import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _timed(func, *a, **kw):
    c, w = time.process_time(), time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = func(*a, **kw)
    return out, time.process_time() - c, time.perf_counter() - w, [str(x.message) for x in caught]


def _stats(d) -> dict:
    med = float(np.median(d))
    return {"median": med, "nmad": float(1.4826 * np.median(np.abs(d - med))), "rmse": float(np.sqrt(np.mean(d ** 2)))}


def _time_v(cmd: list, cwd=None, tree: Path = ROOT) -> dict:
    """Run ``cmd`` under ``/usr/bin/time -v`` (its own small process: the child's peak is not the parent's) with
    ``tree`` on ``PYTHONPATH`` (``cwd`` outside any checkout for ``python -m``): user + system CPU (s), peak
    resident memory (MiB), wall (s)."""
    import re
    import subprocess
    w = time.perf_counter()
    r = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True, cwd=cwd,
                       env=dict(os.environ, PYTHONPATH=str(tree)))
    if r.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr[-3000:]}")
    num = {k: float(re.search(rf"{k}.*: ([\d.]+)", r.stderr).group(1))
           for k in ("User time", "System time", "Maximum resident set size")}
    return {"cpu_s": num["User time"] + num["System time"], "peak_rss_mib": num["Maximum resident set size"] / 1024,
            "wall_s": time.perf_counter() - w}


#: a child ``fotogeo`` run with the automatic pair choice's limits ``{0}`` (JSON; ``--view-angle-limit``,
#: ``--pair-limits``)
LIMIT_RUN = ("import json, runpy, sys; sys.path.insert(0, {1!r}); import dsm_bench_run; "
             "dsm_bench_run.set_limits(json.loads({0!r})); runpy.run_module('fotogeo', run_name='__main__')")


def limits_of(view_angle=None, text=None) -> dict | None:
    """The limits to set: ``--view-angle-limit``'s degrees as ``max_view_angle`` and ``--pair-limits``'s
    ``name=value,...`` (fields of ``fotogeo.stereo.pairs.Limits``); None when neither is given."""
    out = {} if view_angle is None else {"max_view_angle": float(view_angle)}
    for kv in (text or "").split(","):
        if kv.strip():
            k, v = (s.strip() for s in kv.split("="))
            out[k] = float(v)
    return out or None


def set_limits(limits) -> str:
    """Set the defaults of ``fotogeo.stereo.pairs.Limits`` in this process (``limits``: field -> value; None:
    leave them), a measure of the automatic pair choice with other limits (given pairs are matched whatever their
    views); returns the rows' name suffix (:func:`limit_tag`)."""
    import dataclasses

    from fotogeo.stereo.pairs import Limits
    if not limits:
        return ""
    names = [f.name for f in dataclasses.fields(Limits)]
    d = list(Limits.__init__.__defaults__)
    for k, v in limits.items():
        if k not in names:
            raise SystemExit(f"--pair-limits: {k!r} is not a field of fotogeo.stereo.pairs.Limits ({', '.join(names)})")
        d[names.index(k)] = type(d[names.index(k)])(v)
    Limits.__init__.__defaults__ = tuple(d)
    return limit_tag(limits)


def limit_tag(limits) -> str:
    """The rows' name suffix: `` (view-angle limit 70)`` for ``max_view_angle`` alone (the rows of the runs before
    ``--pair-limits``), the other fields named after it."""
    if not limits:
        return ""
    rest = {k: v for k, v in limits.items() if k != "max_view_angle"}
    parts = ([f"view-angle limit {float(limits['max_view_angle']):g}"] if "max_view_angle" in limits else []) + \
        [f"{k} {float(v):g}" for k, v in rest.items()]
    return f" ({', '.join(parts)})"


def python(limits=None) -> list:
    """The child command's ``python -m fotogeo`` (with ``limits``: through :data:`LIMIT_RUN`)."""
    if not limits:
        return [sys.executable, "-m", "fotogeo"]
    return [sys.executable, "-c", LIMIT_RUN.format(json.dumps(limits), str(ROOT / "benchmarks"))]
