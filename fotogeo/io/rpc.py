"""RPC files and rasters: the one entry point :func:`read_rpc` for RPC files of every vendor format, the RPC
of a raster's GDAL metadata (:func:`rpc_from_raster`) and GeoTIFF copies of an image carrying an RPC as GDAL
metadata (:func:`write_rpc_geotiff`; ``gdalwarp -rpc`` reads it).

One reader per format, all returning :class:`~fotogeo.orientation.rpc.Rpc` in the RPC00B pixel convention
(the *centre* of the first pixel is (0, 0), as in GDAL's RPC metadata; vendor conventions are converted by
their reader): ``KEY: value`` text in :mod:`fotogeo.io.rpc_text` (:func:`read_rpc_text`, with the checks every
reader shares), DIMAP and DigitalGlobe XML in
:mod:`fotogeo.io.rpc_xml`, OSSIM ``.geom`` and ``.RPB`` in :mod:`fotogeo.io.rpc_keywords`; the RPC of an
image with its sidecar files: :func:`fotogeo.io.rpc_image.image_rpc`.
"""
from __future__ import annotations

import re
from pathlib import Path

from ..errors import InputError, OutputError, RasterError
from ..orientation.rpc import Rpc
from .rpc_keywords import read_rpc_ossim, read_rpc_rpb
from .rpc_xml import read_rpc_xml
from .rpc_text import checked_rpc, read_rpc_file_text, read_rpc_text  # noqa: F401 (this module's API)


def read_rpc(path) -> Rpc:
    """Read an RPC file, its format told by its content (one reader per format):

    * XML: DIMAP (Pleiades, SPOT 6/7, Pleiades Neo) or DigitalGlobe ``<isd>`` — :mod:`fotogeo.io.rpc_xml`;
    * OSSIM/OTB ``.geom`` keyword list (``line_num_coeff_00:``) and ``.RPB`` (``lineOffset = …;``) —
      :mod:`fotogeo.io.rpc_keywords`;
    * ``KEY: value`` text (IKONOS ``_rpc.txt``, Planet/SkySat ``_RPC.TXT``) — :func:`read_rpc_text`.

    :meth:`~fotogeo.orientation.rpc.Rpc.to_model` moves the result to fotogeo's corner convention.
    """
    path = Path(path)
    head = read_rpc_file_text(path)[:20000]
    if head.lstrip().startswith("<"):
        return read_rpc_xml(path)
    if re.search(r"^\s*line_num_coeff_00\s*:", head, re.MULTILINE):
        return read_rpc_ossim(path)
    if re.search(r"^\s*lineOffset\s*=", head, re.MULTILINE | re.IGNORECASE):
        return read_rpc_rpb(path)
    if re.search(r"^\s*LINE_OFF\s*:", head, re.MULTILINE):
        return read_rpc_text(path)
    raise InputError(f"RPC file {str(path)!r}: unsupported RPC format (expected DIMAP or DigitalGlobe XML, an "
                     f"OSSIM .geom, an .RPB or 'LINE_OFF: ...' text)")


def write_rpc_geotiff(src_path, dst_path, rpc: Rpc, *, overwrite: bool = False) -> Path:
    """Copy raster ``src_path`` to the GeoTIFF ``dst_path`` with ``rpc`` as GDAL RPC metadata.

    ``rpc`` describes the copy's own pixels (as GDAL reads RPC tags). The copy keeps pixels and a
    georeference with a CRS; a CRS-less geotransform (a crop's place in its product) is dropped, since
    beside RPC tags it is ambiguous (:func:`fotogeo.io.rpc_image.image_rpc` refuses it). ``gdalwarp -rpc`` /
    ``gdaltransform -rpc`` and QGIS's RPC option then use the RPC. Written to a temporary file beside
    ``dst_path`` and renamed when complete.
    """
    import rasterio
    import rasterio.shutil
    from rasterio.errors import RasterioError

    from .raster import geotiff_profile

    src_path, dst_path = Path(src_path), Path(dst_path)
    if dst_path.exists() and not overwrite:
        raise OutputError(f"{dst_path} exists; pass overwrite=True or choose another output path", option="overwrite")
    if dst_path.exists() and dst_path.resolve() == src_path.resolve():
        raise OutputError(f"output {dst_path} equals the input raster; choose another output path")
    if not dst_path.parent.is_dir():
        raise OutputError(f"output folder {dst_path.parent} does not exist; create it first")
    if not src_path.exists():
        raise InputError(f"input raster {src_path} does not exist")
    tmp = dst_path.with_name(f".{dst_path.name}.part.tif")
    try:
        rasterio.shutil.copy(str(src_path), str(tmp), **geotiff_profile())
        with rasterio.open(tmp, "r+") as ds:
            ds.update_tags(ns="RPC", **rpc.to_gdal_metadata())
            if ds.crs is None and not ds.transform.is_identity:
                from affine import Affine
                ds.transform = Affine.identity()
        tmp.replace(dst_path)
    except RasterioError as exc:
        raise OutputError(f"cannot write {dst_path} from {src_path}: {exc}") from None
    finally:
        if tmp.exists():
            tmp.unlink()
    return dst_path


def rpc_from_raster(path) -> Rpc:
    """The RPC00B model stored in a raster's GDAL ``RPC`` metadata."""
    from .raster import ropen
    try:
        with ropen(path) as ds:
            rpcs = ds.rpcs
    except Exception as e:  # noqa: BLE001
        raise RasterError(f"cannot read raster {str(path)!r}: {e}") from None
    if rpcs is None:
        raise RasterError(f"raster {str(path)!r} carries no RPC metadata")
    d = {k.upper(): v for k, v in rpcs.to_dict().items()}
    return Rpc.from_mapping(d, f"RPC of {path}")
