"""``fotogeo:dsm`` in QGIS: with a report asked (REPORT) a refused run writes it as the command line does
(:mod:`fotogeo.tools.dsm.refusal`), ``"status": "refused"`` with the error and the pairs tried, and no DSM; the
style an earlier fotogeo wrote beside the DSM, without its marker, is replaced as fotogeo's own (issue 30)."""
from __future__ import annotations

import json

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()


def test_a_refused_dsm_writes_the_report_asked(qgis_app, tmp_path):
    import processing
    from qgis.core import QgsProcessingException

    from dsm_scenes import make_scene
    sc = make_scene("nadir", tmp_path / "scene")
    rep, out = tmp_path / "r.json", tmp_path / "dsm.tif"
    with pytest.raises(QgsProcessingException, match="no stereo pair among the images"):
        processing.run("fotogeo:dsm", {"IMAGES": [str(sc["images"][0]), str(sc["images"][5])],
                                       "CAMERA": str(sc["camera"]), "EO": str(sc["eo"]), "CRS": sc["crs"],
                                       "OUTPUT": str(out), "REPORT": str(rep)})
    got = json.loads(rep.read_text())
    assert got["status"] == "refused" and "no stereo pair" in got["error"] and not out.exists()
    assert got["pairs"][0]["images"] == ["s1_01", "s2_02"] and "overlap 8 % below 20 %" in got["pairs"][0]["reason"]


def test_fotogeos_earlier_unmarked_style_is_replaced_in_qgis(qgis_app, tmp_path):
    """The style an earlier fotogeo wrote (no marker) was kept by every later run in QGIS as "a style of yours",
    the DSM drawn with the old run's range; recognised by its content, it is replaced by the run's own."""
    import processing
    from dsm_scenes import make_scene
    from test_dsm_words import _earlier_style
    from test_qgis_dsm_fill import Feedback

    from fotogeo.io.qml import MARKER
    sc = make_scene("nadir", tmp_path / "scene")
    out, style = tmp_path / "dsm.tif", tmp_path / "dsm.qml"
    style.write_text(_earlier_style(101.25, 187.5))
    fb = Feedback()
    processing.run("fotogeo:dsm", {"IMAGES": [str(p) for p in sc["images"][:2]], "CAMERA": str(sc["camera"]),
                                   "EO": str(sc["eo"]), "CRS": sc["crs"], "OUTPUT": str(out)}, feedback=fb)
    assert MARKER in style.read_text() and not [w for w in fb.warnings if "kept the QGIS style" in w], fb.warnings


def test_a_geographic_crs_refused_in_qgis_writes_the_report_naming_the_option(qgis_app, tmp_path):
    """A refusal of the inputs' first checks (here a geographic CRS) came before the report's context: no report.
    Now written, in the one refusal format (:mod:`fotogeo.tools.common.refusal`), its option ``crs`` named."""
    import processing
    from qgis.core import QgsProcessingException

    from dsm_scenes import make_scene
    sc = make_scene("nadir", tmp_path / "scene")
    rep, out = tmp_path / "r.json", tmp_path / "dsm.tif"
    with pytest.raises(QgsProcessingException, match="geographic"):
        processing.run("fotogeo:dsm", {"IMAGES": [str(p) for p in sc["images"][:2]], "CAMERA": str(sc["camera"]),
                                       "EO": str(sc["eo"]), "CRS": "EPSG:4326", "OUTPUT": str(out),
                                       "REPORT": str(rep)})
    got = json.loads(rep.read_text())
    assert got["status"] == "refused" and got["option"] == "crs" and got["refused"] == got["error"]
    assert "geographic" in got["error"] and not out.exists()
