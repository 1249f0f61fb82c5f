"""The plugin zip: its layout, and installing + loading it in a fresh QGIS profile through qgis.utils.

Loading runs in a fresh Python process (a second QgsApplication cannot be made in this one,
and the provider id would clash with the one the other QGIS tests register).
"""
from __future__ import annotations

import configparser
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from qgis_env import need_qgis

#: every algorithm of the provider, sorted
ALGORITHM_IDS = ["fotogeo:comparemodels", "fotogeo:coreg", "fotogeo:demo", "fotogeo:dsm", "fotogeo:interior", "fotogeo:layertopoints",
                 "fotogeo:matchfeatures", "fotogeo:measuretargets", "fotogeo:mosaic", "fotogeo:orient", "fotogeo:ortho",
                 "fotogeo:pcafusion", "fotogeo:pointstolayer", "fotogeo:register", "fotogeo:registerbatch",
                 "fotogeo:rpcbias", "fotogeo:transferpoints", "fotogeo:triangulate"]

ROOT = Path(__file__).resolve().parents[1]

LOADER = r'''
import json, os, sys
plugins_dir, block, src, out = sys.argv[1:5]
if block:
    import importlib.abc
    class Block(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name == block or name.startswith(block + "."):
                raise ImportError(f"No module named {name!r} (blocked by the test)")
    sys.meta_path.insert(0, Block())
sys.path.append("/usr/share/qgis/python/plugins")
from qgis.core import QgsApplication
app = QgsApplication([], False)
app.initQgis()
from processing.core.Processing import Processing
Processing.initialize()
import qgis.utils
sys.path.insert(0, plugins_dir)       # what QGIS does for each plugin folder of the profile
qgis.utils.plugin_paths = [plugins_dir]
qgis.utils.updateAvailablePlugins()
res = {"available": list(qgis.utils.available_plugins),
       "has_provider": qgis.utils.pluginMetadata("fotogeo_qgis", "hasProcessingProvider"),
       "loaded": qgis.utils.loadPlugin("fotogeo_qgis"),
       "started": qgis.utils.startPlugin("fotogeo_qgis")}
reg = QgsApplication.processingRegistry()
prov = reg.providerById("fotogeo")
res["algorithms"] = sorted(a.id() for a in prov.algorithms()) if prov else None
res["help_mentions_missing"] = "Not runnable yet" in reg.algorithmById("fotogeo:register").shortHelpString()
import processing
try:
    r = processing.run("fotogeo:pcafusion", {"INPUT": src, "OUTPUT": out})
    res["run"] = {"explained": r["EXPLAINED"], "output_exists": os.path.exists(r["OUTPUT"])}
except Exception as e:
    res["error"] = str(e)
res["fotogeo_file"] = getattr(sys.modules.get("fotogeo"), "__file__", None)
res["unloaded"] = qgis.utils.unloadPlugin("fotogeo_qgis")
res["provider_after_unload"] = reg.providerById("fotogeo") is not None
res["fotogeo_after_unload"] = "fotogeo" in sys.modules
print("RESULT " + json.dumps(res))
sys.stdout.flush()
os._exit(0)  # exitQgis can segfault with Processing loaded
'''


