"""QGIS names the options a refusal is about by their labels, as the command line names them by their flags: an
option the bundle's datum refusal is about (the centres' σ) and the CRS option of a reader shared by
several tools (ortho's is "dst_crs", shown as its "--crs")."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()


def _algorithm(name):
    from qgis.core import QgsApplication
    return QgsApplication.processingRegistry().createAlgorithmById(f"fotogeo:{name}")


def test_the_datum_refusal_names_the_prior_parameters(qgis_app):
    from fotogeo.options import TRIANGULATE
    said = _algorithm("triangulate").in_words("or priors on the approximate projection centres (eo_sigma_position, "
                                              "e.g. GNSS/INS centres)", "eo_sigma_position")
    assert f"(“{TRIANGULATE['eo_sigma_position'].label}”, e.g." in said, said


def test_ortho_names_its_crs_parameter_for_a_file_far_from_the_images_gps(qgis_app):
    from fotogeo.options import ORTHO
    said = _algorithm("ortho").in_words("or for other images — check the CRS it is read in (crs)", "crs")
    assert f"(“{ORTHO['dst_crs'].label}”)" in said, said
