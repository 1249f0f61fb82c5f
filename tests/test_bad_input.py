"""The bad-input matrix: every command and the Python API, fed what a hostile user would.

Each case asserts the promise of issue 12: exit code 2 (or the FotogeoError the Python API
raises), one ``Error: ...`` line naming the problem (no traceback, no WKT), nothing left in
the output folder, and the inputs untouched (same sha256, no new side files such as
``.aux.xml``). The inputs are a small synthetic scene (:func:`fotogeo.tools.demo.tool.make_scene`)
and bad files written beside it once per module.
"""
from __future__ import annotations

import errno
import os
import shutil
import subprocess
import warnings
from pathlib import Path

import pytest
from click.testing import CliRunner

from cli_output import not_progress
import fotogeo
from fotogeo.cli import main
from fotogeo.errors import FotogeoError, InputError, OutputError, VectorError
from fotogeo.tools.demo.tool import make_scene
from bad_input_files import _snapshot, _write_bad_inputs, write_round_two_inputs


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad_inputs")
    scene = make_scene(d, seed=7, size=400, pixel=12.0)
    _write_bad_inputs(d, scene)
    write_round_two_inputs(d, scene)
    (d / "exists.tif").write_bytes(b"x")
    return {"dir": d, "sha": _snapshot(d), "names": sorted(p.name for p in d.iterdir())}


@pytest.fixture
def out(env, tmp_path):
    folder = tmp_path / "out"
    folder.mkdir()
    yield folder
    assert sorted(p.name for p in folder.iterdir()) == [], "a failed run left files in the output folder"
    assert _snapshot(env["dir"]) == env["sha"], "an input file was modified"
    assert sorted(p.name for p in env["dir"].iterdir()) == env["names"], "a side file appeared beside the inputs"


def _expand(args, d: Path, out: Path) -> list[str]:
    return [a.format(d=d, out=out) for a in args]


