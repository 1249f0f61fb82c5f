"""DEM heights stated in feet (the band's unit type, or a compound CRS's vertical axis) are converted to the length
unit of the DEM's horizontal CRS before any model meets them: a metric DEM whose band says ``ft`` used as metres put
NGI frame 0182 1.5+ px (5 m cells) off its orthophoto with exit 0."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from fotogeo.io.raster import read_dem

Z = np.array([[100.0, 200.0, 300.0], [400.0, 500.0, 600.0], [700.0, 800.0, 900.0]])


def _dem(path, crs, unit):
    with rasterio.open(path, "w", driver="GTiff", width=3, height=3, count=1, dtype="float32", crs=crs,
                       transform=from_origin(500000, 7000000, 10, 10)) as ds:
        ds.write(Z.astype("float32"), 1)
        if unit is not None:
            ds.units = (unit,)
    return str(path)


@pytest.mark.parametrize("crs, unit, factor", [
    ("EPSG:32735", "ft", 0.3048),                 # metric CRS, heights in international feet
    ("EPSG:32735", "US survey foot", 1200 / 3937),
    ("EPSG:32735", "metre", 1.0),
    ("EPSG:32735", None, 1.0),                    # unstated: taken as they are (as before)
    ("EPSG:2263", "US survey foot", 1.0),         # NY State Plane (ftUS) with ftUS heights: one unit already
    ("EPSG:2263", "m", 3937 / 1200),              # ftUS plane, metre heights: into ftUS
    ("EPSG:32618+6360", None, 1200 / 3937),       # compound: NAVD88 height (ftUS) under UTM 18N
])
def test_read_dem_heights_in_the_crs_unit(tmp_path, crs, unit, factor):
    d = read_dem(_dem(tmp_path / "dem.tif", crs, unit))
    assert np.allclose(d.data, Z * factor, rtol=1e-12)


def test_ortho_dem_window_in_metres_from_a_feet_dem(data_dir, tmp_path):
    """The ortho tool's windowed DEM reader converts as read_dem does: the NGI DEM written in feet gives the
    metre DEM's heights under frame 0182."""
    from fotogeo.tools.ortho.crs_rule import map_crs
    from fotogeo.tools.ortho.inputs import image_models, read_dem_under
    ngi = data_dir / "ngi"
    ft = tmp_path / "dem_ft.tif"
    with rasterio.open(ngi / "dem.tif") as src:
        z, profile = src.read(1), src.profile
    with rasterio.open(ft, "w", **profile) as ds:
        ds.write(z / 0.3048, 1)
        ds.units = ("ft",)
    frame = str(ngi / "frames" / "3324c_2015_1004_05_0182_RGB.tif")
    crs, _ = map_crs("auto", str(ngi / "dem.tif"), str(ngi / "exterior_orientation.txt"), [frame], False)
    im = image_models([frame], crs, camera=str(ngi / "interior_orientation.yaml"),
                      eo=str(ngi / "exterior_orientation.txt"))[0]
    metres, feet = read_dem_under(ngi / "dem.tif", [im], crs), read_dem_under(ft, [im], crs)
    assert feet.data.shape == metres.data.shape
    assert np.nanmax(np.abs(feet.data - metres.data)) < 1e-3


def test_dem_in_feet_queried_from_a_metric_crs_gives_metres(tmp_path):
    """A NY State Plane DEM (ftUS axes, heights in ftUS) sampled at UTM 18N points: heights in metres. On main
    they came back in feet (NGI's DEM in a feet TM under a metric --crs: orthophoto > 1.5 px off, NCC 0.556)."""
    from pyproj import Transformer

    from fotogeo.geometry.dem import Dem, DemSampler
    x0, y0 = 985000.0, 200000.0  # ftUS, Manhattan
    dem = Dem(np.full((3, 3), 328.0833), from_origin(x0, y0, 100, 100), "EPSG:2263")
    centre = Transformer.from_crs("EPSG:2263", "EPSG:32618", always_xy=True).transform(x0 + 150, y0 - 150)
    s = DemSampler(dem, "EPSG:32618")
    assert s.heights(np.array([centre]))[0] == pytest.approx(100.0, abs=1e-3)
    assert s.z_range == pytest.approx((100.0, 100.0), abs=1e-3)
    assert DemSampler(dem, "EPSG:2263").heights(np.array([[x0 + 150, y0 - 150]]))[0] == pytest.approx(328.0833)
