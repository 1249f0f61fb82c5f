"""benchmarks/dsm_bench.py writes only the rows it ran: a partial run (``--rpc-cases``, one peer) replaces the rows
of the same names and keeps the group's others, each with the command and load of the run that measured it."""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from dsm_bench import _merge  # noqa: E402


def test_a_partial_run_keeps_the_other_rows():
    old = {"command": "dsm_bench.py --cases rendered_rpc", "load_average": [[9, 9, 9], [9, 9, 9]]}
    runs = [{"case_group": "ventoux", "command": "v", "load_average": [], "rows": [{"case": "ventoux a"}]},
            {"case_group": "rendered_rpc", **old, "rows": [{"case": "rendered_rpc a", "x": 1},
                                                            {"case": "rendered_rpc b", "x": 2}]}]
    now = {"command": "dsm_bench.py --cases rendered_rpc --rpc-cases b --cars", "load_average": [[1, 1, 1], [1, 1, 1]]}
    out = _merge(runs, "rendered_rpc", [{"case": "rendered_rpc b", "x": 3}, {"case": "rendered_rpc CARS b"}], now)
    assert out[0] == runs[0]  # other groups untouched
    g = out[1]
    assert [r["case"] for r in g["rows"]] == ["rendered_rpc a", "rendered_rpc b", "rendered_rpc CARS b"]
    assert g["rows"][0] == {"case": "rendered_rpc a", "x": 1, "run": old}
    assert g["rows"][1] == {"case": "rendered_rpc b", "x": 3, "run": now} and g["command"] == now["command"]
    again = _merge(out, "rendered_rpc", [{"case": "rendered_rpc a", "x": 4}], old)
    assert [r["x"] for r in again[1]["rows"][:2]] == [4, 3] and again[1]["rows"][1]["run"] == now
