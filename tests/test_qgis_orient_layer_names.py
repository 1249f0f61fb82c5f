"""orient's layers are named after the image oriented, also when its GeoPackage is a temporary output (the dialog's
default): "<image> dlt GCPs", not "VECTORS dlt GCPs"."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from test_qgis_orient import NAME, ORIENT_CHOICES, base, gcps, run  # noqa: E402,F401 - gcps: a fixture


def test_temporary_outputs_are_named_after_the_image(gcps):  # noqa: F811
    from qgis.core import QgsProcessing, QgsProcessingContext, QgsProcessingOutputLayerDefinition, QgsProject
    context = QgsProcessingContext()
    context.setProject(QgsProject.instance())
    temporary = QgsProcessingOutputLayerDefinition(QgsProcessing.TEMPORARY_OUTPUT, QgsProject.instance())
    run("orient", base(gcps, MODEL=ORIENT_CHOICES.index("dlt"), VECTORS=temporary), context=context)
    names = sorted(context.layerToLoadOnCompletionDetails(uri).name for uri in context.layersToLoadOnCompletion())
    assert names == [f"{NAME}_RGB dlt GCPs", f"{NAME}_RGB dlt error vectors"], names
