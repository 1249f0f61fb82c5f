"""The ``.points`` tools: QGIS Georeferencer ``.points`` file ↔ GCP point layer (GeoPackage)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...crs import parse_crs
from ...errors import InputError, VectorError
from ...io.gcps import enabled_rows
from ...io.raster import raster_transform
from ...io.points import pixel_to_source, read_points, source_to_pixel, write_points
from ..common.boundary import tool

DEFAULT_LAYER = "gcps"


@tool("POINTS_TO_LAYER", rasters={"raster": None})
def points_to_layer(points, output, *, raster=None, crs=None, layer: str = DEFAULT_LAYER,
                    overwrite: bool = False, progress=None) -> dict:
    """Convert a ``.points`` file into a GeoPackage point layer (fields id, col, row, z, role, dx, dy, residual).

    ``raster`` is the source raster the points were measured on: needed only when it is
    georeferenced (source coordinates are then its map coordinates); without it the
    unreferenced convention (sourceY = −row) applies. The layer CRS is ``crs`` if given,
    else the file's ``#CRS`` line, else none. Returns a summary dict.
    """
    import shapely

    from ...io.output_checks import check_output
    from ...io.raster import AtomicOutputs
    from ...io.vector import write_layers
    from ...progress import as_progress

    prog = as_progress(progress)
    check_output(output, [points, raster], overwrite, "output GeoPackage", (".gpkg",))
    if not layer or not str(layer).strip():
        raise InputError("layer name must not be empty")
    gp = read_points(points)
    prog(0.3, "points read")
    transform = raster_transform(raster)
    colrow = source_to_pixel(gp.source_xy, transform)
    spec = crs if crs else gp.crs
    crs_obj = parse_crs(spec, "CRS" if crs else f"#CRS line of {str(points)!r}") if spec else None
    n = len(gp)
    res = gp.residual
    columns = {
        "id": np.arange(1, n + 1, dtype=np.int64),
        "col": colrow[:, 0], "row": colrow[:, 1], "z": np.full(n, np.nan),
        "role": np.where(gp.enabled, "control", "check").astype(object),
        "dx": res[:, 0], "dy": res[:, 1], "residual": np.hypot(res[:, 0], res[:, 1]),
        "geometry": shapely.points(gp.map_xy),
    }
    with AtomicOutputs(overwrite) as out:
        write_layers(out.temp(output), {layer: columns}, crs_obj.to_wkt() if crs_obj else None)
        prog(1.0, "layer written")
        out.commit()
    return {"output": str(Path(output)), "layer": layer, "points": n, "enabled": int(gp.enabled.sum()),
            "crs": crs_obj.to_string() if crs_obj else None,
            "source_convention": "georeferenced raster" if transform is not None else "unreferenced (sourceY = -row)"}


@tool("LAYER_TO_POINTS", rasters={"raster": None})
def layer_to_points(source, output, *, layer: str | None = None, raster=None, overwrite: bool = False,
                    progress=None) -> dict:
    """Write a ``.points`` file from a point layer with fields ``col``, ``row`` (and ``role``, ``id``).

    A ``tie_points`` layer of :func:`fotogeo.tools.register.tool.register` works too: its
    ``target_col``, ``target_row`` are the source pixels, its points the reference positions.

    Map coordinates are the point geometries; the ``#CRS`` line is the layer's CRS. Source
    coordinates follow the unreferenced convention unless ``raster`` (georeferenced) is
    given. Points are written in ``id`` order when the field exists. Returns a summary dict.
    """
    from ...io.output_checks import check_output
    from ...io.raster import AtomicOutputs
    from ...io.tables import find_column, is_layer, read_table, require_columns
    from ...progress import as_progress

    prog = as_progress(progress)
    check_output(output, [source, raster], overwrite, "output points file")
    gdf = read_table(source, "point layer", layer)
    what = f"layer {layer or '(first)'} of {str(source)!r}"
    if not is_layer(gdf):
        raise VectorError(f"{what} has no point geometries (the map positions); use a point layer")
    pixel_fields = ["col", "row"]
    if find_column(gdf, "col") is None and find_column(gdf, "row") is None \
            and find_column(gdf, "target_col") is not None and find_column(gdf, "target_row") is not None:
        pixel_fields = ["target_col", "target_row"]  # a register tie_points layer
    col, row = require_columns(gdf, pixel_fields, what, "source pixel coordinates; or target_col/target_row "
                               "of a register tie_points layer")
    if len(gdf) == 0:
        raise VectorError(f"{what} has no features")
    geom = gdf.geometry
    if geom.isna().any() or geom.is_empty.any():
        raise VectorError(f"{what} has features without a geometry (the map position); fix or remove them")
    if not (geom.geom_type == "Point").all():
        kinds = sorted(set(geom.geom_type))
        raise VectorError(f"{what} must hold single points; it has {', '.join(kinds)}")
    id_field, role_field = find_column(gdf, "id"), find_column(gdf, "role")
    dx_field, dy_field = find_column(gdf, "dx"), find_column(gdf, "dy")
    if id_field is not None:
        gdf = gdf.sort_values(id_field, kind="stable")
        geom = gdf.geometry
    prog(0.3, "layer read")
    colrow = np.column_stack([gdf[col].to_numpy(float), gdf[row].to_numpy(float)])
    if not np.isfinite(colrow).all():
        raise VectorError(f"{what} has empty (NULL) or non-finite col/row values")
    enabled = (gdf[role_field].astype(str).str.lower() == "control").to_numpy() if role_field is not None \
        else np.ones(len(gdf), bool)
    enabled = enabled & enabled_rows(gdf)  # a disabled point (field enabled = 0) is written disabled whatever its role
    residual = (np.column_stack([gdf[dx_field].to_numpy(float), gdf[dy_field].to_numpy(float)])
                if dx_field is not None and dy_field is not None else None)
    map_xy = np.column_stack([geom.x.to_numpy(float), geom.y.to_numpy(float)])
    source_xy = pixel_to_source(colrow, raster_transform(raster))
    crs = gdf.crs.to_wkt() if gdf.crs is not None else None
    with AtomicOutputs(overwrite) as out:
        write_points(out.temp(output), map_xy, source_xy, enabled, residual, crs)
        prog(1.0, "points file written")
        out.commit()
    return {"output": str(Path(output)), "points": len(gdf), "enabled": int(enabled.sum()),
            "crs": gdf.crs.to_string() if gdf.crs is not None else None}
