"""Large rasters across workers: the output grid in tiles, each resampled by its own task into its
own GeoTIFF, then assembled (a VRT of the tiles → one Cloud-Optimised GeoTIFF with overviews).

A tile task (:func:`warp_tile`) is a module-level function that opens its own files, so it
runs in a thread of this process or on a Dask worker alike: ``executor`` is anything with
``submit(fn, *args) -> future`` and ``future.result()`` — a
:class:`concurrent.futures.ThreadPoolExecutor` (the default, one thread per CPU) or a
``dask.distributed.Client`` (the tile folder must then be on a file system every worker sees).
Each task holds one resampling window (``block``² pixels, ``threads_per_tile`` of them in flight)
and the GDAL block cache, so the peak memory per worker is bounded by the block size, not by the
raster. Tile edges fall on block edges: every window is the one :func:`~fotogeo.io.warp.warp_to_grid`
computes at that position, so the assembled raster is pixel-identical to a one-process warp.
"""
from __future__ import annotations

import concurrent.futures as cf
import math
import os
import shutil
import tempfile
from pathlib import Path
from xml.sax.saxutils import escape

from rasterio.shutil import copy as rio_copy

from ..progress import Progress
from .compression import cog_options
from .warp import default_threads, make_plan, windows_of, write_env, write_windows
from .raster import GEOTIFF_BLOCK, ropen

#: GDAL's name of each numpy data type a fotogeo raster may have
GDAL_TYPES = {"uint8": "Byte", "int8": "Int8", "uint16": "UInt16", "int16": "Int16", "uint32": "UInt32",
              "int32": "Int32", "float32": "Float32", "float64": "Float64"}


def tile_windows(height: int, width: int, tile: int) -> list[tuple[int, int, int, int]]:
    """``(r0, c0, h, w)`` of the ``tile``-sized tiles of a ``height x width`` grid, row by row.

    >>> tile_windows(5, 7, 4)
    [(0, 0, 4, 4), (0, 4, 4, 3), (4, 0, 1, 4), (4, 4, 1, 3)]
    """
    return windows_of(height, width, tile)


def warp_tile(src_path, tile_path, plan, crs, window, block: int, threads: int = 1) -> dict:
    """Resample the ``window = (r0, c0, h, w)`` of ``plan``'s grid into the GeoTIFF ``tile_path``
    (no overviews); its summary (:func:`~fotogeo.io.warp.write_windows`) with the window."""
    r0, c0, h, w = window
    with ropen(src_path) as src:
        colorinterp = src.colorinterp
    summary = write_windows(src_path, tile_path, plan, windows_of(r0 + h, c0 + w, block, r0, c0, h, w), crs=crs,
                            width=w, height=h, threads=threads, colorinterp=colorinterp, offset=(r0, c0))
    return {**summary, "window": list(window), "path": str(tile_path)}


def write_vrt(path, tiles, *, crs, transform, width: int, height: int, count: int, dtype: str, nodata,
              colorinterp=(), mask: bool = False) -> Path:
    """A GDAL VRT placing each tile ``(tile_path, (r0, c0, h, w))`` at its window of the grid; with ``mask``, the
    tiles' per-dataset mask bands too (the VRT's ``MaskBand``, which the COG copy writes as an internal mask)."""
    path = Path(path)
    wkt = crs.to_wkt() if hasattr(crs, "to_wkt") else str(crs)
    gt = ", ".join(repr(float(v)) for v in (transform.c, transform.a, transform.b, transform.f, transform.d,
                                            transform.e))
    nd = "" if nodata is None else f"    <NoDataValue>{'nan' if nodata != nodata else repr(nodata)}</NoDataValue>\n"
    lines = [f'<VRTDataset rasterXSize="{width}" rasterYSize="{height}">',
             f'  <SRS dataAxisToSRSAxisMapping="1,2">{escape(wkt)}</SRS>', f"  <GeoTransform>{gt}</GeoTransform>"]
    for b in range(1, count + 1):
        ci = colorinterp[b - 1].name.capitalize() if len(colorinterp) >= b else "Undefined"
        lines.append(f'  <VRTRasterBand dataType="{GDAL_TYPES[str(dtype)]}" band="{b}">\n{nd}'
                     f"    <ColorInterp>{ci}</ColorInterp>")
        for tile_path, (r0, c0, h, w) in tiles:
            rel = os.path.relpath(tile_path, path.parent)
            lines.append(f'    <SimpleSource><SourceFilename relativeToVRT="1">{escape(rel)}</SourceFilename>'
                         f'<SourceBand>{b}</SourceBand><SrcRect xOff="0" yOff="0" xSize="{w}" ySize="{h}"/>'
                         f'<DstRect xOff="{c0}" yOff="{r0}" xSize="{w}" ySize="{h}"/></SimpleSource>')
        lines.append("  </VRTRasterBand>")
    if mask:
        lines.append('  <MaskBand><VRTRasterBand dataType="Byte">')
        lines += [f'    <SimpleSource><SourceFilename relativeToVRT="1">{escape(os.path.relpath(p, path.parent))}'
                  f'</SourceFilename><SourceBand>mask,1</SourceBand><SrcRect xOff="0" yOff="0" xSize="{w}" '
                  f'ySize="{h}"/><DstRect xOff="{c0}" yOff="{r0}" xSize="{w}" ySize="{h}"/></SimpleSource>'
                  for p, (r0, c0, h, w) in tiles]
        lines.append("  </VRTRasterBand></MaskBand>")
    lines.append("</VRTDataset>\n")
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def to_cog(vrt, dst_path, *, resampling: str, threads: int, compress: str = "deflate") -> None:
    """Copy ``vrt`` to a Cloud-Optimised GeoTIFF: ``compress`` (:func:`~fotogeo.io.compression.cog_options`:
    DEFLATE unless asked) with the data type's predictor, 256² tiles, overviews (nearest for nearest-neighbour
    outputs, else average), ``threads`` compressing."""
    with write_env(threads):
        rio_copy(str(vrt), str(dst_path), driver="COG", blocksize=GEOTIFF_BLOCK, bigtiff="IF_SAFER",
                 num_threads=str(threads), overview_resampling="NEAREST" if resampling == "nearest" else "AVERAGE",
                 **cog_options(compress))


