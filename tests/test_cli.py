"""The command line as a user meets it: options generated from the option table, exit codes, messages."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin

from fotogeo.cli import main
from fotogeo.cli import common
from fotogeo.options import (COMPARE, DEMO, FUSE, GCP, LAYER_TO_POINTS, MATCH, ORIENT, POINTS_TO_LAYER,
                             REGISTER, REGISTER_TERRAIN, RPC_BIAS, TARGETS, TRANSFER)
from fotogeo.options.dsm import DSM
from fotogeo.options.products import MOSAIC, ORTHO

#: command -> the option tables it is generated from
COMMANDS = {"register": (REGISTER_TERRAIN, REGISTER), "match": (MATCH,), "fuse": (FUSE,), "demo": (DEMO,),
            "orient": (ORIENT, GCP), "compare-models": (COMPARE, GCP), "transfer-points": (TRANSFER,),
            "measure-targets": (TARGETS,), "rpc-bias": (RPC_BIAS,), "points-to-layer": (POINTS_TO_LAYER,),
            "layer-to-points": (LAYER_TO_POINTS,), "ortho": (ORTHO,), "mosaic": (MOSAIC,),
            "dsm": (DSM,)}


@pytest.fixture
def small_rgb(tmp_path):
    """A 3-band 64 x 48 GeoTIFF (UTM, 10 m) of smooth random texture."""
    rng = np.random.default_rng(3)
    data = (rng.random((3, 48, 64)) * 200 + 20).astype(np.uint8)
    path = tmp_path / "rgb.tif"
    with rasterio.open(path, "w", driver="GTiff", width=64, height=48, count=3, dtype="uint8", crs="EPSG:32635",
                       transform=from_origin(500000, 4000000, 10, 10)) as ds:
        ds.write(data)
    return path


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], terminal_width=200)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_command_options_come_from_the_table(name):
    """Each table option is a click option of the command with the table's flag, default and help."""
    params = {p.name: p for p in main.commands[name].params}
    for table in COMMANDS[name]:
        for option in table.values():
            p = params.get(option.name)
            assert p is not None, f"{name}: option {option.name} has no click option"
            assert option.cli_flag in p.opts, (name, option.name, p.opts)
            default = None if option.needs else option.default  # not given: None, the default with the other
            if option.kind in ("choices", "ints") and default is not None:
                default = ",".join(map(str, default))
            assert p.default == default, (name, option.name)
            assert p.help == option.help
            if option.kind == "choice":
                assert tuple(p.type.choices) == option.choices
    help_text = invoke(name, "--help").output
    assert all(o.cli_flag in help_text for t in COMMANDS[name] for o in t.values())


def test_help_shows_the_defaults():
    text = invoke("register", "--help").output
    assert "--ratio FLOAT" in text and "[default: 0.8]" in text and "[default: auto]" in text
    assert "--mutual / --no-mutual" in text and "[default: surf]" in text
    assert "[the paper's: 40,20,15,10,6 classical, 60,55,50,45,40 RFMs]" in " ".join(
        invoke("compare-models", "--help").output.split())


def test_cancel_exits_130_with_one_line(small_rgb, tmp_path, monkeypatch):
    """A progress callback saying stop: exit code 130 (as an interrupted job), one line, no output left."""
    monkeypatch.setattr(common.ConsoleProgress, "__call__", lambda self, fraction, message: False)
    out = tmp_path / "pc1.tif"
    r = invoke("fuse", small_rgb, "-o", out)
    assert r.exit_code == common.EXIT_CANCELLED == 130, r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Cancelled: cancelled by the user"), r.stderr
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["rgb.tif"]


def test_fuse_runs_and_errors_exit_1(small_rgb, tmp_path):
    out = tmp_path / "pc1.tif"
    r = invoke("fuse", small_rgb, "-o", out, "--no-stretch", "--seed", 4, "-q")
    assert r.exit_code == 0, r.output
    with rasterio.open(out) as ds:
        assert ds.dtypes[0] == "float32" and ds.crs.to_epsg() == 32635
    r = invoke("fuse", small_rgb, "-o", out, "-q")  # exists, no --overwrite: the run fails (exit 1)
    assert r.exit_code == 1 and r.stderr.startswith("Error: ") and len(r.stderr.strip().splitlines()) == 1
    assert r.stderr.strip().endswith("exists; pass --overwrite to replace it"), r.stderr  # the flag, not the keyword


