"""The worker's environment check: write and read back a GeoTIFF, a 3-D point and a GeoPackage through the wheels'
GDAL/GEOS/PROJ (:func:`fotogeo.worker.check_environment`, ``python -m fotogeo.worker --check``)."""
from __future__ import annotations

import os


def smoke_test(folder: str) -> None:
    """The calls that fail when a wheel runs against another copy of GDAL/GEOS/PROJ."""
    import geopandas as gpd
    import numpy as np
    import rasterio
    import shapely
    from pyproj import Transformer
    from rasterio.transform import from_origin

    from .clocale import import_pyogrio
    import_pyogrio()
    x, _ = Transformer.from_crs("EPSG:4326", "EPSG:32635", always_xy=True).transform(27.0, -29.0)
    if not 400_000 < x < 600_000:
        raise RuntimeError(f"pyproj transformed lon 27 to x={x} in UTM 35, expected about 500000")
    path = os.path.join(folder, "check.tif")
    with rasterio.open(path, "w", driver="GTiff", width=3, height=2, count=1, dtype="uint8", crs="EPSG:32635",
                       transform=from_origin(500000, 7000000, 5, 5)) as ds:
        ds.write(np.arange(6, dtype="uint8").reshape(1, 2, 3))
    with rasterio.open(path) as ds:
        if ds.read(1)[1, 2] != 5 or ds.crs.to_epsg() != 32635:
            raise RuntimeError("rasterio read back another GeoTIFF than it wrote")
    if len(shapely.to_wkb(shapely.points([[1.0, 2.0, 3.0]]), output_dimension=3)[0]) != 29:
        raise RuntimeError("shapely wrote a 3-D point WKB of the wrong size")
    gpkg = os.path.join(folder, "check.gpkg")
    gpd.GeoDataFrame({"z": [3.0]}, geometry=shapely.points([[1.0, 2.0, 3.0]]), crs="EPSG:32635").to_file(
        gpkg, layer="p", engine="pyogrio")
    back = gpd.read_file(gpkg, layer="p", engine="pyogrio")
    if not back.geometry.iloc[0].has_z or back.crs.to_epsg() != 32635:
        raise RuntimeError("pyogrio read back another GeoPackage than it wrote")