def assert_one_line_error(result, expected: str):
    """Exit code 1 (the run failed) or 2 (an option's value: a usage error), exactly one ``Error:`` line containing
    ``expected``, no traceback, no WKT."""
    text = result.stderr
    assert result.exit_code in (1, 2) and isinstance(result.exception, SystemExit), \
        (result.exit_code, result.output, result.exception)
    assert "Traceback" not in result.output, result.output
    errors = [line for line in text.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1, text
    assert expected.lower() in errors[0].lower(), errors[0]
    assert "DATUM[" not in errors[0] and "PRIMEM[" not in errors[0] and len(errors[0]) < 700, errors[0]


R, T, G = "{d}/reference.tif", "{d}/target.tif", "{d}/gcps.gpkg"
REG = ["register", R, T, "-o", "{out}/o.tif", "-q"]
ORI = ["orient", T]
CMP = ["compare-models", T, G, "--table", "{out}/t.csv", "-q"]
TRF = ["transfer-points", T, T]
TRUE = ["orient", T, "{d}/true_gcps.gpkg", "--rectify", "{out}/r.tif"]
CLI_CASES = {
    # register: options checked before any file is read, inputs refused with their name
    "register seed -1": (REG + ["--seed", "-1"], "seed must be >= 0"),
    "register max-match-pixels 0": (REG + ["--max-match-pixels", "0"], "--max-match-pixels must be"),
    "register resolution inf": (REG + ["--resolution", "inf"], "resolution must be a finite number"),
    "register resolution nan": (REG + ["--resolution", "nan"], "resolution must be"),
    "register resolution negative": (REG + ["--resolution", "-3"], "resolution must be > 0"),
    "register target-nodata 300 on uint8": (REG + ["--target-nodata", "300"], "cannot be stored"),
    "register reference-nodata -5 on uint8": (REG + ["--reference-nodata", "-5"], "cannot be stored"),
    "register target-nodata 1.5 on uint8": (REG + ["--target-nodata", "1.5"], "not a whole number"),
    "register ratio 2": (REG + ["--ratio", "2"], "ratio must be"),
    "register check-fraction 0.95": (REG + ["--check-fraction", "0.95"], "--check-fraction must be"),
    "register ransac-threshold 0": (REG + ["--ransac-threshold", "0"], "--ransac-threshold must be"),
    "register exaggeration 0": (REG + ["--exaggeration", "0"], "exaggeration must be"),
    "register max-keypoints 1": (REG + ["--max-keypoints", "1"], "--max-keypoints must be"),
    "register terrain model without dem": (REG + ["--model", "dlt"], "needs a DEM"),
    "register missing reference": (["register", "{d}/nope.tif", T, "-o", "{out}/o.tif"], "does not exist"),
    "register target not a raster": (["register", R, "{d}/not_raster.tif", "-o", "{out}/o.tif"], "not_raster.tif"),
    "register truncated target": (["register", R, "{d}/truncated.tif", "-o", "{out}/o.tif"], "truncated.tif"),
    "register complex target": (["register", R, "{d}/complex.tif", "-o", "{out}/o.tif"], "complex"),
    "register target is a folder": (["register", R, "{d}/a_folder.tif", "-o", "{out}/o.tif"], "a_folder.tif"),
    "register output folder missing": (["register", R, T, "-o", "{out}/no/o.tif"], "does not exist"),
    "register output exists": (["register", R, T, "-o", "{d}/exists.tif"], "exists"),
    "register output is the target": (["register", R, T, "-o", T, "--overwrite"], "is also an input"),
    "register unreferenced reference": (["register", T, T, "-o", "{out}/o.tif"], "no georeference"),
    "register bad crs": (REG + ["--crs", "EPSG:999999"], "999999"),
    "register dem not a raster": (REG + ["--dem", "{d}/not_raster.tif"], "not_raster.tif"),
    # match and fuse
    "match ratio 0": (["match", R, T, "-o", "{out}/m.gpkg", "--ratio", "0"], "ratio must be"),
    "match missing target": (["match", R, "{d}/nope.tif", "-o", "{out}/m.gpkg"], "does not exist"),
    "match complex target": (["match", R, "{d}/complex.tif", "-o", "{out}/m.gpkg"], "complex"),
    "match output folder missing": (["match", R, T, "-o", "{out}/no/m.gpkg"], "does not exist"),
    "fuse seed -1": (["fuse", T, "-o", "{out}/f.tif", "--seed", "-1"], "seed must be >= 0"),
    "fuse complex source": (["fuse", "{d}/complex.tif", "-o", "{out}/f.tif"], "complex"),
    "fuse source not a raster": (["fuse", "{d}/not_raster.tif", "-o", "{out}/f.tif"], "not_raster.tif"),
    "fuse output exists": (["fuse", T, "-o", "{d}/exists.tif"], "exists"),
    # orient: options, GCP files, camera files
    "orient resolution negative": (ORI + [G, "--rectify", "{out}/r.tif", "--resolution", "-5"], "resolution must be > 0"),
    "orient resolution inf": (ORI + [G, "--rectify", "{out}/r.tif", "--resolution", "inf"], "finite"),
    "orient exaggeration 0": (ORI + [G, "--vectors", "{out}/v.gpkg", "--exaggeration", "0"], "exaggeration must be"),
    "orient scan pixel -1": (ORI + [G, "--report", "{out}/r.json", "--scan-pixel-um", "-1"], "--scan-pixel-um must be"),
    "orient unknown model": (ORI + [G, "--model", "nope"], "'nope' is not one of"),
    "orient csv without crs": (ORI + ["{d}/gcps.csv", "--report", "{out}/r.json"], "carries no CRS"),
    "orient text in numeric column": (ORI + ["{d}/text_col.csv", "--crs", "EPSG:32635"], "'G5' holds 'abc'"),
    "orient null geometries": (ORI + ["{d}/null_geom.gpkg", "--report", "{out}/r.json"], "'G3' has no geometry"),
    "orient points nan first line": (ORI + ["{d}/nan_first.points", "--report", "{out}/r.json"], "line 3: mapX is 'nan'"),
    "orient points nan without header": (ORI + ["{d}/nan_no_header.points", "--crs", "EPSG:32635"], "line 1: mapX"),
    "orient points enable inf": (ORI + ["{d}/enable_inf.points"], "enable is 'inf'"),
    "orient points enable 2": (ORI + ["{d}/enable_2.points"], "enable must be 1"),
    "orient points positive sourceY": (ORI + ["{d}/positive_y.points"], "sourceY = -row"),
    "orient points empty": (ORI + ["{d}/empty.points"], "holds no points"),
    "orient camera malformed": (ORI + [G, "--model", "collinearity", "--camera", "{d}/bad.yaml"],
                                "bad.yaml', line 1: camera 'cam': a camera must be a block of indented 'key: value' lines; got 'type pinhole'"),
    "orient camera text size": (ORI + [G, "--model", "collinearity", "--camera", "{d}/text_size.yaml"], "im_size"),
    "orient camera infinite focal": (ORI + [G, "--model", "collinearity", "--camera", "{d}/inf_focal.yaml"], "focal_len"),
    "orient camera latin-1": (ORI + [G, "--model", "collinearity", "--camera", "{d}/latin1.yaml"], "latin1.yaml"),
    "orient camera missing": (ORI + [G, "--model", "collinearity", "--camera", "{d}/nope.yaml"], "nope.yaml"),
    "orient gcp-tiff with dlt": (ORI + [G, "--model", "dlt", "--gcp-tiff", "{out}/g.tif"], "polynomial models only"),
    "orient rpc with poly1": (ORI + [G, "--model", "poly1", "--rpc", "{out}/r.tif"], "--rpc exports"),
    "orient gcps missing": (ORI + ["{d}/nope.gpkg", "--report", "{out}/r.json"], "does not exist"),
    "orient complex image": (["orient", "{d}/complex.tif", G], "complex"),
    # compare-models
    "compare counts abc": (CMP + ["--counts", "abc"], "is not N or N/M"),
    "compare counts 0,-1": (CMP + ["--counts", "0,-1"], "must be at least 1"),
    "compare trials 0": (CMP + ["--trials", "0"], "trials must be >= 1"),
    "compare seed -1": (CMP + ["--seed", "-1"], "seed must be >= 0"),
    "compare unknown model": (CMP + ["--models", "nope"], "nope unknown"),
    "compare table exists": (["compare-models", T, G, "--table", "{d}/exists.tif"], "exists"),
    # transfer-points and measure-targets
    "transfer nan row": (TRF + ["{d}/nan_row.csv", "-o", "{out}/t.csv"], "point 'B' has no valid 'ref_col'"),
    "transfer text in a column": (TRF + ["{d}/text_row.csv", "-o", "{out}/t.csv"], "'B' holds 'left'"),
    "transfer search radius 0": (TRF + ["{d}/nan_row.csv", "-o", "{out}/t.csv", "--search-radius", "0"],
                                 "--search-radius must be"),
    "transfer half window 1": (TRF + ["{d}/nan_row.csv", "-o", "{out}/t.csv", "--half-window", "1"],
                               "--half-window must be"),
    "transfer table missing": (TRF + ["{d}/nope.csv", "-o", "{out}/t.csv"], "does not exist"),
    "targets half window 2": (["measure-targets", T, "{d}/targets_nan.csv", "-o", "{out}/m.csv", "--half-window", "2"],
                              "--half-window must be"),
    "targets empty cell": (["measure-targets", T, "{d}/targets_nan.csv", "-o", "{out}/m.csv"], "'T2' has no valid"),
    # demo and the .points tools
    "demo seed -1": (["demo", "-o", "{out}/demo", "--seed", "-1"], "seed must be >= 0"),
    "demo unknown detector": (["demo", "-o", "{out}/demo", "--detector", "orb"], "'orb' is not one of"),
    "points-to-layer nan first line": (["points-to-layer", "{d}/nan_first.points", "-o", "{out}/g.gpkg"], "line 3"),
    "points-to-layer enable inf": (["points-to-layer", "{d}/enable_inf.points", "-o", "{out}/g.gpkg"], "finite"),
    "points-to-layer folder": (["points-to-layer", "{d}/rpc_folder", "-o", "{out}/g.gpkg"], "is a directory"),
    "layer-to-points null geometry": (["layer-to-points", "{d}/null_geom.gpkg", "-o", "{out}/g.points"],
                                      "without a geometry"),
    "layer-to-points csv": (["layer-to-points", "{d}/gcps.csv", "-o", "{out}/g.points"], "no point geometries"),
    # issue 24: heights the model never saw, a camera nested to exhaustion, options the image cannot hold
    "orient dlt rectify on a DEM above the camera": (TRUE + ["--model", "dlt", "--dem", "{d}/dem_high.tif"],
                                                     "dem_high.tif' reaches"),
    "orient collinearity rectify on a DEM above the camera": (
        TRUE + ["--model", "collinearity", "--camera", "{d}/camera.yaml", "--dem", "{d}/dem_high.tif"],
        "above the camera's projection centre (height 4300.0)"),
    "orient rfm-poly rectify on a DEM in feet": (TRUE + ["--model", "rfm-poly", "--dem", "{d}/dem_feet.tif"],
                                                 "the model has only seen"),
    "orient dlt rectify at a height above the camera": (TRUE + ["--model", "dlt", "--height", "6000"],
                                                        "the height 6000.0 reaches"),
    "orient camera nested 3000 deep": (ORI + [G, "--model", "collinearity", "--camera", "{d}/deep.yaml"],
                                       "deep.yaml', line 3: im_size: a list nested 3000 deep"),
    "register camera nested 3000 deep": (REG + ["--dem", "{d}/dem.tif", "--camera", "{d}/deep.yaml"],
                                         "deep.yaml', line 3"),
    "transfer empty table": (TRF + ["{d}/empty_points.csv", "-o", "{out}/t.csv"], "empty_points.csv' holds no points"),
    "targets empty table": (["measure-targets", T, "{d}/empty_targets.csv", "-o", "{out}/m.csv"], "holds no points"),
    "transfer half window larger than the image": (TRF + ["{d}/one_point.csv", "-o", "{out}/t.csv", "--half-window",
                                                          "5000"], "--half-window 5000 makes a 10001 x 10001 px window"),
    "targets half window larger than the image": (["measure-targets", T, "{d}/one_point.csv", "-o", "{out}/m.csv",
                                                   "--half-window", "100000"], "give at most 349"),
    "compare empty model name": (CMP + ["--models", "poly1,,affine"], "an empty entry in 'poly1,,affine'"),
}


@pytest.mark.parametrize("case", list(CLI_CASES))
def test_cli_bad_input(env, out, case):
    args, expected = CLI_CASES[case]
    result = CliRunner().invoke(main, _expand(args, env["dir"], out), terminal_width=200)
    assert_one_line_error(result, expected)


def _api_cases(d: Path, out: Path):
    t, r, g = d / "target.tif", d / "reference.tif", d / "gcps.gpkg"
    return {
        "register seed -1": (lambda: fotogeo.register(r, t, out / "o.tif", seed=-1), InputError, "seed"),
        "register resolution inf": (lambda: fotogeo.register(r, t, out / "o.tif", resolution=float("inf")),
                                    InputError, "finite"),
        "register target nodata 300": (lambda: fotogeo.register(r, t, out / "o.tif", target_nodata=300),
                                       InputError, "cannot be stored"),
        "orient resolution -1": (lambda: fotogeo.orient(t, g, rectify=out / "r.tif", resolution=-1.0), InputError,
                                 "resolution"),
        "orient unknown model": (lambda: fotogeo.orient(t, g, model="nope"), InputError, "nope"),
        "compare counts 0": (lambda: fotogeo.compare_models(t, g, counts=(0, 5)), InputError, "counts"),
        "compare trials 0": (lambda: fotogeo.compare_models(t, g, trials=0), InputError, "trials"),
        "compare seed -1": (lambda: fotogeo.compare_models(t, g, seed=-1), InputError, "seed"),
        "fuse seed -1": (lambda: fotogeo.fuse_raster(t, out / "f.tif", seed=-1), InputError, "seed"),
        "fuse complex": (lambda: fotogeo.fuse_raster(d / "complex.tif", out / "f.tif"), InputError, "complex"),
        "transfer radius 0": (lambda: fotogeo.transfer_gcps(t, t, d / "nan_row.csv", out / "t.csv", search_radius=0),
                              InputError, "search_radius"),
        "transfer nan row": (lambda: fotogeo.transfer_gcps(t, t, d / "nan_row.csv", out / "t.csv"), VectorError, "'B'"),
        "targets half window 0": (lambda: fotogeo.measure_targets(t, d / "targets_nan.csv", out / "m.csv",
                                                                  half_window=0), InputError, "half_window"),
        "match ratio 5": (lambda: fotogeo.match_images(r, t, out / "m.gpkg", ratio=5.0), InputError, "ratio"),
        "points_to_layer nan": (lambda: fotogeo.points_to_layer(d / "nan_no_header.points", out / "g.gpkg"),
                                VectorError, "line 1"),
        "layer_to_points null geometry": (lambda: fotogeo.layer_to_points(d / "null_geom.gpkg", out / "g.points"),
                                          VectorError, "geometry"),
        "run_demo seed -1": (lambda: fotogeo.run_demo(out / "demo", seed=-1), InputError, "seed"),
        "read_gcps null geometry": (lambda: fotogeo.orient(t, d / "null_geom.gpkg"), VectorError, "'G3'"),
        "transfer half window 5000": (lambda: fotogeo.transfer_gcps(t, t, d / "one_point.csv", out / "t.csv",
                                                                    half_window=5000), InputError, "half_window 5000"),
    }


API_CASES = list(_api_cases(Path("."), Path(".")))


@pytest.mark.parametrize("case", API_CASES)
def test_python_api_bad_input(env, out, case):
    call, kind, expected = _api_cases(env["dir"], out)[case]
    with pytest.raises(kind) as info:
        call()
    text = str(info.value)
    assert expected in text and "\n" not in text and len(text) < 700, text


# -- faults while writing: disk full, permission denied (simulated and, where possible, real) -----------------

def _failing_json(error):
    def write_json(path, data):
        Path(path).write_text("{")  # a partial temporary file, as a real failure leaves it
        raise error(Path(path))
    return write_json


@pytest.mark.parametrize("code, kind, expected", [
    (errno.ENOSPC, OutputError, "disk full while writing"),
    (errno.EACCES, OutputError, "permission denied"),
    (errno.EROFS, OutputError, "permission denied"),
])
def test_write_fault_names_the_final_output(env, out, monkeypatch, code, kind, expected):
    import fotogeo.tools.orient.tool as orient_tool
    monkeypatch.setattr(orient_tool, "write_json",
                        _failing_json(lambda p: OSError(code, os.strerror(code), str(p))))
    with pytest.raises(kind) as info:
        fotogeo.orient(env["dir"] / "target.tif", env["dir"] / "gcps.gpkg", report=out / "r.json")
    text = str(info.value)
    assert expected in text and str(out / "r.json") in text and ".part" not in text, text


def test_cli_disk_full_message(env, out, monkeypatch):
    import fotogeo.tools.orient.tool as orient_tool
    monkeypatch.setattr(orient_tool, "write_json",
                        _failing_json(lambda p: OSError(errno.ENOSPC, "No space left on device", str(p))))
    result = CliRunner().invoke(main, ["orient", str(env["dir"] / "target.tif"), str(env["dir"] / "gcps.gpkg"),
                                       "--report", str(out / "r.json"), "-q"])
    assert_one_line_error(result, f"disk full while writing '{out / 'r.json'}'")
    assert ".part" not in result.stderr


@pytest.fixture
def full_disk(tmp_path):
    """A 600 kB tmpfs nearly filled (root and mount needed; skipped otherwise)."""
    folder = tmp_path / "full"
    folder.mkdir()
    if os.geteuid() != 0 or not shutil.which("mount"):
        pytest.skip("a real full disk needs root to mount a small tmpfs")
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=600k", "tmpfs", str(folder)],
                      capture_output=True).returncode != 0:
        pytest.skip("mounting a small tmpfs is not allowed here")
    try:
        (folder / "fill").write_bytes(b"\0" * 560 * 1024)
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], check=False)


