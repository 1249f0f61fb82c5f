"""A pyproj ``CRSError`` raised inside a tool reached the command line as a traceback (exit 1, no ``Error:``
line); the tool boundary (:mod:`fotogeo.tools.common.boundary`) now turns it into one line naming the CRS option
given, in the caller's words."""
from __future__ import annotations

import numpy as np
import rasterio
from click.testing import CliRunner
from pyproj.exceptions import CRSError

from fotogeo.cli import main
from test_bad_input import assert_one_line_error


def test_a_crs_error_inside_a_tool_is_one_line_naming_the_crs(tmp_path, monkeypatch):
    import fotogeo.tools.ortho.tool as ortho_tool

    def refuse(*args, **kwargs):
        raise CRSError("Invalid projection: EPSG:32631: (Internal Proj Error: proj_create: no database context)")

    monkeypatch.setattr(ortho_tool, "map_crs", refuse)
    img = tmp_path / "img.tif"
    with rasterio.open(img, "w", driver="GTiff", width=16, height=16, count=1, dtype="uint8") as ds:
        ds.write(np.zeros((1, 16, 16), np.uint8))
    out = tmp_path / "o.tif"
    r = CliRunner().invoke(main, ["ortho", str(img), "--rpc", "--height", "0", "--crs", "EPSG:32631", "-o",
                                  str(out), "-q"])
    assert_one_line_error(r, "--crs 'EPSG:32631' or the CRS of the inputs cannot be used (Invalid projection")
    assert not out.exists()


def test_another_pyproj_error_is_not_blamed_on_the_crs_given(tmp_path, monkeypatch):
    """Every pyproj exception read as "the CRS cannot be used; give a CRS pyproj knows" — wrong advice for a failed
    transformation or missing PROJ data, where the CRS given is fine (a reviewer's finding)."""
    import fotogeo.tools.ortho.tool as ortho_tool
    from pyproj.exceptions import ProjError

    def fail(*args, **kwargs):
        raise ProjError("x, y, z, and time must be same size")

    monkeypatch.setattr(ortho_tool, "map_crs", fail)
    img = tmp_path / "img.tif"
    with rasterio.open(img, "w", driver="GTiff", width=16, height=16, count=1, dtype="uint8") as ds:
        ds.write(np.zeros((1, 16, 16), np.uint8))
    r = CliRunner().invoke(main, ["ortho", str(img), "--rpc", "--height", "0", "--crs", "EPSG:32631", "-o",
                                  str(tmp_path / "o.tif"), "-q"])
    assert_one_line_error(r, "PROJ could not transform the coordinates (x, y, z, and time must be same size)")
    assert "give a CRS pyproj knows" not in r.output
