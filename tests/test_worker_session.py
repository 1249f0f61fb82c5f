"""The long-lived worker (``python -m fotogeo.worker --session``) and its QGIS client
(``processing_provider.session.WorkerSession``): one answer per request, errors that do not end
the session, warnings before the result, restart after a crash, thread safety."""
from __future__ import annotations

import json
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from qgis_env import qgis_app  # noqa: F401  (a session fixture: the QGIS client tests need it)

ROOT = Path(__file__).resolve().parents[1]
CRS = "EPSG:32635"


@pytest.fixture
def dem_path(tmp_path):
    """A 100 x 100 DEM, 10 m cells from (500000, 7001000): z = 100 + 0.01 X' + 0.02 Y' (local metres)."""
    path = tmp_path / "dem.tif"
    rows, cols = np.mgrid[0:100, 0:100]
    z = 100 + 0.01 * (cols + 0.5) * 10 + 0.02 * (100 - rows - 0.5) * 10
    with rasterio.open(path, "w", driver="GTiff", width=100, height=100, count=1, dtype="float64", crs=CRS,
                       transform=from_origin(500000, 7001000, 10, 10)) as ds:
        ds.write(z[None])
    return path


def plane_height(x, y):
    return 100 + 0.01 * (x - 500000) + 0.02 * (y - 7000000)


def affine_gcps(n=8, role="control"):
    """GCPs of an exact affine image: col = (X - 500100) / 2, row = (7000900 - Y) / 2."""
    rng = np.random.default_rng(3)
    xy = rng.uniform([500100, 7000100], [500900, 7000900], (n, 2))
    return [{"id": f"p{k}", "col": (x - 500100) / 2, "row": (7000900 - y) / 2, "x": x, "y": y, "z": None,
             "role": role} for k, (x, y) in enumerate(xy)]


def run_session(lines: list[str], timeout=120) -> list[dict]:
    proc = subprocess.run([sys.executable, "-m", "fotogeo.worker", "--session"], input="\n".join(lines) + "\n",
                          capture_output=True, text=True, cwd=ROOT, timeout=timeout)
    assert proc.returncode == 0, proc.stderr
    return [json.loads(line) for line in proc.stdout.splitlines()]


def test_session_answers_each_request_once_and_survives_errors(dem_path):
    requests = [
        json.dumps({"id": 1, "tool": "no_such_tool", "kwargs": {}}),
        "{not json",
        json.dumps({"id": 2, "tool": "sample_heights", "kwargs": {"xy": [[500155, 7000555], [400000, 0]],
                                                                 "crs": CRS, "dem": str(dem_path)}}),
        json.dumps({"id": 3, "tool": "fit_gcps", "kwargs": {"gcps": affine_gcps(2), "model": "affine", "crs": CRS}}),
        json.dumps({"id": 4, "tool": "fit_gcps", "kwargs": {"gcps": [{"id": "a"}], "model": "affine", "crs": CRS}}),
        json.dumps({"id": 5, "tool": "fit_gcps", "kwargs": {"gcps": affine_gcps(8), "model": "affine", "crs": CRS,
                                                           "width": 400, "height": 400}}),
        "quit",
        json.dumps({"id": 6, "tool": "sample_heights", "kwargs": {}}),  # after quit: never answered
    ]
    answers = run_session(requests)
    assert [(a["id"], a["type"]) for a in answers] == [(1, "error"), (None, "error"), (2, "result"), (3, "result"),
                                                       (4, "error"), (5, "result")]
    assert "unknown tool 'no_such_tool'" in answers[0]["message"] and "fit_gcps" in answers[0]["message"]
    assert answers[1]["error"] == "InputError"
    z = answers[2]["result"]["z"]
    assert z[0] == pytest.approx(plane_height(500155, 7000555), abs=1e-6) and z[1] is None
    assert answers[3]["result"]["ok"] is False and answers[3]["result"]["needed"] == 1
    assert answers[4]["error"] == "InputError" and "GCP a" in answers[4]["message"]
    fit = answers[5]["result"]
    assert fit["ok"] and fit["rms"]["control_px"] < 1e-6 and fit["forward"]["x"][0][0] == pytest.approx(500100)
    assert all("\n" not in a.get("message", "") for a in answers)


class _Collect:
    def __init__(self):
        self.sent = []

    def send(self, **message):
        self.sent.append(message)


def warn_then_return(progress=None, value=1):
    warnings.warn("first caution")
    warnings.warn("second\ncaution")
    return {"value": np.float64(value), "missing": [float("nan"), np.inf]}


