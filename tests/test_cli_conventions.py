"""The command line's conventions (fotogeo/cli/conventions.py, rio as the model): GDAL virtual paths and URLs
as raster inputs, exit codes 0/1/2/130, -v/-q logging, --json, deprecated option spellings, library warnings
as fotogeo's one line."""
from __future__ import annotations

import json
import logging
import warnings
import zipfile

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin

from fotogeo.cli import conventions, main
from fotogeo.io.raster import is_virtual_path, open_raster


@pytest.fixture
def rgb(tmp_path, monkeypatch):
    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    rng = np.random.default_rng(7)
    path = tmp_path / "rgb.tif"
    with rasterio.open(path, "w", driver="GTiff", width=64, height=48, count=3, dtype="uint8", crs="EPSG:32635",
                       transform=from_origin(500000, 4000000, 10, 10)) as ds:
        ds.write((rng.random((3, 48, 64)) * 200 + 20).astype(np.uint8))
    return path


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], terminal_width=200)


def test_virtual_paths_are_recognised():
    for p in ("/vsizip//data/a.zip/b.tif", "/vsicurl/https://x.org/a.tif", "/vsis3/bucket/a.tif",
              "https://x.org/a.tif", "s3://bucket/a.tif", "zip+file://a.zip!b.tif"):
        assert is_virtual_path(p), p
    for p in ("a.tif", "/data/vsizip.tif", "C:\\data\\a.tif", "./vsi/a.tif"):
        assert not is_virtual_path(p), p


def test_fuse_reads_a_raster_inside_a_zip(rgb, tmp_path):
    """``fotogeo fuse /vsizip//.../archive.zip/rgb.tif`` reads through GDAL as ``rio`` does; same PC1 as unzipped."""
    archive = tmp_path / "archive.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.write(rgb, "inner/rgb.tif")
    virtual = f"/vsizip/{archive}/inner/rgb.tif"
    assert open_raster(virtual).path == virtual and open_raster(virtual).width == 64
    r = invoke("fuse", virtual, "-o", tmp_path / "zipped.tif", "-q")
    assert r.exit_code == 0, r.output
    r = invoke("fuse", rgb, "-o", tmp_path / "plain.tif", "-q")
    with rasterio.open(tmp_path / "zipped.tif") as a, rasterio.open(tmp_path / "plain.tif") as b:
        assert np.array_equal(a.read(), b.read()) and a.crs == b.crs
    r = invoke("fuse", f"/vsizip/{archive}/inner/missing.tif", "-o", tmp_path / "x.tif")
    assert r.exit_code == 1 and "cannot be read through GDAL" in r.stderr and "/vsizip/" in r.stderr
    assert not (tmp_path / "x.tif").exists()


def test_exit_codes(rgb, tmp_path):
    """1 for a failed run, 2 for a usage error (click's or an option's value), 0 done."""
    r = invoke("fuse", tmp_path / "missing.tif", "-o", tmp_path / "o.tif")
    assert r.exit_code == 1 and r.stderr.startswith("Error: ") and isinstance(r.exception, SystemExit)
    r = invoke("fuse", rgb, "-o", tmp_path / "o.tif", "--no-such-option")
    assert r.exit_code == 2 and "No such option" in r.stderr
    r = invoke("register", rgb, rgb, "-o", tmp_path / "o.tif", "--ratio", "0.01", "-q")
    assert r.exit_code == 2 and "ratio must be >= 0.05" in r.stderr
    assert invoke("fuse", rgb, "-o", tmp_path / "o.tif", "-q").exit_code == 0


def test_ctrl_c_exits_130(rgb, tmp_path, monkeypatch):
    import fotogeo.tools.register.fuse as fuse

    def interrupted(*a, **k):
        raise KeyboardInterrupt
    monkeypatch.setattr(fuse, "fuse_raster", interrupted)
    r = invoke("fuse", rgb, "-o", tmp_path / "o.tif")
    assert r.exit_code == 130 and "Cancelled: interrupted (Ctrl-C)" in r.stderr


@pytest.mark.parametrize("where", ["group", "command"])
def test_json_summary_on_stdout(rgb, tmp_path, where):
    args = ["fuse", rgb, "-o", tmp_path / "o.tif"]
    r = invoke(*(["--json", *args] if where == "group" else [*args, "--json"]))
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)  # stdout is the JSON document alone; the human line went to stderr
    assert doc["command"] == "fuse" and doc["exit_code"] == 0 and doc["result"]["output"] == str(tmp_path / "o.tif")
    assert 0 < doc["result"]["explained"] <= 1 and "PC1 explains" in r.stderr
    r = invoke("--json", "fuse", rgb, "-o", tmp_path / "o.tif")  # exists: a failed run, still JSON
    assert r.exit_code == 1 and json.loads(r.stdout) == {"command": "fuse", "exit_code": 1,
                                                         "error": r.stderr.strip()}


def test_quiet_and_verbose(rgb, tmp_path):
    r = invoke("-q", "fuse", rgb, "-o", tmp_path / "q.tif")
    assert r.exit_code == 0 and r.stderr == "" and r.stdout.startswith("PC1 explains")
    r = invoke("-v", "fuse", rgb, "-o", tmp_path / "v.tif")
    steps = [line for line in r.stderr.splitlines() if "%" in line]
    assert r.exit_code == 0 and len(steps) >= 2 and "\r" not in r.stderr  # one plain line per step


