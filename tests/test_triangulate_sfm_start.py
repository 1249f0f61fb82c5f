"""``triangulate --eo`` reads OpenSfM/ODM, COLMAP and orthority files as well as 'name X Y Z ω φ κ' lines
(issue 20): the same block started from each gives the same adjustment."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fotogeo.errors import FotogeoWarning, InputError
from fotogeo.geometry.approx_block import ApproxCamera, ApproximateBlock, ApproxShot
from fotogeo.io.block import read_gcp_list
from fotogeo.io.camera import read_exterior_orientation
from fotogeo.io.colmap import write_colmap
from fotogeo.io.opensfm import write_opensfm
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.tools.triangulate import triangulate
from test_triangulate import CAMERA, write_block


def _approx(tmp_path, crs):
    eos = read_exterior_orientation(tmp_path / "eo.txt")
    shots = {n: ApproxShot(n, "cam", (e.X, e.Y, e.Z), (e.omega, e.phi, e.kappa)) for n, e in eos.items()}
    return ApproximateBlock({"cam": ApproxCamera(CAMERA)}, shots, crs)


def _run(tmp_path, eo, out, checks, crs=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FotogeoWarning)
        return triangulate(sorted(tmp_path.glob("s*.tif")), tmp_path / "camera.yaml", eo, tmp_path / "tie.csv",
                           tmp_path / out, gcps=tmp_path / "gcp_list.txt", check_points=checks, image_sigma=0.3, crs=crs)


@pytest.fixture(scope="module")
def block_files(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sfm")
    sb = simulate_block(seed=6, strips=2, frames_per_strip=4, camera=CAMERA, point_spacing=50.0, margin=3.0,
                        blunder_fraction=0.0, n_check=6)
    _, checks = write_block(tmp, sb)
    return tmp, checks


@pytest.mark.parametrize("fmt", ["opensfm", "colmap"])
def test_an_sfm_start_gives_the_adjustment_of_the_text_start(block_files, fmt):
    tmp, checks = block_files
    crs = read_gcp_list(tmp / "gcp_list.txt").crs
    from fotogeo.crs import parse_crs
    approx = _approx(tmp, parse_crs(crs))
    if fmt == "opensfm":
        from fotogeo.crs import to_lonlat
        c = np.mean([s.position for s in approx.shots.values()], axis=0)
        lon, lat = to_lonlat(approx.crs, [c[:2]])[0]
        (tmp / fmt).mkdir(exist_ok=True)
        from dataclasses import replace  # an RTK dop (2 cm) in exif/: the camera centres decide the frame
        rtk = replace(approx, shots={n: replace(s, sigma_h=0.02) for n, s in approx.shots.items()})
        write_opensfm(tmp / fmt / "reconstruction.json", rtk, (lat, lon, 0.0), extension=".tif")
        eo = tmp / fmt / "reconstruction.json"
    else:
        write_colmap(tmp / fmt, approx, extension=".tif")
        eo = tmp / fmt
    if not (tmp / "out_txt").exists():
        _run(tmp, tmp / "eo.txt", "out_txt", checks)
    import json
    ref = json.loads((tmp / "out_txt" / "report.json").read_text())
    got = _run(tmp, eo, f"out_{fmt}", checks, crs if fmt == "colmap" else None)  # COLMAP carries no CRS
    base = read_exterior_orientation(tmp / "out_txt" / "exterior_orientation.txt")
    for n, e in read_exterior_orientation(tmp / f"out_{fmt}" / "exterior_orientation.txt").items():
        assert np.allclose([e.X, e.Y, e.Z], [base[n].X, base[n].Y, base[n].Z], atol=1e-3), n
    assert got["start"]["source"].startswith("--eo") and got["sigma0"] == pytest.approx(ref["sigma0"], rel=1e-3)


def test_an_sfm_file_missing_a_frame_is_refused_by_name(block_files, tmp_path):
    tmp, checks = block_files
    from fotogeo.crs import parse_crs
    approx = _approx(tmp, parse_crs(read_gcp_list(tmp / "gcp_list.txt").crs))
    name = sorted(approx.shots)[0]
    shots = {k: v for k, v in approx.shots.items() if k != name}
    write_colmap(tmp_path / "model", ApproximateBlock(approx.cameras, shots, approx.crs), extension=".tif")
    with pytest.raises(InputError, match=f"no pose for frame\\(s\\) {name}"):
        _run(tmp, tmp_path / "model", "out_missing", checks, approx.crs.to_string())
