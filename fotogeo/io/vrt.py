"""GDAL VRT files that present a north-up raster on another pixel lattice of the same CRS, without copying it.

A lattice is ``(pixel width, pixel height, origin)``: two north-up grids share one when their pixel sizes are
equal and their origins a whole number of pixels apart. :func:`lattice_vrt` writes a VRT whose grid is the
target lattice's cells covering the source's footprint; each band is one ``ComplexSource`` whose
floating-point ``SrcRect`` is the source-pixel rectangle of that grid (GDAL ≥ 2.0 resamples fractional
windows), so a read of the VRT resamples the source on the fly (bilinear by default), nodata respected.
GDAL's pixel convention: (0, 0) is the top-left corner of the top-left pixel.
"""
from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import escape

from affine import Affine

from .raster import is_virtual_path

#: GDAL's VRT data type names for numpy dtype names
_VRT_TYPES = {"uint8": "Byte", "int8": "Int8", "uint16": "UInt16", "int16": "Int16", "uint32": "UInt32",
              "int32": "Int32", "float32": "Float32", "float64": "Float64"}


def on_lattice(transform: Affine, lattice: Affine, tol: float = 1e-6) -> bool:
    """Whether north-up ``transform`` has ``lattice``'s pixel size and an origin whole pixels from its origin."""
    if transform.b or transform.d or (transform.a, transform.e) != (lattice.a, lattice.e):
        return False
    off = ((transform.c - lattice.c) / lattice.a, (transform.f - lattice.f) / lattice.e)
    return all(abs(o - round(o)) <= tol for o in off)


def covering_grid(transform: Affine, width: int, height: int, lattice: Affine) -> tuple[Affine, int, int]:
    """The cells of ``lattice`` that cover the footprint of a north-up ``width`` × ``height`` grid ``transform``."""
    x0, y1 = transform.c, transform.f
    x1, y0 = x0 + transform.a * width, y1 + transform.e * height
    tol = 1e-9
    c0 = math.floor((x0 - lattice.c) / lattice.a + tol)
    c1 = math.ceil((x1 - lattice.c) / lattice.a - tol)
    r0 = math.floor((y1 - lattice.f) / lattice.e + tol)
    r1 = math.ceil((y0 - lattice.f) / lattice.e - tol)
    grid = Affine(lattice.a, 0.0, lattice.c + c0 * lattice.a, 0.0, lattice.e, lattice.f + r0 * lattice.e)
    return grid, c1 - c0, r1 - r0


def lattice_vrt(source: str, info, lattice: Affine, path, resampling: str = "bilinear", mask=None,
                mask_scale=(1.0, 1.0)) -> Path:
    """Write ``path`` (.vrt): raster ``source`` (described by ``info``, a :class:`fotogeo.io.raster.RasterInfo`,
    north-up) resampled onto ``lattice``'s cells covering its footprint; returns ``path``. ``mask``: a one-band
    byte raster on ``source``'s grid decimated by ``mask_scale`` (its cell ``fx, fy`` source pixels; 0 invalid,
    255 valid), the VRT's dataset mask (nearest), which GDAL's warper and masked reads honour like nodata."""
    vtype = _VRT_TYPES.get(str(info.dtype))
    if vtype is None:
        raise ValueError(f"no VRT data type for {info.dtype}")
    grid, width, height = covering_grid(info.transform, info.width, info.height, lattice)
    t = info.transform
    src = ((grid.c - t.c) / t.a, (grid.f - t.f) / t.e, width * grid.a / t.a, height * grid.e / t.e)
    nodata = info.nodata
    nd = "" if nodata is None else f"<NoDataValue>{nodata!r}</NoDataValue>"
    snd = "" if nodata is None else f"<NODATA>{nodata!r}</NODATA>"
    name = escape(str(source) if is_virtual_path(source) else str(Path(source).resolve()))
    bands = "".join(
        f'<VRTRasterBand dataType="{vtype}" band="{b}">{nd}<ComplexSource resampling="{resampling.upper()}">'
        f'<SourceFilename relativeToVRT="0">{name}</SourceFilename><SourceBand>{b}</SourceBand>'
        f'<SrcRect xOff="{src[0]!r}" yOff="{src[1]!r}" xSize="{src[2]!r}" ySize="{src[3]!r}"/>'
        f'<DstRect xOff="0" yOff="0" xSize="{width}" ySize="{height}"/>{snd}</ComplexSource></VRTRasterBand>'
        for b in range(1, info.count + 1))
    if mask is not None:
        fx, fy = mask_scale
        src = (src[0] / fx, src[1] / fy, src[2] / fx, src[3] / fy)
        bands += (f'<MaskBand><VRTRasterBand dataType="Byte"><ComplexSource resampling="NEAR">'
                  f'<SourceFilename relativeToVRT="0">{escape(str(Path(mask).resolve()))}</SourceFilename>'
                  f'<SourceBand>1</SourceBand><SrcRect xOff="{src[0]!r}" yOff="{src[1]!r}" xSize="{src[2]!r}" '
                  f'ySize="{src[3]!r}"/><DstRect xOff="0" yOff="0" xSize="{width}" ySize="{height}"/>'
                  f'</ComplexSource></VRTRasterBand></MaskBand>')
    srs = f"<SRS>{escape(info.crs.to_wkt())}</SRS>" if info.crs is not None else ""
    gt = ", ".join(repr(float(v)) for v in (grid.c, grid.a, 0.0, grid.f, 0.0, grid.e))
    path = Path(path)
    path.write_text(f'<VRTDataset rasterXSize="{width}" rasterYSize="{height}">{srs}<GeoTransform>{gt}'
                    f'</GeoTransform>{bands}</VRTDataset>\n', encoding="utf-8")
    return path
