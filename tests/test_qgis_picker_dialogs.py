"""The picker's Rectify options and where its file dialogs open (issue 22)."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

need_qgis()

from qgis.core import QgsCoordinateReferenceSystem, QgsSettings  # noqa: E402

from processing_provider.picker import rectify_dialog as rd  # noqa: E402


@pytest.fixture
def no_last_folder(qgis_app):  # noqa: F811
    saved = QgsSettings().value(rd.LAST_FOLDER, "", type=str)
    QgsSettings().remove(rd.LAST_FOLDER)
    yield
    QgsSettings().setValue(rd.LAST_FOLDER, saved)


def test_file_dialogs_start_beside_the_image_then_in_the_last_folder(no_last_folder, tmp_path):
    image = tmp_path / "frames" / "f1.tif"
    image.parent.mkdir()
    assert rd.start_folder(str(image)) == str(image.parent)  # not the home folder
    assert rd.suggested(str(image), "_rectified.tif") == str(image.parent / "f1_rectified.tif")
    (tmp_path / "out").mkdir()
    rd.remember(str(tmp_path / "out" / "a.points"))
    assert rd.start_folder(str(image)) == str(tmp_path / "out")


def test_rectify_dialog_offers_resampling_resolution_and_crs(no_last_folder, tmp_path):
    image = tmp_path / "f1.tif"
    dlg = rd.RectifyDialog(None, str(image), QgsCoordinateReferenceSystem("EPSG:32735"))
    c = dlg.choices()
    assert c["path"] == str(tmp_path / "f1_rectified.tif") and c["resolution"] is None  # 0: the image's GSD
    assert c["crs"].authid() == "EPSG:32735" and c["resampling"] == "cubic"
    assert [dlg.resampling.itemText(i) for i in range(dlg.resampling.count())] == ["nearest", "bilinear", "cubic"]
    dlg.resolution.setValue(2.5)
    dlg.crs.setCrs(QgsCoordinateReferenceSystem("EPSG:32734"))
    c = dlg.choices()
    assert c["resolution"] == 2.5 and c["crs"].authid() == "EPSG:32734"
