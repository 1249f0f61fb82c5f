"""A pyproj ``CRSError`` raised inside a tool reached the command line as a traceback (exit 1, no ``Error:``
line); the tool boundary (:mod:`fotogeo.tools.common.boundary`) now turns it into one line naming the CRS option
given, in the caller's words; another pyproj error (a transformation, PROJ's data) is not blamed on the CRS given
— that read "give a CRS pyproj knows" where the CRS was fine (a reviewer's finding)."""
from __future__ import annotations

import numpy as np
import rasterio
from click.testing import CliRunner
import pytest
from pyproj.exceptions import CRSError, ProjError

from fotogeo.cli import main
from test_bad_input import assert_one_line_error


def _ortho_failing_with(error, tmp_path, monkeypatch):
    """``fotogeo ortho … --crs EPSG:32631`` on a small image whose CRS step raises ``error``."""
    import fotogeo.tools.ortho.tool as ortho_tool

    def fail(*args, **kwargs):
        raise error

    monkeypatch.setattr(ortho_tool, "map_crs", fail)
    img = tmp_path / "img.tif"
    with rasterio.open(img, "w", driver="GTiff", width=16, height=16, count=1, dtype="uint8") as ds:
        ds.write(np.zeros((1, 16, 16), np.uint8))
    return CliRunner().invoke(main, ["ortho", str(img), "--rpc", "--height", "0", "--crs", "EPSG:32631", "-o",
                                     str(tmp_path / "o.tif"), "-q"])


@pytest.mark.parametrize("error, line", [
    (CRSError("Invalid projection: EPSG:32631: (Internal Proj Error: proj_create: no database context)"),
     "--crs 'EPSG:32631' or the CRS of the inputs cannot be used (Invalid projection"),
    (ProjError("x, y, z, and time must be same size"),
     "PROJ could not transform the coordinates (x, y, z, and time must be same size)")])
def test_a_pyproj_error_inside_a_tool_is_one_line(tmp_path, monkeypatch, error, line):
    r = _ortho_failing_with(error, tmp_path, monkeypatch)
    assert_one_line_error(r, line)
    assert not (tmp_path / "o.tif").exists()
    assert isinstance(error, CRSError) or "give a CRS pyproj knows" not in r.output


def test_a_gdal_error_is_not_read_as_permission_denied(tmp_path, monkeypatch):
    """GDAL's errors carry GDAL's error class as ``errno`` (CPLE_AppDefined is 1, EPERM as an OS number): a broken
    XMP packet read by GDAL came out as "cannot write …: permission denied; choose a folder you can write to"."""
    from rasterio._err import CPLE_AppDefinedError
    r = _ortho_failing_with(CPLE_AppDefinedError(1, 1, "Line 12: </rdf:Descr> doesn't have matching <rdf:Descr>."),
                            tmp_path, monkeypatch)
    assert r.exit_code == 1 and "permission denied" not in r.output.lower(), r.output
    assert "doesn't have matching" in r.output, r.output