@pytest.mark.parametrize("args, output", [
    (["fuse", "{d}/target.tif", "-o", "{full}/f.tif"], "f.tif"),
    (["orient", "{d}/target.tif", "{d}/gcps.gpkg", "--vectors", "{full}/v.gpkg"], "v.gpkg"),
])
def test_real_disk_full(env, full_disk, args, output):
    before = sorted(p.name for p in full_disk.iterdir())
    result = CliRunner().invoke(main, [a.format(d=env["dir"], full=full_disk) for a in args] + ["-q"])
    assert_one_line_error(result, f"disk full while writing '{full_disk / output}'")
    assert ".part" not in result.stderr
    assert sorted(p.name for p in full_disk.iterdir()) == before, "a temporary file was left on the full disk"
    assert _snapshot(env["dir"]) == env["sha"]


# -- warnings on success: one line each ------------------------------------------------------------------------

def test_cli_prints_library_warnings_as_one_line(env, out, monkeypatch):
    import fotogeo.tools.register.fuse as fuse_tool
    real = fuse_tool.pca_fuse

    def noisy(*args, **kwargs):
        warnings.warn("a library complains\n  with a second line", RuntimeWarning)
        warnings.warn("a library complains\n  with a second line", RuntimeWarning)
        return real(*args, **kwargs)

    monkeypatch.setattr(fuse_tool, "pca_fuse", noisy)
    # no -q: it hides the warnings
    result = CliRunner().invoke(main, ["fuse", str(env["dir"] / "target.tif"), "-o", str(out / "f.tif")])
    assert result.exit_code == 0, result.output
    assert not_progress(result.stderr) == ["Warning: a library complains with a second line"], result.stderr
    (out / "f.tif").unlink()


