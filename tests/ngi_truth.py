"""True geometry of the NGI raw frames (camera + exterior orientation + DEM), shared by tests.

Checked against the orthophotos in tests/test_camera.py (0.7–0.8 orthophoto pixel RMSE).
"""
import numpy as np
from pyproj import CRS

from fotogeo.io.camera import load_ngi_frame
from fotogeo.io.raster import read_dem
from fotogeo.crs import transform_points
from fotogeo.pixels import pixel_centres

FRAMES = [("3324c_2015_1004_05_0182", "ngi_rgb_byte_1.tif"), ("3324c_2015_1004_05_0184", "ngi_rgb_byte_2.tif")]


def truth_points(ngi, name, step=10, crs=32735):
    """Frame pixels on a dense grid (every ``step`` px) and their true ground points
    ``(X, Y, Z)``, X and Y in EPSG:``crs``."""
    dem = read_dem(ngi / "dem.tif")
    frame = load_ngi_frame(ngi, name)
    w, h = frame.camera.image_size
    x, y = pixel_centres(w // step, h // step)
    px = np.column_stack([x.ravel(), y.ravel()]) * step
    g = frame.pixel_to_world(px, dem)
    ok = np.isfinite(g).all(axis=1)
    xy = transform_points(CRS.from_wkt(dem.crs.to_wkt()), CRS.from_epsg(crs), g[ok, :2])
    return px[ok], np.column_stack([xy, g[ok, 2]])
