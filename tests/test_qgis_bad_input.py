"""Bad inputs through QGIS Processing (headless QGIS): the same one-line message as the command line.

Each case runs one algorithm with ``processing.run`` on the bad files of
:mod:`test_bad_input` and the matching ``fotogeo`` command; the
:class:`QgsProcessingException` must carry the CLI's ``Error:`` text (one line, no
traceback) — an option named by its parameter's label where the command line says its flag —,
nothing may be left in the output folder and the inputs stay unchanged, with no side file beside
them. GDAL's side files are enabled here (``GDAL_PAM_ENABLED`` unset, which the other QGIS tests set
to NO): a raster QGIS loads as a layer gets an ``.aux.xml`` of statistics beside it (tested), and
fotogeo's algorithms must not make QGIS load their file inputs (issue 24).
"""
from __future__ import annotations

import pytest
from click.testing import CliRunner
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingException, QgsProcessingFeedback  # noqa: E402

from fotogeo.cli import main  # noqa: E402
from test_bad_input import _snapshot, env, out  # noqa: E402,F401 - the bad input files and their checks

R, T, G = "{d}/reference.tif", "{d}/target.tif", "{d}/gcps.gpkg"
#: case: (algorithm, parameters, the equivalent command line, text both messages contain)
CASES = {
    "fuse complex raster": ("pcafusion", {"INPUT": "{d}/complex.tif", "OUTPUT": "{out}/f.tif"},
                            ["fuse", "{d}/complex.tif", "-o", "{out}/f.tif"], "complex"),
    "register target nodata 300": ("register", {"REFERENCE": R, "TARGET": T, "OUTPUT": "{out}/o.tif",
                                                "TARGET_NODATA": 300},
                                   ["register", R, T, "-o", "{out}/o.tif", "--target-nodata", "300"],
                                   "cannot be stored"),
    "register unreferenced reference": ("register", {"REFERENCE": T, "TARGET": T, "OUTPUT": "{out}/o.tif"},
                                        ["register", T, T, "-o", "{out}/o.tif"], "no georeference"),
    "orient points nan first line": ("orient", {"IMAGE": T, "GCPS": "{d}/nan_first.points",
                                                "REPORT": "{out}/r.json"},
                                     ["orient", T, "{d}/nan_first.points", "--report", "{out}/r.json"], "line 3"),
    "orient points enable inf": ("orient", {"IMAGE": T, "GCPS": "{d}/enable_inf.points", "REPORT": "{out}/r.json"},
                                 ["orient", T, "{d}/enable_inf.points", "--report", "{out}/r.json"], "enable is 'inf'"),
    "orient text in numeric column": ("orient", {"IMAGE": T, "GCPS": "{d}/text_col.csv", "CRS": "EPSG:32635",
                                                 "REPORT": "{out}/r.json"},
                                      ["orient", T, "{d}/text_col.csv", "--crs", "EPSG:32635", "--report",
                                       "{out}/r.json"], "'G5' holds 'abc'"),
    "orient null geometries": ("orient", {"IMAGE": T, "GCPS": "{d}/null_geom.gpkg", "REPORT": "{out}/r.json"},
                               ["orient", T, "{d}/null_geom.gpkg", "--report", "{out}/r.json"], "no geometry"),
    "orient positive sourceY": ("orient", {"IMAGE": T, "GCPS": "{d}/positive_y.points", "REPORT": "{out}/r.json"},
                                ["orient", T, "{d}/positive_y.points", "--report", "{out}/r.json"], "sourceY = -row"),
    "orient camera malformed": ("orient", {"IMAGE": T, "GCPS": G, "MODEL": "collinearity", "CAMERA": "{d}/bad.yaml",
                                           "REPORT": "{out}/r.json"},
                                ["orient", T, G, "--model", "collinearity", "--camera", "{d}/bad.yaml", "--report",
                                 "{out}/r.json"], "line 1: camera 'cam'"),
    "transfer nan row": ("transferpoints", {"REFERENCE": T, "SEARCH": T, "POINTS": "{d}/nan_row.csv",
                                            "OUTPUT": "{out}/t.csv"},
                         ["transfer-points", T, T, "{d}/nan_row.csv", "-o", "{out}/t.csv"], "point 'B'"),
    "orient dlt rectify on a DEM above the camera": (
        "orient", {"IMAGE": T, "GCPS": "{d}/true_gcps.gpkg", "MODEL": "dlt", "DEM": "{d}/dem_high.tif",
                   "RECTIFY": "{out}/r.tif"},
        ["orient", T, "{d}/true_gcps.gpkg", "--model", "dlt", "--dem", "{d}/dem_high.tif", "--rectify", "{out}/r.tif"],
        "above the camera's projection centre"),
    "orient camera nested 3000 deep": ("orient", {"IMAGE": T, "GCPS": G, "MODEL": "collinearity",
                                                  "CAMERA": "{d}/deep.yaml", "REPORT": "{out}/r.json"},
                                       ["orient", T, G, "--model", "collinearity", "--camera", "{d}/deep.yaml",
                                        "--report", "{out}/r.json"], "nested 3000 deep"),
    "transfer empty table": ("transferpoints", {"REFERENCE": T, "SEARCH": T, "POINTS": "{d}/empty_points.csv",
                                                "OUTPUT": "{out}/t.csv"},
                             ["transfer-points", T, T, "{d}/empty_points.csv", "-o", "{out}/t.csv"], "holds no points"),
    "transfer half window larger than the image": (
        "transferpoints", {"REFERENCE": T, "SEARCH": T, "POINTS": "{d}/one_point.csv", "OUTPUT": "{out}/t.csv",
                           "HALF_WINDOW": 5000},
        ["transfer-points", T, T, "{d}/one_point.csv", "-o", "{out}/t.csv", "--half-window", "5000"],
        "5000 makes a 10001 x 10001 px window"),
    "points to layer enable inf": ("pointstolayer", {"INPUT": "{d}/enable_inf.points", "OUTPUT": "{out}/g.gpkg"},
                                   ["points-to-layer", "{d}/enable_inf.points", "-o", "{out}/g.gpkg"], "enable is 'inf'"),
}