@pytest.fixture(scope="module")
def plugin_zip(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("dist") / "fotogeo_qgis.zip"
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_plugin.py"), "--output", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return out


def test_zip_layout(plugin_zip, tmp_path):
    import fotogeo
    with zipfile.ZipFile(plugin_zip) as z:
        names = z.namelist()
        meta_text = z.read("fotogeo_qgis/metadata.txt").decode()
    assert {n.split("/")[0] for n in names} == {"fotogeo_qgis"}
    assert "fotogeo_qgis/__init__.py" in names
    assert {"fotogeo_qgis/processing_provider/styles/tie_points.qml",
            "fotogeo_qgis/processing_provider/styles/error_vectors.qml",
            "fotogeo_qgis/processing_provider/provider.py"} <= set(names)
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc") or "/fotogeo/cli/" in n]
    # every module of the fotogeo package (but its command line) is vendored
    expected = {f"fotogeo_qgis/fotogeo/{p.relative_to(ROOT / 'fotogeo').as_posix()}"
                for p in (ROOT / "fotogeo").rglob("*.py") if "__pycache__" not in p.parts and p.parts[-2] != "cli"
                and "cli" not in p.relative_to(ROOT / "fotogeo").parts}
    assert expected <= set(names)
    cp = configparser.ConfigParser()
    cp.read_string(meta_text)
    g = cp["general"]
    assert g["qgisMinimumVersion"] == "3.22" and g["hasProcessingProvider"] == "yes"
    assert g["version"] == fotogeo.__version__
    assert f"fotogeo_qgis/{g['icon']}" in names
    for key in ("name", "description", "about", "author", "license"):
        assert g[key].strip(), key
    assert "example.org" not in meta_text and "fotogeo_qgis/LICENSE" in names
    assert "GNU GENERAL PUBLIC LICENSE" in z_text(plugin_zip, "fotogeo_qgis/LICENSE") and g["license"] == "GPL-3.0-or-later"
    assert "fotogeo_qgis/fotogeo/worker.py" in names and "fotogeo_qgis/processing_provider/runtime-requirements.txt" in names
    # the same sources give the same bytes
    again = tmp_path / "again.zip"
    subprocess.run([sys.executable, str(ROOT / "scripts" / "build_plugin.py"), "--output", str(again)],
                   check=True, capture_output=True, timeout=120)
    assert again.read_bytes() == plugin_zip.read_bytes()


def z_text(zip_path, name) -> str:
    with zipfile.ZipFile(zip_path) as z:
        return z.read(name).decode()


def _install_and_load(plugin_zip, tmp_path, data_dir, block="", runtime=None):
    need_qgis()
    profile = tmp_path / "profile" / "python" / "plugins"
    profile.mkdir(parents=True)
    with zipfile.ZipFile(plugin_zip) as z:
        z.extractall(profile)
    script = tmp_path / "load_plugin.py"
    script.write_text(LOADER)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONSTARTUP", "FOTOGEO_PYTHON")}
    if runtime is None:
        env["FOTOGEO_PYTHON"] = sys.executable  # this venv serves as the plugin's runtime
    else:
        env["FOTOGEO_RUNTIME"] = str(runtime)
    env["QT_QPA_PLATFORM"] = "offscreen"
    env["HOME"] = str(tmp_path / "home")  # a fresh QGIS settings folder
    out = tmp_path / "pc1.tif"
    src = data_dir / "landsat_rgb" / "RGB.byte.tif"
    r = subprocess.run([sys.executable, str(script), str(profile), block, str(src), str(out)], cwd=tmp_path,
                       env=env, capture_output=True, text=True, timeout=180)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"loader failed (rc {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return json.loads(lines[-1][7:]), profile, out


@pytest.mark.qgis
def test_zip_installs_and_loads_in_fresh_profile(plugin_zip, tmp_path, data_dir):
    res, profile, out = _install_and_load(plugin_zip, tmp_path, data_dir)
    assert "fotogeo_qgis" in res["available"] and res["has_provider"] == "yes"
    assert res["loaded"] and res["started"], res
    assert res["algorithms"] == ALGORITHM_IDS
    assert not res["help_mentions_missing"]
    assert "error" not in res, res.get("error")
    assert res["run"]["output_exists"] and 0.5 < res["run"]["explained"] <= 1
    # QGIS imported the vendored fotogeo (its option table) from the installed plugin, not the repository's
    assert res["fotogeo_file"].startswith(str(profile / "fotogeo_qgis" / "fotogeo"))
    assert res["unloaded"] and not res["provider_after_unload"] and not res["fotogeo_after_unload"]


@pytest.mark.qgis
def test_plugin_loads_without_its_runtime_and_says_what_is_missing(plugin_zip, tmp_path, data_dir):
    """No runtime and no rasterio in QGIS's Python: the plugin loads, the algorithms name the fix."""
    res, _, out = _install_and_load(plugin_zip, tmp_path, data_dir, block="rasterio", runtime=tmp_path / "none")
    assert res["loaded"] and res["started"] and res["algorithms"] == ALGORITHM_IDS, res
    assert res["help_mentions_missing"]
    assert "run" not in res
    assert "none is not installed" in res["error"] and "Install / repair runtime" in res["error"], res["error"]
    assert not out.exists()
