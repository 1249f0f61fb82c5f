"""ODM/OpenSfM ``gcp_list.txt`` for the GCP picker: the measurements of one image in and out (JSON).

Session tools of ``python -m fotogeo.worker --session`` (the picker never parses the file itself,
so it reads and writes exactly what ``fotogeo triangulate --gcps`` and ODM read):

* :func:`read_image_gcps` — the GCPs of ``path`` measured on ``image`` (its file name or stem) as
  the picker's rows ``{"id", "col", "row", "x", "y", "z", "role"}`` (corner convention, ground in
  the file's CRS, returned as WKT);
* :func:`write_image_gcps` — the picker's rows (every one with a height: ODM needs Z) as a
  ``gcp_list.txt`` of ``image``; the CRS line is the EPSG code when the CRS has one, else its
  PROJ string.

File format and pixel conventions: :mod:`fotogeo.io.block`.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ...crs import parse_crs
from ...errors import InputError
from ...io.block import GcpList, frame_key, read_gcp_list, write_gcp_list
from ...io.raster import AtomicOutputs
from ..common.boundary import tool
from .fit import parse_gcp_rows


@tool()
def read_image_gcps(path, *, image, progress=None) -> dict:
    """``{"crs": WKT, "gcps": [...]}``: the measurements of ``image`` in the GCP list ``path``."""
    gcp = read_gcp_list(path)
    key = frame_key(image)
    mine = np.flatnonzero(gcp.frame == key)
    if not len(mine):
        names = ", ".join(sorted(set(gcp.frame))[:5])
        raise InputError(f"GCP list {str(path)!r} has no measurement on image {key!r} (it names {names}); "
                         f"open that image in the picker")
    crs = parse_crs(gcp.crs, f"the CRS line of GCP list {str(path)!r}")
    rows = [{"id": str(gcp.name[k]), "col": float(gcp.pixel[k, 0]), "row": float(gcp.pixel[k, 1]),
             "x": float(gcp.ground[k, 0]), "y": float(gcp.ground[k, 1]), "z": float(gcp.ground[k, 2]),
             "role": "control"} for k in mine]
    return {"crs": crs.to_wkt(), "gcps": rows}


@tool(outputs=("output",))
def write_image_gcps(gcps, *, crs, image, output, progress=None) -> dict:
    """Write ``gcps`` (the picker's rows, ground in ``crs``) as the ``gcp_list.txt`` ``output`` of ``image``."""
    ids, _, pixel, xy, z = parse_gcp_rows(gcps)
    missing = [str(i) for i, v in zip(ids, z) if not np.isfinite(v)]
    if missing:
        raise InputError(f"GCP(s) {', '.join(missing[:10])} have no height; ODM's gcp_list.txt needs Z: choose a DEM "
                         f"or a constant height (or fill the z field) first")
    map_crs = parse_crs(crs, "the GCPs' CRS")
    epsg = map_crs.to_epsg()
    with warnings.catch_warnings():  # pyproj: "you will likely lose ... information" (ODM takes PROJ strings)
        warnings.simplefilter("ignore", UserWarning)
        line = f"EPSG:{epsg}" if epsg else map_crs.to_proj4()
    gcp = GcpList(line, ids, np.column_stack([xy, z]), pixel, np.full(len(ids), Path(str(image)).name, dtype=object))
    with AtomicOutputs(True) as out:
        write_gcp_list(out.temp(Path(output)), line, gcp)
        out.commit()
    return {"count": len(ids), "output": str(output)}
