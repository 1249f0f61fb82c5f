"""Vector and report outputs: tie points and error vectors as GeoPackage layers, JSON reports.

Error vectors are LineStrings from the reference (true) position ``P`` to the model's
position ``P'``; with an ``exaggeration`` k the drawn line ends at ``P + k (P' − P)`` so that
metre-sized errors are visible on a map, while ``dx``, ``dy`` and ``length`` always hold
the true (unexaggerated) values in map units.
"""
from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import shapely

from ..errors import OutputError


def error_vectors(start: np.ndarray, end: np.ndarray, exaggeration: float = 1.0) -> np.ndarray:
    """Shapely LineStrings from ``start`` to ``start + exaggeration * (end - start)``."""
    stop = start + exaggeration * (end - start)
    coords = np.stack([start, stop], axis=1)  # (N, 2, 2)
    return shapely.linestrings(coords)


def write_layers(path, layers: dict, crs) -> None:
    """Write ``{layer name: GeoDataFrame-like dict with 'geometry'}`` into one GeoPackage."""
    path = Path(path)
    try:
        for i, (name, columns) in enumerate(layers.items()):
            gdf = gpd.GeoDataFrame({k: v for k, v in columns.items() if k != "geometry"},
                                   geometry=columns["geometry"], crs=crs)
            # GeoPackage 1.2: QGIS 3.22's GDAL reads the 1.4 files newer GDALs write only partially
            opts = {"dataset_options": {"VERSION": "1.2"}} if i == 0 else {}
            gdf.to_file(path, layer=name, driver="GPKG", mode="w" if i == 0 else "a", engine="pyogrio", **opts)
    except Exception as e:  # noqa: BLE001 - any writer failure becomes one clear error
        raise OutputError(f"could not write GeoPackage {str(path)!r}: {e}") from None
