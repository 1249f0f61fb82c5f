"""The DSM algorithm in QGIS offers --fill-max-distance from the one option table: a number in cells, default 4,
within (0, 64]. QGIS keeps every parameter's last-used value, so a reach other than the default while "Fill holes"
is off is not a choice made for this run: it is not used, and the log says so naming both labels and the fix (the
command line, where a flag is given on purpose, refuses it: check_needs)."""
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
    # without "Fill holes": whatever the dialog holds is not given to the tool
    assert alg.option_value({}, DSM["fill_max_distance"], context) is None
    assert alg.option_value({"FILL_MAX_DISTANCE": 2.5}, DSM["fill_max_distance"], context) is None


class Feedback:
    """QgsProcessingFeedback keeping the warnings pushed."""

    def __new__(cls):
        from qgis.core import QgsProcessingFeedback

        class Keeping(QgsProcessingFeedback):
            def __init__(self):
                super().__init__()
                self.warnings = []

            def pushWarning(self, text):  # noqa: N802 - QGIS API
                self.warnings.append(text)
                super().pushWarning(text)
        return Keeping()


@pytest.mark.parametrize("reach,noted", [(8.0, True), (4.0, False)])
def test_a_last_used_reach_without_fill_is_not_used_and_said_so(qgis_app, tmp_path, reach, noted):
    """Through the provider (processing.run): "Fill holes" off, the reach QGIS kept from an earlier run (8) is not
    given to the tool — the run goes on to the tool's own refusal of these images (unoriented), not to "acts only
    with fill" — and the log names both labels and the fix; the default reach says nothing."""
    import numpy as np
    import processing
    import rasterio
    from qgis.core import QgsProcessingException
    images = []
    for k in range(2):
        images.append(str(tmp_path / f"i{k}.tif"))
        with rasterio.open(images[-1], "w", driver="GTiff", width=64, height=48, count=1, dtype="uint8",
                           crs="EPSG:32633", transform=rasterio.transform.from_origin(5e5, 5e6, 1, 1)) as d:
            d.write(np.full((1, 48, 64), 90 + k, np.uint8))
    fb = Feedback()
    with pytest.raises(QgsProcessingException) as e:
        processing.run("fotogeo:dsm", {"IMAGES": images, "FILL": False, "FILL_MAX_DISTANCE": reach,
                                       "OUTPUT": str(tmp_path / "dsm.tif")}, feedback=fb)
    assert "acts only with" not in str(e.value) and "Fill at most" not in str(e.value), str(e.value)
    said = [w for w in fb.warnings if "is not used" in w]
    if noted:
        assert said == ["“Fill at most this many cells from a matched height” 8 is not used: it acts only with “Fill "
                        "holes (interpolated cells are marked in a mask band)”, which is off; tick “Fill holes "
                        "(interpolated cells are marked in a mask band)” to use it (left as it is, the last value used "
                        "stays in the dialog)"], fb.warnings
    else:
        assert not said, fb.warnings


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
