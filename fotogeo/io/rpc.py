"""RPC files: RPC00B text (``_RPC.TXT``), Pleiades DIMAP XML, GDAL RPC metadata of a raster, and
GeoTIFF copies of an image carrying a fitted RPC as GDAL metadata (``gdalwarp -rpc`` reads it).
"""
from __future__ import annotations

import dataclasses
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import InputError, OutputError, RasterError, one_line
from ..orientation.rpc import Rpc
from .text import read_text_file


def _read_text(path: Path, what: str) -> str:
    """The text of ``path`` (undecodable bytes replaced; :func:`~fotogeo.io.text.read_text_file`)."""
    return read_text_file(path, what, hint="give the RPC file (_RPC.TXT or DIMAP RPC XML)", errors="replace")


def _checked(rpc: Rpc, source: str) -> Rpc:
    """``rpc`` if every value is finite, the scales non-zero and the denominators not all zero."""
    for f in dataclasses.fields(rpc):
        value = np.asarray(getattr(rpc, f.name), dtype=np.float64)
        if not np.isfinite(value).all():
            raise InputError(f"{source}: {f.name.upper()} is not finite; the RPC file is damaged")
        if f.name.endswith("_scale") and value == 0:
            raise InputError(f"{source}: {f.name.upper()} is 0; the RPC file is damaged")
        if f.name.endswith("_den") and not value.any():
            raise InputError(f"{source}: {f.name.upper()}_COEFF are all 0; the RPC file is damaged")
    return rpc


def read_rpc_text(path) -> Rpc:
    """Read a ``KEY: value [unit]`` RPC text file (IKONOS ``_rpc.txt``, Planet/SkySat ``_RPC.TXT``)."""
    path = Path(path)
    d = {}
    for line in _read_text(path, "RPC file").splitlines():
        key, sep, value = line.partition(":")
        if sep and value.split():
            d[key.strip().upper()] = value.split()[0]
    source = f"RPC file {str(path)!r}"
    return _checked(Rpc.from_mapping(d, source), source)


def read_rpc_dimap(path) -> Rpc:
    """Read the ground -> image ``Inverse_Model`` of a DIMAP v2 RPC XML (Pleiades, SPOT 6/7)."""
    path = Path(path)
    source = f"RPC file {str(path)!r}"
    _read_text(path, "RPC file")  # a folder or a missing file: a clear message
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, ValueError, LookupError, UnicodeError) as exc:
        raise InputError(one_line(f"{source}: not valid XML ({exc}); give a DIMAP RPC XML or an RPC text file")) from None
    except OSError as exc:
        raise InputError(one_line(f"cannot read {source}: {exc}")) from None
    inv = root.find(".//Inverse_Model")
    valid = root.find(".//RFM_Validity")
    if inv is None or valid is None:
        raise InputError(f"{source}: no DIMAP Inverse_Model / RFM_Validity; unsupported RPC file")
    d = {el.tag: el.text for el in list(inv) + list(valid) if el.text and el.text.strip()}
    return _checked(Rpc.from_mapping(d, source), source)


def read_rpc(path) -> Rpc:
    """Read an RPC text or DIMAP XML file (by content)."""
    path = Path(path)
    head = _read_text(path, "RPC file")[:2000]
    if head.lstrip().startswith("<"):
        return read_rpc_dimap(path)
    if re.search(r"^\s*LINE_OFF\s*:", head, re.MULTILINE):
        return read_rpc_text(path)
    raise InputError(f"RPC file {str(path)!r}: unsupported RPC format (expected 'LINE_OFF: ...' text or DIMAP XML)")


def write_rpc_geotiff(src_path, dst_path, rpc: Rpc, *, overwrite: bool = False) -> Path:
    """Copy raster ``src_path`` to the GeoTIFF ``dst_path`` with ``rpc`` as GDAL RPC metadata.

    The copy keeps pixels and any georeference; ``gdalwarp -rpc`` / ``gdaltransform -rpc`` and
    QGIS's RPC option then use the RPC. Written to a temporary file beside ``dst_path`` and
    renamed when complete.
    """
    import rasterio
    import rasterio.shutil
    from rasterio.errors import RasterioError

    from .raster import geotiff_profile

    src_path, dst_path = Path(src_path), Path(dst_path)
    if dst_path.exists() and not overwrite:
        raise OutputError(f"{dst_path} exists; pass overwrite=True or choose another output path")
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
