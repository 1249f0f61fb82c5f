"""The triangulate algorithm's --dsm in QGIS: an optional raster destination, unset by default (no DSM made), the
path the user picks when set."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingContext, QgsProcessingParameterRasterDestination  # noqa: E402


def test_the_dsm_of_triangulate_is_an_optional_raster_destination(qgis_app, tmp_path):
    from qgis.core import QgsApplication

    from fotogeo.options import TRIANGULATE
    tri = QgsApplication.processingRegistry().algorithmById("fotogeo:triangulate")
    p = tri.parameterDefinition("DSM")
    assert isinstance(p, QgsProcessingParameterRasterDestination) and not p.createByDefault()
    assert tri.outputDefinition("DSM") is not None
    context = QgsProcessingContext()
    assert tri.option_value({}, TRIANGULATE["dsm"], context) is None
    assert tri.option_value({"DSM": None}, TRIANGULATE["dsm"], context) is None
    path = str(tmp_path / "dsm.tif")
    assert tri.option_value({"DSM": path}, TRIANGULATE["dsm"], context) == path
