"""The plugin's runtime route without QGIS: the worker protocol, its cancel, the runtime's files.

``python -m fotogeo.worker`` is what the QGIS algorithms run (processing_provider/runner.py);
``processing_provider/runtime.py`` builds the environment it runs in.
"""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path


from processing_provider import runtime as rt

ROOT = Path(__file__).resolve().parents[1]


def _requirement_names(lines) -> dict:
    out = {}
    for line in lines:
        line = line.split("#")[0].strip()
        if line:
            name = re.match(r"[A-Za-z0-9_.-]+", line).group(0).lower()
            out.setdefault(name, set()).update(s.strip() for s in line[len(name):].split(",") if s.strip())
    return out


def test_runtime_requirements_follow_pyproject():
    """Every dependency of pyproject (click aside) and of its 'batch' extra, with pyproject's bounds and no
    others: the runtime is an isolated venv, so constraints.txt's Debian-venv caps do not apply to it."""
    import tomllib
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    deps = _requirement_names(project["dependencies"] + project["optional-dependencies"]["batch"])
    runtime = _requirement_names(rt.REQUIREMENTS.read_text().splitlines())
    deps.pop("click")
    assert runtime == deps


def _worker(request: dict, cwd) -> subprocess.Popen:
    env = rt.worker_environment({**os.environ, "GDAL_PAM_ENABLED": "NO", "LD_LIBRARY_PATH": "/usr/lib/grass82/lib"})
    proc = subprocess.Popen([sys.executable, "-m", "fotogeo.worker"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=cwd)
    proc.stdin.write(json.dumps(request) + "\n")
    proc.stdin.flush()
    return proc


def test_worker_runs_a_tool_and_answers_in_json(data_dir, tmp_path):
    proc = _worker({"tool": "fuse_raster", "args": [str(data_dir / "landsat_rgb/RGB.byte.tif"),
                                                    str(tmp_path / "pc1.tif")], "kwargs": {}}, tmp_path)
    lines = [json.loads(line) for line in proc.stdout]
    assert proc.wait() == 0
    assert {m["type"] for m in lines[:-1]} == {"progress"} and lines[-1]["type"] == "result"
    assert 0.5 < lines[-1]["result"]["explained"] <= 1 and (tmp_path / "pc1.tif").is_file()
    # a fotogeo error: one line, the CLI's exit status
    proc = _worker({"tool": "fuse_raster", "args": [str(tmp_path / "missing.tif"), str(tmp_path / "x.tif")],
                    "kwargs": {}}, tmp_path)
    last = [json.loads(line) for line in proc.stdout][-1]
    assert proc.wait() == 2 and last["type"] == "error" and "missing.tif" in last["message"]
    assert "\n" not in last["message"] and not last["cancelled"]


def test_sigterm_cancels_and_cleans_up(data_dir, tmp_path):
    """SIGTERM during resampling: Cancelled inside the tool, exit 130, no file left (AtomicOutputs)."""
    out = tmp_path / "out"
    out.mkdir()
    proc = _worker({"tool": "register", "args": [str(data_dir / "ngi/ortho/ngi_rgb_byte_1.tif"),
                                                 str(data_dir / "ngi/frames/3324c_2015_1004_05_0182_RGB.tif"),
                                                 str(out / "r.tif")], "kwargs": {"max_keypoints": 1500}}, tmp_path)
    last = None
    for line in proc.stdout:
        last = json.loads(line)
        if last["type"] == "progress" and last["message"].startswith("resampling window"):
            proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 130
    assert last["type"] == "error" and last["cancelled"]
    assert last["message"].startswith("cancelled by the user during: resampling")
    assert sorted(p.name for p in out.iterdir()) == []


def test_worker_check_reports_the_wheels_libraries():
    info = json.loads(subprocess.run([sys.executable, "-m", "fotogeo.worker", "--check"], capture_output=True,
                                     text=True, env=rt.worker_environment(), timeout=120, check=True).stdout)
    assert info["ok"], info["problems"]
    assert set(info["libraries"]) == {"GDAL (rasterio)", "GDAL (pyogrio)", "GEOS (shapely)", "PROJ (pyproj)"}
    assert info["loaded"] and all("site-packages" in p for p in info["loaded"])


def test_worker_environment_drops_qgis_library_variables():
    env = rt.worker_environment({"LD_LIBRARY_PATH": "/usr/lib/grass82/lib", "GDAL_DATA": "/usr/share/gdal",
                                 "PROJ_LIB": "/usr/share/proj", "HOME": "/root", "GDAL_PAM_ENABLED": "NO"})
    assert env == {"HOME": "/root", "GDAL_PAM_ENABLED": "NO", "PYTHONPATH": str(rt.PLUGIN_ROOT),
                   "PYTHONNOUSERSITE": "1"}


def test_status_names_what_is_missing_and_the_fix(tmp_path, monkeypatch):
    monkeypatch.delenv("FOTOGEO_PYTHON", raising=False)
    monkeypatch.delenv("FOTOGEO_RUNTIME", raising=False)
    runtime = rt.resolve(tmp_path / "profile")
    assert runtime.folder == tmp_path / "profile" / "python" / "fotogeo-env"
    ok, message = rt.status(runtime)
    assert not ok and "is not installed" in message and rt.fix_command(runtime) in message
    (runtime.folder / "bin").mkdir(parents=True)
    runtime.python.symlink_to(sys.executable)
    runtime.stamp.write_text(json.dumps({"requirements": "old", "check": {"ok": True}}))
    ok, message = rt.status(runtime)
    assert not ok and "other requirements" in message
    runtime.stamp.write_text(json.dumps({"requirements": rt.requirements_digest(),
                                         "check": {"ok": True, "libraries": {"GEOS (shapely)": "3.14.1"}}}))
    assert rt.status(runtime) == (True, f"fotogeo runs in {runtime.folder} (GEOS (shapely) 3.14.1)")


def test_ini_edit_keeps_other_lines(tmp_path):
    ini = tmp_path / "QGIS3.ini"
    ini.write_text("[General]\nlocale=en\n\n[PythonPlugins]\nprocessing=true\nother=false\n\n[qgis]\nx=@Variant(\\0)\n")
    rt.set_ini_value(ini, "PythonPlugins", "fotogeo_qgis", "true")
    rt.set_ini_value(ini, "PythonPlugins", "other", "true")
    rt.set_ini_value(ini, "fotogeo", "runtime", "/opt/rt")
    assert ini.read_text() == ("[General]\nlocale=en\n\n[PythonPlugins]\nprocessing=true\nother=true\n"
                               "fotogeo_qgis=true\n\n[qgis]\nx=@Variant(\\0)\n\n[fotogeo]\nruntime=/opt/rt\n")


def test_install_progress_names_pip_steps_never_warnings():
    """The install's progress messages are pip's steps in a few words; a warning stays in the log (it was shown
    cut at 80 characters as the progress line)."""
    import doctest
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner()
    for test in finder.find(rt.pip_step, "pip_step", globs={"pip_step": rt.pip_step}):
        runner.run(test)
    assert runner.failures == 0 and runner.tries == 3
    assert rt.pip_step("Successfully installed affine-2.4.0 numpy-1.26.4") == "installed"
    assert rt.pip_step("DEPRECATION: a long notice about something that pip will change in a future version") is None