@pytest.fixture(autouse=True)
def side_files_enabled(monkeypatch):
    """GDAL writes its .aux.xml side files as it does for a user (qgis_env switched them off)."""
    monkeypatch.delenv("GDAL_PAM_ENABLED", raising=False)


def _fill(value, d, out):
    return value.format(d=d, out=out) if isinstance(value, str) else value


@pytest.mark.parametrize("case", list(CASES))
def test_qgis_gives_the_cli_message(qgis_app, env, out, case):
    import processing
    from qgis.core import QgsProcessingAlgorithm
    alg, params, cli, expected = CASES[case]
    d = env["dir"]
    algorithm = qgis_app.processingRegistry().algorithmById(f"fotogeo:{alg}")
    assert isinstance(algorithm, QgsProcessingAlgorithm)
    if "MODEL" in params:  # an enum parameter takes the index of the choice
        option = next(o for o in algorithm.parameterDefinitions() if o.name() == "MODEL")
        params = {**params, "MODEL": option.options().index(params["MODEL"])}
    result = CliRunner().invoke(main, [_fill(a, d, out) for a in cli] + ["-q"])
    cli_errors = [line for line in result.stderr.splitlines() if line.startswith("Error: ")]
    assert result.exit_code in (1, 2) and len(cli_errors) == 1, result.output  # a failed run or an option value
    with pytest.raises(QgsProcessingException) as info:
        processing.run(f"fotogeo:{alg}", {k: _fill(v, d, out) for k, v in params.items()},
                       feedback=QgsProcessingFeedback())
    message = str(info.value)
    assert expected in message and "Traceback" not in message, message
    # the same message, its --flags in the dialog's words (the parameter labels)
    assert algorithm.in_words(cli_errors[0][len("Error: "):]) in message, (cli_errors[0], message)
    assert " --" not in message, message  # no command-line flag in QGIS


def test_qgis_runs_leave_no_side_file_beside_the_inputs(qgis_app, env, out, tmp_path):
    """A successful run on file inputs (the ``out`` fixture checks the inputs' folder for side files); the
    control: the same raster loaded as a QGIS layer gets its .aux.xml beside it — QGIS's own doing."""
    import shutil

    import processing
    from qgis.core import QgsRasterLayer
    d = env["dir"]
    processing.run("fotogeo:pcafusion", {"INPUT": str(d / "target.tif"), "OUTPUT": str(out / "f.tif")},
                   feedback=QgsProcessingFeedback())
    processing.run("fotogeo:orient", {"IMAGE": str(d / "target.tif"), "GCPS": str(d / "true_gcps.gpkg"),
                                      "DEM": str(d / "dem.tif"), "REPORT": str(out / "r.json")},
                   feedback=QgsProcessingFeedback())
    for name in ("f.tif", "r.json"):
        (out / name).unlink()
    copy = tmp_path / "copy.tif"
    shutil.copy(d / "target.tif", copy)
    layer = QgsRasterLayer(str(copy), "copy", "gdal")
    assert layer.isValid()
    del layer
    assert (tmp_path / "copy.tif.aux.xml").is_file(), "QGIS no longer writes statistics beside a layer: update README"
