"""fotogeo:triangulate in QGIS names the interior parameters it held fixed on one line, as the console does."""
from __future__ import annotations

import warnings

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from fotogeo.options.shared import SELF_CALIBRATION  # noqa: E402
from fotogeo.orientation.block_simulation import simulate_block  # noqa: E402
from test_qgis_provider import Recorder  # noqa: E402
from test_triangulate import CAMERA, write_block  # noqa: E402


class Warnings(Recorder):
    def __init__(self):
        super().__init__()
        self.warnings = []

    def pushWarning(self, warning):
        self.warnings.append(warning)
        super().pushWarning(warning)


def test_the_parameters_held_fixed_are_one_warning_line(qgis_app, tmp_path):
    """A flat 2 x 5 block (relief 1 m) with f, ppx, ppy and k1 asked for: the focal length and the principal point
    cannot be told from the flying heights and the attitudes — held fixed, named in one warning, the reasons in
    full left to the report."""
    import processing
    sb = simulate_block(seed=4, strips=2, frames_per_strip=5, camera=CAMERA, relief=1.0, attitude_sd=0.3,
                        point_spacing=50.0, margin=3.0, n_check=4)
    frames, checks = write_block(tmp_path, sb)
    params = {"FRAMES": [str(f) for f in frames], "CAMERA": str(tmp_path / "camera.yaml"),
              "EO": str(tmp_path / "eo.txt"), "OBSERVATIONS": str(tmp_path / "tie.csv"),
              "GCPS": str(tmp_path / "gcp_list.txt"), "CHECK_POINTS": checks, "IMAGE_SIGMA": 0.3,
              "SELF_CALIBRATION": [SELF_CALIBRATION.index(n) for n in ("f", "ppx", "ppy", "k1")],
              "OUTDIR": str(tmp_path / "out")}
    feedback = Warnings()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        processing.run("fotogeo:triangulate", params, feedback=feedback)
    held = [w for w in feedback.warnings if "held fixed" in w]
    assert len(held) == 1, feedback.warnings
    assert held[0].startswith("held fixed (report.html says why): f (correlation "), held
    assert all(f"{p} (correlation" in held[0] for p in ("f", "ppx", "ppy")), held
    assert "cannot be told from the exterior orientation" not in held[0]  # the full reason is the report's
