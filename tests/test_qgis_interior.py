"""fotogeo:interior in real, headless QGIS: a rendered film scan (known truth) oriented, and a scan with too
few marks refused with the marks named."""
from __future__ import annotations

import json

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingException, QgsProcessingFeedback  # noqa: E402

from film_scans import RMK_LIKE, render_scan, report_yaml  # noqa: E402
from test_interior import write_scan  # noqa: E402


def run(params):
    import processing
    return processing.run("fotogeo:interior", params, feedback=QgsProcessingFeedback())


def test_interior_in_qgis(qgis_app, tmp_path):
    from fotogeo.options.interior import INTERIOR
    scan = render_scan(RMK_LIKE, kind="cross", theta=1.0)
    path = write_scan(tmp_path / "scan.tif", scan)
    (tmp_path / "cal.yaml").write_text(report_yaml(RMK_LIKE, kind="cross"))
    params = {"SCANS": [str(path)], "CAMERA_REPORT": str(tmp_path / "cal.yaml"), "SCAN_PIXEL_UM": 150.0,
              "ROTATION": INTERIOR["rotation"].qgis_choices.index("0"), "OUTDIR": str(tmp_path / "out")}
    res = run(params)
    rec = json.loads((tmp_path / "out" / "scan.json").read_text())
    assert res["SCANS_DONE"] == 1 and res["MAX_RESIDUAL_PX"] <= 0.2 and len(rec["fiducials"]) == 4
    cut = write_scan(tmp_path / "cut.tif", render_scan(RMK_LIKE, kind="cross", missing=("2", "3")))
    with pytest.raises(QgsProcessingException, match=r"2 of 4 fiducial marks found \(1, 4\)"):
        run({**params, "SCANS": [str(cut)], "OUTDIR": str(tmp_path / "out2")})
