"""No GDAL side file beside an input when fotogeo's algorithms read it in QGIS (processing_provider.side_files).

Here in the tests' own QGIS process with GDAL's PAM turned on (qgis_env turns it off for the session); the real
``qgis_process`` program is tested in test_qgis_real_programs (every run there checks its inputs).
"""
from __future__ import annotations

import gc

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from osgeo import gdal  # noqa: E402
from qgis.core import QgsProcessingContext, QgsProject, QgsRasterLayer  # noqa: E402

from processing_provider.runtime import worker_environment  # noqa: E402
from processing_provider.side_files import no_side_files, runs_fotogeo  # noqa: E402


@pytest.fixture
def pam_on():
    """GDAL's PAM on in this process (a user's default) for one test."""
    before = gdal.GetConfigOption("GDAL_PAM_ENABLED")
    gdal.SetConfigOption("GDAL_PAM_ENABLED", "YES")
    yield
    gdal.SetConfigOption("GDAL_PAM_ENABLED", before)


def _scene(folder):
    from fotogeo.tools.demo.tool import make_scene
    make_scene(folder, seed=3, size=120, pixel=20.0)
    return folder / "reference.tif", folder / "target.tif"


def test_runs_fotogeo_recognises_qgis_process_command_lines():
    assert runs_fotogeo(["/usr/bin/qgis_process.bin", "--json", "run", "fotogeo:register", "--", "A=run"])
    assert runs_fotogeo([r"C:\OSGeo4W\bin\qgis_process-qgis.exe", "run", "fotogeo:ortho"])
    assert not runs_fotogeo(["/usr/bin/qgis_process.bin", "run", "native:buffer", "--", "INPUT=fotogeo:x"])
    assert not runs_fotogeo(["/usr/bin/qgis_process.bin", "list"])
    assert not runs_fotogeo(["/usr/bin/qgis.bin", "--code", "run", "fotogeo:register"])
    assert not runs_fotogeo([])


def test_the_worker_runs_without_pam():
    assert worker_environment({"GDAL_PAM_ENABLED": "YES", "HOME": "/h"})["GDAL_PAM_ENABLED"] == "NO"


def test_a_layer_loaded_without_side_files_leaves_none(qgis_app, pam_on, tmp_path):
    """The control first: a raster layer loaded with PAM on leaves ``.aux.xml`` (its statistics) when it
    closes; loaded inside :func:`no_side_files`, none, though PAM is on again before it closes."""
    reference, target = _scene(tmp_path)
    layer = QgsRasterLayer(str(reference), "r", "gdal")
    assert layer.isValid()
    del layer
    gc.collect()
    assert (tmp_path / "reference.tif.aux.xml").is_file()
    with no_side_files():
        layer = QgsRasterLayer(str(target), "t", "gdal")
    assert layer.isValid() and gdal.GetConfigOption("GDAL_PAM_ENABLED") == "YES"
    del layer
    gc.collect()
    assert not (tmp_path / "target.tif.aux.xml").exists()


def test_multiple_layer_inputs_leave_nothing_beside_them(qgis_app, pam_on, tmp_path):
    """processing.run with PAM on: file paths, and file paths mixed with a project layer (which makes
    Processing load the paths as layers), leave the input folder as it was."""
    import processing
    import test_mosaic as tm
    folder = tmp_path / "in"
    folder.mkdir()
    a = tm._ortho(folder / "a.tif", 0, 300, 150, box_value=240)
    b = tm._ortho(folder / "b.tif", 180, 480, 330, tm.GAIN, tm.OFFSET, box_value=30)
    names = sorted(p.name for p in folder.iterdir())
    context = QgsProcessingContext()
    context.setProject(QgsProject.instance())
    processing.run("fotogeo:mosaic", {"ORTHOS": [str(a), str(b)], "OUTPUT": str(tmp_path / "m1.tif")},
                   context=context)
    with no_side_files():  # a project layer (its own side file would be QGIS's, not the algorithm's)
        layer = QgsRasterLayer(str(a), "a", "gdal")
    QgsProject.instance().addMapLayer(layer)
    try:
        processing.run("fotogeo:mosaic", {"ORTHOS": [layer.id(), str(b)], "OUTPUT": str(tmp_path / "m2.tif")},
                       context=context)
    finally:
        QgsProject.instance().removeMapLayer(layer.id())
    del context
    gc.collect()
    assert (tmp_path / "m1.tif").is_file() and (tmp_path / "m2.tif").is_file()
    assert sorted(p.name for p in folder.iterdir()) == names