def test_cli_says_library_warnings_in_fotogeo_words(env, out, monkeypatch):
    """numpy's and rasterio's notes (issue 24) are silenced or translated; fotogeo's own pass as they are."""
    from rasterio.errors import NodataShadowWarning, NotGeoreferencedWarning

    import fotogeo.tools.register.fuse as fuse_tool
    from fotogeo.errors import IllPosedWarning
    real = fuse_tool.pca_fuse

    def noisy(*args, **kwargs):
        warnings.warn("All-NaN slice encountered", RuntimeWarning)
        warnings.warn("overflow encountered in multiply", RuntimeWarning)
        warnings.warn(NotGeoreferencedWarning("Dataset has no geotransform, gcps, or rpcs."))
        warnings.warn(NodataShadowWarning())
        warnings.warn("flat terrain: use a 2-D model", IllPosedWarning)
        return real(*args, **kwargs)

    monkeypatch.setattr(fuse_tool, "pca_fuse", noisy)
    result = CliRunner().invoke(main, ["fuse", str(env["dir"] / "target.tif"), "-o", str(out / "f.tif")])
    assert result.exit_code == 0, result.output
    lines = not_progress(result.stderr)
    assert len(lines) == 2 and "nodata value and an alpha band" in lines[0], lines
    assert lines[1] == "Warning: flat terrain: use a 2-D model"
    (out / "f.tif").unlink()