def warp_tiled(src_path, dst_path, inverse_map, *, crs, transform, width: int, height: int,
               resampling: str = "nearest", nodata=None, src_nodata=None, tile: int = 4096, block: int = 512,
               executor=None, tile_dir=None, threads_per_tile: int = 1, progress: Progress | None = None) -> dict:
    """:func:`~fotogeo.io.warp.warp_to_grid` for grids too large for one process: tiles of ``tile``²
    pixels (rounded up to a multiple of ``block``) are resampled in parallel by ``executor``
    (default: one thread per CPU) into ``tile_dir`` (default: a hidden folder beside
    ``dst_path``, removed at the end), then assembled into the COG ``dst_path``.

    ``inverse_map`` must be picklable when ``executor`` runs in other processes (a Dask
    cluster): a :class:`~fotogeo.geometry.georeference.Georeference` method is. Returns the
    summary of ``warp_to_grid`` plus ``tiles`` (their count).
    """
    progress = progress or Progress()
    block = int(block)
    tile = int(math.ceil(max(tile, block) / block) * block)
    with ropen(src_path) as src:
        plan = make_plan(src, inverse_map, transform, resampling, nodata, src_nodata)
        colorinterp = src.colorinterp
    dst_path = Path(dst_path)
    own_dir = tile_dir is None
    folder = Path(tempfile.mkdtemp(prefix=f".{dst_path.stem}.tiles.", dir=dst_path.parent)) if own_dir \
        else Path(tile_dir)
    own_pool = executor is None
    pool = cf.ThreadPoolExecutor(default_threads(), thread_name_prefix="fotogeo-tile") if own_pool else executor
    tiles = tile_windows(height, width, tile)
    try:
        futures = [pool.submit(warp_tile, str(src_path), str(folder / f"tile_{r0:06d}_{c0:06d}.tif"), plan, crs,
                               (r0, c0, h, w), block, threads_per_tile) for r0, c0, h, w in tiles]
        done = []
        for k, fut in enumerate(futures):
            done.append(fut.result())
            progress(0.8 * (k + 1) / len(futures), f"resampled tile {k + 1}/{len(futures)}")
        vrt = write_vrt(folder / "tiles.vrt", [(d["path"], tuple(d["window"])) for d in done], crs=crs,
                        transform=transform, width=width, height=height, count=plan.count, dtype=plan.dtype,
                        nodata=plan.nodata, colorinterp=colorinterp)
        progress(0.8, "assembling the tiles into a cloud-optimised GeoTIFF")
        to_cog(vrt, dst_path, resampling=resampling, threads=default_threads())
    finally:
        if own_pool:
            pool.shutdown(wait=True, cancel_futures=True)
        if own_dir:
            shutil.rmtree(folder, ignore_errors=True)
    progress(1.0, "resampled")
    nd = plan.nodata
    return {"valid_pixels": sum(d["valid_pixels"] for d in done), "nodata": None if nd != nd else nd,
            "nodata_collisions": sum(d["nodata_collisions"] for d in done), "tiles": len(done)}
