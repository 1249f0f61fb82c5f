"""fotogeo:coreg in QGIS refuses a window larger than the overlap up front, naming the dialog's label."""
from __future__ import annotations

import pytest
from coreg_patch import patch_pair
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingException  # noqa: E402

from fotogeo.options.coreg import COREG  # noqa: E402


def test_window_larger_than_the_overlap_names_the_dialog_label(qgis_app, data_dir, tmp_path):  # noqa: F811
    import processing
    from test_qgis_provider import Recorder
    reference, target = patch_pair(data_dir, tmp_path)
    with pytest.raises(QgsProcessingException) as e:
        processing.run("fotogeo:coreg", {"REFERENCE": str(reference), "TARGET": str(target), "WINDOW": 512,
                                         "OUTPUT": str(tmp_path / "out.tif")}, feedback=Recorder())
    text = str(e.value)
    assert f"“{COREG['window'].label}” 512 is larger than the overlap" in text and "use 448 or less" in text, text
    assert "--window" not in text and "\n" not in text.strip()
    assert not (tmp_path / "out.tif").exists()
