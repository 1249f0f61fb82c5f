"""The triangulate dialog in the desktop ``qgis`` under Xvfb, as a GIS user meets it (issue 22): the frames,
orthophotos and DEM are layers of the project, no CRS is given, and the first run succeeds; the footprints load
as outlines below the points, and the log states the accuracy in words."""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
from test_qgis_real_programs import QGIS_DESKTOP, ROOT, _env, config  # noqa: F401 - config: a fixture

pytestmark = [pytest.mark.qgis, pytest.mark.skipif(
    not shutil.which("xvfb-run") or not os.path.exists(QGIS_DESKTOP),
    reason="xvfb and the qgis desktop are not installed (make test installs them)")]

FRAMES = ("3324c_2015_1004_05_0182_RGB.tif", "3324c_2015_1004_05_0184_RGB.tif")
ORTHOS = ("ngi_rgb_byte_1.tif", "ngi_rgb_byte_2.tif")

SCRIPT = r'''
import os, sys
from qgis.PyQt.QtCore import QTimer
from qgis.PyQt.QtWidgets import QTextEdit
from qgis.utils import iface
from qgis.core import QgsProject
OUT, DATA, TESTS = (os.environ[k] for k in ("FOTOGEO_DESKTOP_OUT", "FOTOGEO_DESKTOP_DATA", "FOTOGEO_DESKTOP_TESTS"))
sys.path.insert(0, TESTS)
from desktop_harness import Harness
HARNESS = Harness(OUT)
state, finish, guard = HARNESS.state, HARNESS.finish, HARNESS.guard

@guard
def dialog():
    import processing
    iface.mainWindow().resize(1280, 800)
    layers = {}
    for name in ("dem", "ngi_rgb_byte_1", "ngi_rgb_byte_2", "3324c_2015_1004_05_0182_RGB",
                 "3324c_2015_1004_05_0184_RGB"):
        layers[name] = iface.addRasterLayer(os.path.join(DATA, name + ".tif"), name).id()
    # what a user fills in: frames, camera, EO, the orthophotos and the DEM — no CRS, defaults otherwise
    dlg = processing.createAlgorithmDialog("fotogeo:triangulate", {
        "FRAMES": [layers["3324c_2015_1004_05_0182_RGB"], layers["3324c_2015_1004_05_0184_RGB"]],
        "CAMERA": os.path.join(DATA, "interior_orientation.yaml"),
        "EO": os.path.join(DATA, "exterior_orientation.txt"),
        "REFERENCE": [layers["ngi_rgb_byte_1"], layers["ngi_rgb_byte_2"]], "DEM": layers["dem"],
        "OUTDIR": os.path.join(OUT, "block")})
    dlg.resize(900, 760)
    dlg.show()
    globals()["DLG"] = dlg
    state["crs_param"] = str(dlg.createProcessingParameters().get("CRS"))
    QTimer.singleShot(1000, guard(lambda: (HARNESS.grab(dlg, "qgis_triangulate_dialog.png", 900), dlg.runAlgorithm(),
                                           wait(0))))

@guard
def wait(n):
    log = DLG.findChild(QTextEdit, "txtLog").toPlainText()
    if len(QgsProject.instance().mapLayers()) >= 8 or "Execution failed" in log or n > 400:
        state["layers"] = [node.layer().name() for node in QgsProject.instance().layerTreeRoot().findLayers()]
        state["log"] = log
        DLG.close()
        iface.mapCanvas().zoomToFullExtent()
        QTimer.singleShot(3000, guard(lambda: (HARNESS.grab(iface.mainWindow(), "qgis_triangulate_results.png", 960),
                                               finish())))
    else:
        QTimer.singleShot(500, guard(lambda: wait(n + 1)))

QTimer.singleShot(3000, dialog)
'''


def test_triangulate_dialog_runs_first_time_with_orthophotos_and_dem(config, data_dir, tmp_path, request):  # noqa: F811
    ngi = data_dir / "ngi"
    # a short folder as a user's survey folder: the dialog's screenshot in the docs shows its path
    survey = Path(tempfile.mkdtemp(prefix="survey-"))
    request.addfinalizer(lambda: shutil.rmtree(survey, ignore_errors=True))
    data = survey / "data"
    data.mkdir()
    for src in [ngi / "frames" / f for f in FRAMES] + [ngi / "ortho" / f for f in ORTHOS] + [
            ngi / "dem.tif", ngi / "interior_orientation.yaml", ngi / "exterior_orientation.txt"]:
        shutil.copy(src, data / src.name)
    script = tmp_path / "startup.py"
    script.write_text(SCRIPT)
    out = tmp_path / "desktop"
    out.mkdir()
    env = {**_env(config, pam="NO"), "FOTOGEO_DESKTOP_OUT": str(out), "FOTOGEO_DESKTOP_DATA": str(data),
           "FOTOGEO_DESKTOP_TESTS": str(Path(__file__).resolve().parent)}
    env.pop("QT_QPA_PLATFORM")
    subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x800x24", QGIS_DESKTOP, "--nologo", "--noversioncheck",
                    "--code", str(script)], capture_output=True, text=True, timeout=400, env=env, cwd=tmp_path)
    state = json.loads((out / "result.json").read_text())
    assert "error" not in state, state.get("error")
    assert state["crs_param"] in ("None", "")  # nothing given for the CRS
    log = state["log"]
    assert "Execution failed" not in log and "give the map CRS" not in log, log[-1500:]
    # the accuracy in words: check points held out by default, control placed by the images alone
    assert re.search(r"check points \(n=\d+, not used in the adjustment\): RMSE X [\d.]+ Y [\d.]+ Z [\d.]+ m", log)
    assert "control points placed by the images alone" in log and "σ-weighted" in log
    # the block's layers above the inputs: points, then the footprints (outlines) above the rasters
    layers = state["layers"]
    assert layers.index("Control and check points") < layers.index("Frame footprints")
    assert layers.index("Tie points") < layers.index("Frame footprints") < layers.index("ngi_rgb_byte_1")
    assert (out / "block" / "report.html").is_file()
    for png in ("qgis_triangulate_dialog.png", "qgis_triangulate_results.png"):
        assert (out / png).stat().st_size > 20_000, png
        if os.environ.get("FOTOGEO_UPDATE_SCREENSHOTS"):
            shutil.copy(out / png, ROOT / "docs" / png)