def test_library_log_records_become_one_warning_line(capsys):
    conventions.setup_logging(0, False)
    try:
        logging.getLogger("rasterio._env").warning("CPLE_AppDefined in TIFFReadDirectory:\n  odd tag 1234")
        logging.getLogger("rasterio._env").warning("CPLE_AppDefined in TIFFReadDirectory:\n  odd tag 1234")
        logging.getLogger("rasterio._env").info("a detail only -vv shows")
        logging.getLogger("fotogeo.x").info("a step only -v shows")
        err = capsys.readouterr().err
        assert err == "Warning: GDAL: TIFFReadDirectory: odd tag 1234\n", err
        conventions.setup_logging(1, False)
        logging.getLogger("fotogeo.x").info("a step -v shows")
        assert capsys.readouterr().err == "a step -v shows\n"
        conventions.setup_logging(0, True)
        logging.getLogger("rasterio._env").warning("hidden by -q")
        assert capsys.readouterr().err == ""
    finally:
        conventions.setup_logging(0, False)


def test_library_warnings_are_fotogeo_lines(rgb, tmp_path, monkeypatch):
    """A library's warning inside a run is one ``Warning:`` line in fotogeo's words, or silenced."""
    import fotogeo.tools.register.fuse as fuse
    real = fuse.fuse_raster

    def noisy(*a, **k):
        from rasterio.errors import NotGeoreferencedWarning
        warnings.warn("Dataset has no geotransform, gcps, or rpcs.", NotGeoreferencedWarning)
        warnings.warn("'crs' was not provided.  The output dataset will not have projection information defined "
                      "and may not be usable in other systems.", UserWarning)
        return real(*a, **k)
    monkeypatch.setattr(fuse, "fuse_raster", noisy)
    r = invoke("fuse", rgb, "-o", tmp_path / "o.tif")
    warned = [line for line in r.stderr.splitlines() if "Warning" in line or "warn" in line.lower()]
    assert r.exit_code == 0 and warned == ["Warning: a vector output has no CRS because its input has none; assign "
                                           "one (QGIS: Layer Properties > Source, or ogr2ogr -a_srs) before "
                                           "overlaying it on a map"], r.stderr


def test_deprecated_spellings_still_work_with_a_warning(rgb, tmp_path):
    assert conventions.rewrite_deprecated("register-batch", ["--outdir=x", "-q"]) == ["--output=x", "-q"]
    r = invoke("register-batch", rgb, tmp_path / "missing.tif", "--outdir", tmp_path / "out", "-q")
    assert "Warning: --outdir is deprecated and goes in the next release; use --output" in r.stderr
    assert "No such option" not in r.stderr
    r = invoke("coreg", rgb, rgb, "--reference-band", "1", "--target-band", "1", "--help")
    assert r.exit_code == 0 and "--reference-bands" in r.stdout and "--reference-band " not in r.stdout


def test_one_spelling_for_the_main_output():
    """Every command that writes a main output names it -o/--output."""
    for name, cmd in main.commands.items():
        flags = {o for p in cmd.params for o in getattr(p, "opts", [])}
        if "-o" in flags:
            assert "--output" in flags, (name, sorted(flags))
        assert not {"--outdir", "--out", "--reference-band", "--target-band"} & flags, (name, sorted(flags))


@pytest.mark.parametrize("where", ["group", "command"])
def test_quiet_silences_warnings_and_json_keeps_them(data_dir, tmp_path, where):
    """``-q`` is one setting wherever it is given: on main ``orient ... -q`` (the sub-command's flag) still printed
    the 'Warning: 2 GCP(s) ... outside the image' line; the --json document lists it, the report its GCPs."""
    qb2 = data_dir / "qb2"
    args = ["orient", qb2 / "qb2_basic1b.tif", qb2 / "gcps.geojson", "--model", "similarity",
            "--report", tmp_path / "r.json"]
    r = invoke(*(["-q", *args] if where == "group" else [*args, "-q"]))
    assert r.exit_code == 0 and r.stderr == "", r.stderr
    assert "skipped (outside the image (850x1450 px))" in r.stdout  # the summary stays
    assert [s["id"] for s in json.loads((tmp_path / "r.json").read_text())["skipped"]] == [
        "house-swcnr-90b", "grasnek-roadjunction1-50"]
    r = invoke(*args, "--overwrite", "-q", "--json")
    doc = json.loads(r.stdout)
    assert "Warning" not in r.stderr and len(doc["warnings"]) == 1 and "2 GCP(s)" in doc["warnings"][0]
    r = invoke(*args, "--overwrite")  # without -q the line is shown, once
    assert r.stderr.count("Warning: 2 GCP(s) of") == 1


def test_quiet_keeps_the_final_error(rgb, tmp_path):
    assert invoke("fuse", rgb, "-o", tmp_path / "o.tif", "-q").exit_code == 0
    r = invoke("fuse", rgb, "-o", tmp_path / "o.tif", "-q")
    assert r.exit_code == 1 and r.stderr.startswith("Error: ") and "--overwrite" in r.stderr
    assert not conventions.SETTINGS.quiet  # a sub-command's -q lasts for its run only
