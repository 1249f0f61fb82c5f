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


def test_rectify_defaults_the_maps_horizontal_crs_and_a_round_pixel_size(no_last_folder, tmp_path, data_dir):
    import rasterio
    with rasterio.open(data_dir / "ngi" / "dem.tif") as ds:  # "Lo25 WGS84 + EGM2008 height": a compound CRS
        compound = QgsCoordinateReferenceSystem.fromWkt(ds.crs.to_wkt(version="WKT2_2019"))
    assert compound.toWkt(QgsCoordinateReferenceSystem.WKT2_2019).startswith("COMPOUNDCRS")
    dlg = rd.RectifyDialog(None, str(tmp_path / "f1.tif"), compound, resolution=5.7523)
    c = dlg.choices()
    wkt = c["crs"].toWkt(QgsCoordinateReferenceSystem.WKT2_2019)
    assert wkt.startswith("PROJCRS") and "VERTCRS" not in wkt and "+lon_0=25" in c["crs"].toProj()
    assert c["resolution"] == 6.0
    dlg.crs.setCrs(QgsCoordinateReferenceSystem("EPSG:4326"))  # degrees: the metre pixel size no longer applies
    assert dlg.choices()["resolution"] is None


def test_ground_resolution_of_a_fit_grid():
    # 10 px per grid step, the ground 5.75 m per pixel along both axes, rotated 30°
    import math
    a = math.radians(30)
    cols, rows = [0, 10, 20], [0, 10]
    x = [[5.75 * (c * math.cos(a) - r * math.sin(a)) for c in cols] for r in rows]
    y = [[5.75 * (c * math.sin(a) + r * math.cos(a)) for c in cols] for r in rows]
    assert abs(rd.ground_resolution({"forward": {"cols": cols, "rows": rows, "x": x, "y": y}}) - 5.75) < 1e-9
    assert rd.ground_resolution({}) is None