def fail_unexpectedly(progress=None):
    raise KeyError("x")


def test_warnings_come_before_the_result_and_bugs_are_named(monkeypatch):
    from fotogeo import worker
    monkeypatch.setitem(worker.SESSION_TOOLS, "warn", ("test_worker_session", "warn_then_return"))
    monkeypatch.setitem(worker.SESSION_TOOLS, "bug", ("test_worker_session", "fail_unexpectedly"))
    channel = _Collect()
    worker.answer_request({"id": 7, "tool": "warn", "kwargs": {"value": 2}}, channel)
    worker.answer_request({"id": 8, "tool": "bug"}, channel)
    worker.answer_request({"id": 9, "tool": "warn", "kwargs": [1]}, channel)
    assert [(m["id"], m["type"]) for m in channel.sent] == [(7, "warning"), (7, "warning"), (7, "result"),
                                                           (8, "error"), (9, "error")]
    assert channel.sent[1]["message"] == "second caution"
    assert json.loads(worker._json_line(channel.sent[2]))["result"] == {"value": 2.0, "missing": [None, None]}
    assert channel.sent[3]["error"] == "KeyError" and channel.sent[3]["message"] == "KeyError: 'x'"


def test_the_worker_shows_warnings_as_the_command_line_does():
    """One rule for both (issue 24): numpy's notes silenced, rasterio's nodata/alpha note translated,
    fotogeo's own warning as it is — in the one-shot worker's hook and in a session request."""
    from fotogeo import worker
    from fotogeo.errors import IllPosedWarning
    from rasterio.errors import NodataShadowWarning
    channel = _Collect()
    show = worker._warning_hook(channel)
    for message, category in (("All-NaN slice encountered", RuntimeWarning),
                              ("overflow encountered in multiply", RuntimeWarning),
                              (NodataShadowWarning(), NodataShadowWarning), ("flat terrain", IllPosedWarning)):
        show(message, category, "f.py", 1)
    texts = [m["message"] for m in channel.sent]
    assert len(texts) == 2 and "alpha band" in texts[0] and texts[1] == "flat terrain", texts


# -- the QGIS client -----------------------------------------------------------------------------

@pytest.fixture
def session(qgis_app):
    from processing_provider.session import WorkerSession
    s = WorkerSession()
    yield s
    s.close()


def test_worker_session_calls_errors_restart_and_threads(session, dem_path):
    from processing_provider.session import SessionError
    z = session.call("sample_heights", xy=[[500155, 7000555]], crs=CRS, dem=str(dem_path))["z"]
    assert z[0] == pytest.approx(plane_height(500155, 7000555), abs=1e-6)
    with pytest.raises(SessionError, match="role 'maybe' is not one of") as e:
        session.call("fit_gcps", gcps=[{**affine_gcps(1)[0], "role": "maybe"}], model="affine", crs=CRS)
    assert e.value.error == "InputError"
    session._proc.kill()  # a crashed worker is restarted at the next call
    session._proc.wait()
    fit = session.call("fit_gcps", gcps=affine_gcps(6), model="affine", crs=CRS)
    assert fit["ok"] and session.starts == 2
    results, errors = {}, []

    def worker(k):
        try:
            results[k] = session.call("sample_heights", xy=[[500100 + 50 * k, 7000500]], crs=CRS, dem=str(dem_path))
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)
    threads = [threading.Thread(target=worker, args=(k,)) for k in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert not errors
    assert {k: r["z"][0] for k, r in results.items()} == pytest.approx(
        {k: plane_height(500100 + 50 * k, 7000500) for k in range(6)}, abs=1e-6)
    assert session.starts == 2


def test_worker_session_timeout_stops_the_worker(session, dem_path):
    from processing_provider.session import SessionError
    gcps = affine_gcps(40)
    with pytest.raises(SessionError, match="did not answer within"):
        session.call("fit_gcps", timeout=0.001, gcps=gcps, model="rfm", crs=CRS, default_height=100.0)
    assert session.call("sample_heights", xy=[[500155, 7000555]], crs=CRS, dem=str(dem_path))["z"][0] is not None
    assert session.starts == 2


def test_shared_session_is_one_per_process(qgis_app):
    from processing_provider.session import close_shared_session, shared_session
    a = shared_session()
    assert shared_session() is a
    close_shared_session()
    assert shared_session() is not a
    close_shared_session()
