"""A numbers-only resection: `fotogeo orient GCPS --camera C.yaml` (no image raster) — the GCPs' pixel positions
and the camera, whose image size is the image's. Checked on the NGI frame's true geometry: the same fit as with the
raster, and the outputs that need the raster refused by name."""
import json

import numpy as np
import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.io.camera import load_ngi_frame
from fotogeo.io.raster import read_dem
from fotogeo.orientation.simulation import make_gcps
from test_bad_input import assert_one_line_error
from test_orient import NAME, _write


@pytest.fixture(scope="module")
def gcps(data_dir, tmp_path_factory):
    d = tmp_path_factory.mktemp("numbers")
    ngi = data_dir / "ngi"
    frame, dem = load_ngi_frame(ngi, NAME), read_dem(ngi / "dem.tif")
    s = make_gcps(frame, dem, 12, 8, "homogeneous", noise=0.5, seed=11)  # another draw than test_orient's
    _write(d / "gcps.gpkg", np.vstack([s.gcp_ground, s.check_ground]), np.vstack([s.gcp_pixel, s.check_pixel]),
           ["control"] * 12 + ["check"] * 8, dem.crs.to_wkt())
    return d / "gcps.gpkg", ngi


def test_resection_without_the_raster_equals_the_one_with_it(gcps, tmp_path):
    path, ngi = gcps
    camera = str(ngi / "interior_orientation.yaml")
    reports = {}
    for name, args in (("numbers", [str(path)]), ("raster", [str(ngi / "frames" / f"{NAME}_RGB.tif"), str(path)])):
        out = tmp_path / f"{name}.json"
        result = CliRunner().invoke(main, ["orient", *args, "--camera", camera, "--model", "collinearity",
                                           "--report", str(out), "--vectors", str(tmp_path / f"{name}.gpkg"), "-q"])
        assert result.exit_code == 0, result.output
        reports[name] = json.loads(out.read_text())
    a, b = reports["numbers"], reports["raster"]
    assert a["image"] is None and a["check"]["n"] == 8
    assert a["check"]["rms_xy_px"] == pytest.approx(b["check"]["rms_xy_px"], abs=1e-6)
    assert a["check"]["rms_xy_px"] < 1.0  # 0.5 px noise


@pytest.mark.parametrize("args,expected", [
    ([], "--camera for a numbers-only resection"),
    (["--camera", "CAM", "--plot", "p.png"], "--plot needs the image raster"),
    (["--camera", "CAM", "--rectify", "r.tif", "--model", "collinearity"], "--rectify needs the image raster"),
])
def test_what_needs_the_raster_is_refused_by_name(gcps, tmp_path, args, expected):
    path, ngi = gcps
    args = [str(ngi / "interior_orientation.yaml") if a == "CAM" else str(tmp_path / a) if "." in a else a
            for a in args]
    result = CliRunner().invoke(main, ["orient", str(path), *args, "-q"])
    assert_one_line_error(result, expected)
    assert not list(tmp_path.iterdir())
