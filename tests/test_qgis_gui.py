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
#: a guard against a hung dialog, not a time limit: at load 25–30 on 2 cores the dialogs took 413 s wall for
#: 16.5 CPU s (docs/development.md), and 180 s failed them there
HANG_GUARD_S = 900
pytestmark = [pytest.mark.qgis]

SCRIPT = r'''
import json, os, sys
root, data, out, gcps = sys.argv[1:5]
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
from fotogeo.options import ORIENT
res = {}
values = {
    "pcafusion": {"INPUT": f"{data}/landsat_rgb/RGB.byte.tif", "OUTPUT": f"{out}/pc1.tif"},
    "register": {"REFERENCE": f"{data}/ngi/ortho/ngi_rgb_byte_1.tif", "MAX_KEYPOINTS": 1500,
                 "TARGET": f"{data}/ngi/frames/3324c_2015_1004_05_0182_RGB.tif", "OUTPUT": f"{out}/reg.tif"},
    "pointstolayer": {"INPUT": f"{out}/in.points", "OUTPUT": f"{out}/gcps.gpkg"},
    "layertopoints": {"INPUT": f"{out}/gcps.gpkg", "OUTPUT": f"{out}/back.points"},
    "orient": {"IMAGE": f"{data}/ngi/frames/3324c_2015_1004_05_0182_RGB.tif", "GCPS": gcps,
               "DEM": f"{data}/ngi/dem.tif", "MODEL": ORIENT["model"].qgis_choices.index("dlt"),
               "REPORT": f"{out}/orient.json",
               "VECTORS": f"{out}/orient.gpkg"},
    "comparemodels": {"IMAGE": f"{data}/ngi/frames/3324c_2015_1004_05_0182_RGB.tif", "GCPS": gcps,
                      "DEM": f"{data}/ngi/dem.tif", "MODELS": [0, 4], "COUNTS": "20", "TRIALS": 1,
                      "TABLE": f"{out}/table.csv"},
}
with open(f"{out}/in.points", "w") as f:
    f.write("#CRS: EPSG:32735\nmapX,mapY,sourceX,sourceY,enable,dX,dY,residual\n"
            "1,2,3.5,-4.5,1,0,0,0\n5,6,7.5,-8.5,0,0,0,0\n")
context = QgsProcessingContext()
others = sorted(a.name() for a in provider.algorithms() if a.name() not in values)
for name in list(values) + others:  # every dialog opens; the algorithms with values also run, in this order
    alg = QgsApplication.processingRegistry().algorithmById(f"fotogeo:{name}")
    r = res[name] = {}
    try:
        dialog = AlgorithmDialog(alg.create(), False, None)
        panel = dialog.mainWidget()
        r["widgets"] = sorted(panel.wrappers)
        r["parameters"] = sorted(p.name() for p in alg.parameterDefinitions() if not p.isDestination())
        r["destinations"] = sorted(p.name() for p in alg.parameterDefinitions() if p.isDestination())
        for key, value in values.get(name, {}).items():
            panel.wrappers[key].setParameterValue(value, context)
        if name not in values:
            continue
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


def _gcps(data_dir, path):
    """60 GCPs of NGI frame 0182 from its true geometry (fields col, row, role, id; heights from the DEM)."""
    import geopandas as gpd
    import numpy as np
    import shapely

    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.simulation import make_gcps
    ngi = data_dir / "ngi"
    dem = read_dem(ngi / "dem.tif")
    s = make_gcps(load_ngi_frame(ngi, "3324c_2015_1004_05_0182"), dem, 40, 20, "homogeneous", noise=0.3, seed=5)
    pixel = np.vstack([s.gcp_pixel, s.check_pixel])
    gpd.GeoDataFrame({"id": [f"P{i}" for i in range(60)], "col": pixel[:, 0], "row": pixel[:, 1],
                      "role": ["control"] * 40 + ["check"] * 20},
                     geometry=shapely.points(np.vstack([s.gcp_ground, s.check_ground])[:, :2]),
                     crs=dem.crs.to_wkt()).to_file(path, driver="GPKG")
    return path


def test_every_algorithm_runs_from_its_dialog(tmp_path, data_dir):
    need_qgis()
    script = tmp_path / "dialogs.py"
    script.write_text(SCRIPT)
    gcps = _gcps(data_dir, tmp_path / "ngi_gcps.gpkg")
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", HOME=str(tmp_path / "home"),
               FOTOGEO_PYTHON=sys.executable)
    r = subprocess.run([sys.executable, str(script), str(ROOT), str(data_dir), str(tmp_path), str(gcps)],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=HANG_GUARD_S)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"dialog script failed (rc {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    res = json.loads(lines[-1][7:])
    sys.path.insert(0, str(ROOT))
    from processing_provider.algorithms import ALGORITHMS
    assert set(res) == {a.ALG_ID for a in ALGORITHMS}
    for name, r in res.items():
        assert "error" not in r, f"{name}:\n{r['error']}"
        # one widget per parameter, destinations included
        assert r["destinations"] and set(r["parameters"]) | set(r["destinations"]) == set(r["widgets"]), name
    assert (tmp_path / "pc1.tif").exists() and res["pcafusion"]["result"]["EXPLAINED"] > 0.5
    reg = res["register"]["result"]
    # the reference's CRS (tmerc lon_0=25), register's default output CRS since issue 11
    assert 'PARAMETER["central_meridian",25]' in reg["OUTPUT_CRS"] and reg["INLIERS"] > 50
    assert {p.name for p in tmp_path.iterdir()} >= {"reg.tif"}
    assert res["pointstolayer"]["result"]["COUNT"] == 2 and res["layertopoints"]["result"]["COUNT"] == 2
    assert res["orient"]["result"]["MODEL_NAME"] == "dlt" and res["orient"]["result"]["CHECK_RMS_XY_PX"] < 0.6
    assert (tmp_path / "orient.json").exists() and (tmp_path / "orient.gpkg").exists()
    assert res["comparemodels"]["result"]["ROWS"] == 4 and (tmp_path / "table.csv").exists()
    assert (tmp_path / "back.points").read_text().splitlines()[2:] == ["1,2,3.5,-4.5,1,0,0,0", "5,6,7.5,-8.5,0,0,0,0"]


DEFAULTS_SCRIPT = r'''
import json, os, sys
root, data = sys.argv[1:3]
sys.path.append("/usr/share/qgis/python/plugins")
sys.path.insert(0, root)
from qgis.core import QgsApplication, QgsProject, QgsRasterLayer
app = QgsApplication([], True)
app.initQgis()
from processing.core.Processing import Processing
Processing.initialize()
from processing_provider.provider import FotogeoProvider
provider = FotogeoProvider()
QgsApplication.processingRegistry().addProvider(provider)
from processing.gui.AlgorithmDialog import AlgorithmDialog
project = QgsProject.instance()
layers = {"frame 0182": f"{data}/ngi/frames/3324c_2015_1004_05_0182_RGB.tif",
          "orthophoto": f"{data}/ngi/ortho/ngi_rgb_byte_1.tif", "dem": f"{data}/ngi/dem.tif"}
