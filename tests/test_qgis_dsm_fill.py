"""The DSM algorithm in QGIS offers --fill-max-distance from the one option table: a number in cells, default 4,
within (0, 64]."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingContext, QgsProcessingParameterNumber  # noqa: E402


def test_the_dsm_algorithm_takes_the_fill_reach(qgis_app):
    from qgis.core import QgsApplication

    from fotogeo.options import DSM
    alg = QgsApplication.processingRegistry().algorithmById("fotogeo:dsm")
    p = alg.parameterDefinition("FILL_MAX_DISTANCE")
    assert isinstance(p, QgsProcessingParameterNumber)
    assert p.defaultValue() == 4.0 and p.maximum() == 64.0
    context = QgsProcessingContext()
    assert alg.option_value({}, DSM["fill_max_distance"], context) == 4.0
    assert alg.option_value({"FILL_MAX_DISTANCE": 2.5}, DSM["fill_max_distance"], context) == 2.5
