"""triangulate's start reads only the window of the DEM its frames can see (before, a regional DEM was read whole
for the start height and the level frames' attitudes): the frames' positions plus a margin from their height above
the DEM and their field of view (``frame_reach``), so memory follows the block, not the DEM."""
from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera

CRS = "EPSG:32635"
CAMERA = FrameCamera(6.0, (4.0, 6.0), (400, 600))  # half diagonal field of view 31°
SIZE = 3000  # 3 x 3 km at 1 m: 72 MB as float64, the block sees ~0.3 x 0.5 km of it


@pytest.fixture(scope="module")
def regional_dem(tmp_path_factory):
    path = tmp_path_factory.mktemp("dem") / "regional.tif"
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    z = (100.0 + 0.01 * cols + 0.002 * rows).astype(np.float32)
    with rasterio.open(path, "w", driver="GTiff", width=SIZE, height=SIZE, count=1, dtype="float32", crs=CRS,
                       transform=from_origin(500000.0, 7003000.0, 1.0, 1.0), tiled=True, compress="deflate") as ds:
        ds.write(z, 1)
    return path


def _eos():
    return [ExteriorOrientation(501500.0 + dx, 7001500.0, 330.0, 0.0, 0.0, 0.0) for dx in (0.0, 120.0)]


def test_the_start_height_reads_the_frames_window_only(regional_dem):
    from pyproj import CRS as PCRS

    from fotogeo.tools.triangulate.tool import start_height
    tracemalloc.start()
    try:
        h = start_height(None, regional_dem, PCRS.from_user_input(CRS), _eos(), CAMERA)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert h == pytest.approx(100.0 + 0.01 * 1560 + 0.002 * 1500, abs=0.05)  # the DEM under the two centres
    # the heights' range from a decimated read of at most 1 M cells (~21 MB), then the window; whole: 72 MB and more
    assert peak < 40e6, f"{peak / 1e6:.0f} MB for a {SIZE} x {SIZE} DEM"


def test_the_window_is_the_frames_reach(regional_dem):
    from pyproj import CRS as PCRS

    from fotogeo.geometry.dem import underlying_dem
    from fotogeo.tools.triangulate.ortho import dem_near_frames, frame_reach
    eos = _eos()
    d = underlying_dem(dem_near_frames(regional_dem, PCRS.from_user_input(CRS), CAMERA, eos))[0]
    lowest = 100.0 - 0.1 * 36.0 - 100.0  # the DEM's lowest height less the padding of read_dem_around
    r = (330.0 - lowest) * np.tan(np.arctan(np.hypot(200 / 600, 300 / 600)))
    assert frame_reach(CAMERA, eos, lowest)[0][1] == pytest.approx([501500.0 + r, 7001500.0 - r], abs=1e-6)
    rows, cols = d.data.shape
    assert abs(cols - (2 * r + 120)) <= 8 and abs(rows - 2 * r) <= 8, (d.data.shape, r)
    tilted = [ExteriorOrientation(e.X, e.Y, e.Z, 30.0, 0.0, 0.0) for e in eos]  # 30° oblique: a wider reach
    assert underlying_dem(dem_near_frames(regional_dem, PCRS.from_user_input(CRS), CAMERA, tilted))[0].data.shape[0] \
        > 2 * rows
