"""The DSM's ``<name>.qml`` in QGIS: the algorithms offer "Write a QGIS style (.qml) beside the DSM" from the one
option table, and a style the user saved with "Save as Default" — QGIS writes it to that very file, without
fotogeo's marker — is kept by the next run of fotogeo:dsm (the plugin always passes overwrite for the DSM QGIS asked
about), said in the log, and the DSM loads with it instead of the plugin's ramp."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingParameterBoolean  # noqa: E402

LABEL = "Write a QGIS style (.qml) beside the DSM"


def test_the_algorithms_offer_the_style_switch(qgis_app):
    from qgis.core import QgsApplication
    for alg in ("fotogeo:dsm", "fotogeo:triangulate"):
        p = QgsApplication.processingRegistry().algorithmById(alg).parameterDefinition("QGIS_STYLE")
        assert isinstance(p, QgsProcessingParameterBoolean), alg
        assert p.defaultValue() is True and p.description() == LABEL, alg


def test_a_style_saved_as_default_in_qgis_is_kept_by_the_next_run(qgis_app, tmp_path):
    import processing
    from qgis.core import QgsRasterLayer
    from rendered_pair import render
    from test_qgis_dsm_fill import Feedback

    from fotogeo.io.qml import MARKER, users_style
    from fotogeo.tools.dsm import dsm
    (tmp_path / "pair").mkdir()
    pair = render(tmp_path / "pair", 256)
    out, style = tmp_path / "dsm.tif", tmp_path / "dsm.qml"
    dsm(pair["images"], out, camera=pair["camera"], eo=pair["eo"], crs="EPSG:32635")
    assert MARKER in style.read_text() and users_style(out) is None
    layer = QgsRasterLayer(str(out), "dsm")
    assert layer.renderer().type() == "singlebandpseudocolor"  # fotogeo's style, loaded as the default
    layer.renderer().setOpacity(0.5)  # the user's own touch
    message, ok = layer.saveDefaultStyle()
    assert ok, message
    saved = style.read_text()
    assert MARKER not in saved and users_style(out) == style  # QGIS writes the layer's style, not the file it read
    fb = Feedback()
    processing.run("fotogeo:dsm", {"IMAGES": [str(p) for p in pair["images"]], "CAMERA": str(pair["camera"]),
                                   "EO": str(pair["eo"]), "CRS": "EPSG:32635", "OUTPUT": str(out)}, feedback=fb)
    assert style.read_text() == saved
    assert [w for w in fb.warnings if w.startswith("kept the QGIS style")] == [
        f"kept the QGIS style {str(style)!r}: fotogeo did not write it (a style of yours?); delete it to have "
        f"fotogeo's written, or untick “{LABEL}” to say so"], fb.warnings
    from processing_provider.postprocess import dsm_look
    assert dsm_look(str(out)) is None  # the layer keeps the style QGIS loads with it
    style.unlink()
    processing.run("fotogeo:dsm", {"IMAGES": [str(p) for p in pair["images"]], "CAMERA": str(pair["camera"]),
                                   "EO": str(pair["eo"]), "CRS": "EPSG:32635", "QGIS_STYLE": False,
                                   "OUTPUT": str(out)})
    assert not style.exists() and dsm_look(str(out)) == "dsm"
