"""The toolbox dialogs: every fotogeo algorithm opens in Processing's AlgorithmDialog, every parameter
gets a widget, and the values a user enters there run the algorithm.

Runs in a fresh process with a GUI-enabled QgsApplication (offscreen); the other QGIS tests share
a non-GUI one, and only one QgsApplication can exist per process.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from qgis_env import need_qgis

ROOT = Path(__file__).resolve().parents[1]
pytestmark = [pytest.mark.qgis]

SCRIPT = r'''
import json, os, sys
root, data, out = sys.argv[1:4]
sys.path.append("/usr/share/qgis/python/plugins")
sys.path.insert(0, root)
from qgis.core import QgsApplication, QgsProcessingContext
app = QgsApplication([], True)
app.initQgis()
from processing.core.Processing import Processing
Processing.initialize()
from processing_provider.provider import FotogeoProvider
provider = FotogeoProvider()
QgsApplication.processingRegistry().addProvider(provider)
import processing
from processing.gui.AlgorithmDialog import AlgorithmDialog
res = {}
values = {
    "pcafusion": {"INPUT": f"{data}/landsat_rgb/RGB.byte.tif", "OUTPUT": f"{out}/pc1.tif"},
    "register": {"REFERENCE": f"{data}/ngi/ortho/ngi_rgb_byte_1.tif", "MAX_KEYPOINTS": 1500,
                 "TARGET": f"{data}/ngi/frames/3324c_2015_1004_05_0182_RGB.tif", "OUTPUT": f"{out}/reg.tif"},
    "pointstolayer": {"INPUT": f"{out}/in.points", "OUTPUT": f"{out}/gcps.gpkg"},
    "layertopoints": {"INPUT": f"{out}/gcps.gpkg", "OUTPUT": f"{out}/back.points"},
}
with open(f"{out}/in.points", "w") as f:
    f.write("#CRS: EPSG:32735\nmapX,mapY,sourceX,sourceY,enable,dX,dY,residual\n1,2,3.5,-4.5,1,0,0,0\n5,6,7.5,-8.5,0,0,0,0\n")
context = QgsProcessingContext()
for name in ("pcafusion", "register", "pointstolayer", "layertopoints"):
    alg = QgsApplication.processingRegistry().algorithmById(f"fotogeo:{name}")
    r = res[name] = {}
    try:
        dialog = AlgorithmDialog(alg.create(), False, None)
        panel = dialog.mainWidget()
        r["widgets"] = sorted(panel.wrappers)
        r["parameters"] = sorted(p.name() for p in alg.parameterDefinitions())
        for key, value in values[name].items():
            if key in panel.wrappers:
                panel.wrappers[key].setParameterValue(value, context)
            else:  # destinations have their own widgets in 3.22
                panel.outputWidgets[key].setValue(value)
        params = panel.createProcessingParameters()
        r["result"] = {k: (v if isinstance(v, (int, float, str)) else str(v))
                       for k, v in processing.run(alg, params).items()}
    except Exception as e:
        import traceback
        r["error"] = traceback.format_exc()
print("RESULT " + json.dumps(res))
sys.stdout.flush()
os._exit(0)
'''


def test_every_algorithm_runs_from_its_dialog(tmp_path, data_dir):
    need_qgis()
    script = tmp_path / "dialogs.py"
    script.write_text(SCRIPT)
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", HOME=str(tmp_path / "home"))
    r = subprocess.run([sys.executable, str(script), str(ROOT), str(data_dir), str(tmp_path)], cwd=tmp_path,
                       env=env, capture_output=True, text=True, timeout=180)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"dialog script failed (rc {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    res = json.loads(lines[-1][7:])
    assert set(res) == {"pcafusion", "register", "pointstolayer", "layertopoints"}
    for name, r in res.items():
        assert "error" not in r, f"{name}:\n{r['error']}"
        inputs = [p for p in r["parameters"] if p not in ("OUTPUT", "VECTORS", "REPORT")]
        assert set(inputs) <= set(r["widgets"]), (name, set(inputs) - set(r["widgets"]))
    assert (tmp_path / "pc1.tif").exists() and res["pcafusion"]["result"]["EXPLAINED"] > 0.5
    reg = res["register"]["result"]
    assert reg["OUTPUT_CRS"] == "EPSG:32735" and reg["INLIERS"] > 50
    assert {p.name for p in tmp_path.iterdir()} >= {"reg.tif"}
    assert res["pointstolayer"]["result"]["COUNT"] == 2 and res["layertopoints"]["result"]["COUNT"] == 2
    assert (tmp_path / "back.points").read_text().splitlines()[2:] == ["1,2,3.5,-4.5,1,0,0,0", "5,6,7.5,-8.5,0,0,0,0"]
