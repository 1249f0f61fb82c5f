"""The DSM algorithm in QGIS offers --fill-max-distance from the one option table: a number in cells, default 4,
within (0, 64]; a reach changed while "Fill holes" is off is refused naming both labels (it was ignored)."""
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
    assert alg.option_value({"FILL": True}, DSM["fill_max_distance"], context) == 4.0
    assert alg.option_value({"FILL": True, "FILL_MAX_DISTANCE": 2.5}, DSM["fill_max_distance"], context) == 2.5
    # without "Fill holes": the default the dialog holds is no value given; another one goes to the tool, refused
    assert alg.option_value({}, DSM["fill_max_distance"], context) is None
    assert alg.option_value({"FILL_MAX_DISTANCE": 2.5}, DSM["fill_max_distance"], context) == 2.5


def test_a_reach_without_fill_is_refused_in_the_labels(qgis_app):
    from qgis.core import QgsApplication

    from fotogeo.errors import InputError
    from fotogeo.options import DSM, check_needs
    from processing_provider.runner import _in_callers_words
    alg = QgsApplication.processingRegistry().algorithmById("fotogeo:dsm")
    with pytest.raises(InputError) as e:
        check_needs({"fill_max_distance": 2.5, "fill": False}, DSM.values())
    error = {"message": str(e.value), "option": e.value.option, "also": list(e.value.also)}  # as the worker sends it
    assert _in_callers_words(error, alg.in_words) == (
        "“Fill at most this many cells from a matched height” 2.5 acts only with “Fill holes (interpolated cells are "
        "marked in a mask band)” (alone it would be ignored): give both, or leave it out")