def test_heights_partly_unseen_are_a_warning(env, out):
    """A DEM 3000 m higher on a corner: the rectification runs and says where it extrapolates."""
    result = CliRunner().invoke(main, _expand(TRUE + ["--model", "dlt", "--dem", "{d}/dem_corner.tif"],
                                              env["dir"], out))  # no -q: it hides the warnings
    assert result.exit_code == 0, result.output
    warned = [line for line in result.stderr.splitlines() if line.startswith("Warning:")]
    assert len(warned) == 1 and "dem_corner.tif" in warned[0] and "extrapolated" in warned[0], result.stderr
    (out / "r.tif").unlink()


def test_transfer_summary_names_statuses_plainly(env, out):
    result = CliRunner().invoke(main, _expand(TRF + ["{d}/one_point.csv", "-o", "{out}/t.csv", "-q"], env["dir"], out))
    assert result.exit_code == 0 and "statuses {'converged': 1}" in result.stdout, result.output
    assert "np.str_" not in result.output
    (out / "t.csv").unlink()


# -- readers used outside the tools -----------------------------------------------------------------------------

@pytest.mark.parametrize("content, expected", [
    (None, "is a folder"),
    (b'<?xml version="1.0" encoding="klingon"?><a/>', "not valid XML"),
    (b"<Dimap_Document><Inverse_Model/></Dimap_Document>", "no DIMAP Inverse_Model"),
    (b"LINE_OFF: 10\nSAMP_OFF: 5\n", "missing RPC00B key"),
    (b"\xff\xfe\x00garbage", "unsupported RPC format"),
])
def test_rpc_reader_bad_files(env, tmp_path, content, expected):
    from fotogeo.io.rpc import read_rpc
    path = env["dir"] / "rpc_folder" if content is None else tmp_path / "x_RPC.TXT"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(InputError, match=expected) as info:
        read_rpc(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_one_line_messages_shorten_wkt():
    from pyproj import CRS

    from fotogeo.errors import one_line
    text = one_line(f"the CRS {CRS.from_epsg(32635).to_wkt()} is projected")
    assert text == 'the CRS PROJCRS["WGS 84 / UTM zone 35N"] is projected'


def test_every_public_tool_is_behind_the_boundary():
    names = ["register", "orient", "compare_models", "match_images", "fuse_raster", "transfer_gcps",
             "measure_targets", "points_to_layer", "layer_to_points", "run_demo", "rpc_bias", "register_batch",
             "triangulate"]
    assert all(hasattr(getattr(fotogeo, n), "__wrapped_tool__") for n in names)


def test_matrix_size():
    assert len(CLI_CASES) + len(API_CASES) >= 60
    commands = {args[0] for args, _ in CLI_CASES.values()}
    assert commands >= {"register", "match", "fuse", "orient", "compare-models", "transfer-points",
                        "measure-targets", "demo", "points-to-layer", "layer-to-points"}
    assert isinstance(FotogeoError("x"), Exception)
