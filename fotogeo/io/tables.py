"""Point tables: CSV files or vector layers (any OGR format) in, CSV or GeoPackage out."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VectorError


def _read_table(path, what):
    p = Path(path)
    if not p.exists():
        raise VectorError(f"{what} {str(p)!r} does not exist")
    try:
        if p.suffix.lower() == ".csv":
            import pandas as pd
            return pd.read_csv(p), None
        import geopandas as gpd
        gdf = gpd.read_file(p, engine="pyogrio")
        return gdf, gdf
    except Exception as e:  # noqa: BLE001 - any reader failure becomes one clear error
        raise VectorError(f"{what} {str(p)!r} cannot be read: {e}") from None


def _columns(table, names, what):
    low = {c.lower(): c for c in table.columns}
    missing = [n for n in names if n.lower() not in low]
    if missing:
        raise VectorError(f"{what} lacks the column(s) {', '.join(missing)} (has: {', '.join(map(str, table.columns))})")
    return table[[low[n.lower()] for n in names]].to_numpy(float)


def _write_table(path, columns: dict, crs=None, xy=None):
    if str(path).lower().endswith(".csv"):
        import pandas as pd
        pd.DataFrame(columns).to_csv(path, index=False)
    else:
        import shapely

        from .vector import write_layers
        geom = shapely.points(xy if xy is not None else np.column_stack([columns["col"], columns["row"]]))
        write_layers(path, {"points": {**columns, "geometry": geom}}, crs)