@pytest.mark.parametrize("args, message", [
    (["--ratio", "0.01"], "ratio must be >= 0.05"),
    (["--check-fraction", "0.95"], "--check-fraction must be >= 0.0 and <= 0.89"),
    (["--resolution", "0"], "resolution must be > 0.0"),
    (["--max-keypoints", "5"], "--max-keypoints must be >= 10"),
])
def test_register_ranges_from_the_table(small_rgb, tmp_path, args, message):
    """Out-of-range values stop before any work, with the option's name and its valid range."""
    r = invoke("register", small_rgb, small_rgb, "-o", tmp_path / "o.tif", "-q", *args)
    assert r.exit_code == 2 and message in r.stderr, r.stderr
    assert not (tmp_path / "o.tif").exists()


def test_comma_lists_are_checked(small_rgb, tmp_path):
    r = invoke("compare-models", small_rgb, tmp_path / "g.csv", "--counts", "10,x")
    assert r.exit_code == 2 and "'x' is not N or N/M" in r.output
    r = invoke("compare-models", small_rgb, tmp_path / "g.csv", "--spreads", "homogeneous,random")
    assert r.exit_code == 2 and "random unknown" in r.output


class _Stream:
    """A text stream that says whether it is a terminal."""

    def __init__(self, tty: bool):
        self.tty, self.text = tty, ""

    def isatty(self):
        return self.tty

    def write(self, s):
        self.text += s

    def flush(self):
        pass


def test_progress_never_goes_back_and_writes_plain_lines_into_a_log():
    """Nested stages report 2.3 % then 0.7 % (make demo's log showed 11.2 % -> 6.9 %): the shown percentage
    stays; into a file (not a terminal) a line per step, no carriage returns."""
    steps = [(0.023, "target: reading"), (0.007, "reference: keypoints"), (0.007, "reference: keypoints"),
             (0.112, "matching"), (0.069, "matching"), (0.5, "matching"), (1.0, "done")]
    log = _Stream(tty=False)
    bar = common.ConsoleProgress(stream=log)
    for f, m in steps:
        bar(f, m)
    bar.close()
    lines = log.text.splitlines()
    assert "\r" not in log.text and lines == ["  2.3% target: reading", "  2.3% reference: keypoints",
                                              " 11.2% matching", " 50.0% matching", "100.0% done"]
    log = _Stream(tty=False)  # a message that differs only in its counts: one line per 10 % step
    bar = common.ConsoleProgress(stream=log)
    for i in range(60):
        bar(0.5 + 0.001 * i, f"bundle adjustment: iteration {i + 1}, cost {6606.3 - i * 0.01:g}")
    bar(0.56, "matching pair 1/7")
    bar(0.57, "matching pair 2/7")
    assert log.text.splitlines() == [" 50.0% bundle adjustment: iteration 1, cost 6606.3", " 56.0% matching pair 1/7"]
    term = _Stream(tty=True)
    bar = common.ConsoleProgress(stream=term)
    for f, m in steps:
        bar(f, m)
    shown = [float(p) for p in re.findall(r"\] +([\d.]+)%", term.text)]
    assert shown == sorted(shown) and term.text.startswith("\r[")


def test_python_m_fotogeo_cli_is_the_command(tmp_path):
    """``python -m fotogeo.cli`` runs the same command group as the ``fotogeo`` script (a user without the
    script on the PATH); a bad input is the same one ``Error:`` line and exit code 1 (a failed run)."""
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    r = subprocess.run([sys.executable, "-m", "fotogeo.cli", "--help"], capture_output=True, text=True, env=env,
                       timeout=120)
    assert r.returncode == 0 and "triangulate" in r.stdout and "Usage: fotogeo" in r.stdout, r.stderr
    r = subprocess.run([sys.executable, "-m", "fotogeo.cli", "triangulate", str(tmp_path / "missing.JPG"), "-o",
                        str(tmp_path / "out")], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 1 and r.stderr.count("Error:") == 1 and "missing.JPG" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "out").exists()