res = {}
# as users have them: the DEM added last (on top of the layer tree); the raw frame added last
for order in (("frame 0182", "orthophoto", "dem"), ("orthophoto", "dem", "frame 0182")):
    project.removeAllMapLayers()
    for name in order:
        project.addMapLayer(QgsRasterLayer(layers[name], name))
    for alg_id, names in (("fotogeo:register", ("REFERENCE", "TARGET", "DEM")), ("fotogeo:coreg", ("REFERENCE", "TARGET"))):
        alg = QgsApplication.processingRegistry().algorithmById(alg_id)
        panel = AlgorithmDialog(alg.create(), False, None).mainWidget()
        values = {}
        for n in names:
            w = panel.wrappers[n]
            v = w.parameterValue() if hasattr(w, "parameterValue") else w.value()
            layer = project.mapLayer(v) if isinstance(v, str) else v
            values[n] = layer.name() if layer is not None else None
        res[f"{alg_id} {order[-1]}"] = values
print("RESULT " + json.dumps(res))
sys.stdout.flush()
os._exit(0)
'''


def test_dialogs_prefill_layers_by_their_role(tmp_path, data_dir):
    """A DEM on top of the layer tree, or the raw frame: register's Reference starts on the orthophoto (never the DEM,
    never an image without georeference), Target on the frame, its DEM input on the DEM; co-register's Reference and
    Target on two different images, the reference the georeferenced one."""
    need_qgis()
    script = tmp_path / "defaults.py"
    script.write_text(DEFAULTS_SCRIPT)
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", HOME=str(tmp_path / "home"), GDAL_PAM_ENABLED="NO")
    r = subprocess.run([sys.executable, str(script), str(ROOT), str(data_dir)], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=HANG_GUARD_S)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"dialog script failed (rc {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    res = json.loads(lines[-1][7:])
    for last in ("dem", "frame 0182"):
        reg, coreg = res[f"fotogeo:register {last}"], res[f"fotogeo:coreg {last}"]
        assert reg == {"REFERENCE": "orthophoto", "TARGET": "frame 0182", "DEM": "dem"}, (last, reg)
        assert coreg == {"REFERENCE": "orthophoto", "TARGET": "frame 0182"}, (last, coreg)
