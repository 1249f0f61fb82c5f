"""The blending of ``fotogeo mosaic`` in tiles: each tile its own task and GeoTIFF, then a VRT → one COG.

:class:`Blend` holds what every output window needs (the seam grid's signed distances per orthophoto, over its
own window of the seam grid; gains, offsets, the feather width); :func:`blend_tile` — a module-level function
that opens its own files, so a thread of this process or a Dask worker runs it alike — writes one tile of
``TILE``² pixels window by window (``BLOCK``², only the orthophotos that reach the window read), and
:func:`write_tiled` runs the tiles on an executor (threads, or a ``dask.distributed.Client``: the tile folder
must then be on a file system every worker sees), places them in a VRT (:func:`fotogeo.io.warp_tiles.write_vrt`)
and copies that to a Cloud-Optimised GeoTIFF with overviews (:func:`fotogeo.io.warp_tiles.to_cog`). A task's
memory is one window per orthophoto reaching it plus GDAL's bounded block cache, whatever the mosaic's size.
"""
from __future__ import annotations

import concurrent.futures as cf
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import Cancelled
from ...io.warp import default_threads, windows_of, write_env
from ...io.warp_tiles import tile_windows, to_cog, write_vrt
from ...mosaic.blend import feather_weights

#: output pixels per tile task (a multiple of BLOCK) and per blended window
TILE, BLOCK = 4096, 512


@dataclass(frozen=True)
class Blend:
    """The mosaic's grid, gains and offsets ``(n, bands)``, each orthophoto's signed distances on the seam grid
    (``signed[i]`` over its window whose top-left cell is ``origins[i]``; ``factor`` output pixels per seam
    cell), the feather width, the output type and nodata (None: the valid area is the mosaic's mask band,
    :func:`fotogeo.tools.ortho.mosaic_nodata.output_nodata`), and each orthophoto's bounds."""
    transform: object
    gains: np.ndarray
    offsets: np.ndarray
    signed: tuple
    origins: tuple
    factor: int
    feather: float
    dtype: str
    nodata: float | None
    bounds: tuple

    def reaching(self, r0: int, c0: int, h: int, w: int) -> list[int]:
        """The orthophotos whose bounds reach the output window."""
        x0, y1 = self.transform * (c0, r0)
        x1, y0 = self.transform * (c0 + w, r0 + h)
        return [i for i, b in enumerate(self.bounds) if b.left < x1 and b.right > x0 and b.bottom < y1 and
                b.top > y0]

    def window(self, handle, r0: int, c0: int, h: int, w: int) -> tuple:
        """``(values, valid, moved)``: the blended ``(bands, h, w)`` window at ``(r0, c0)``, its valid cells ``(h, w)``
        and the count of band values moved off the nodata (:func:`off_nodata`: a valid cell never holds it);
        ``handle(i)`` opens orthophoto ``i``."""
        import cv2
        f = self.factor
        mx = ((np.arange(c0, c0 + w) + 0.5) / f - 0.5).astype(np.float32)  # seam-grid coordinates (centres)
        my = ((np.arange(r0, r0 + h) + 0.5) / f - 0.5).astype(np.float32)
        x0, y1 = self.transform * (c0, r0)
        which = self.reaching(r0, c0, h, w)
        vals, ok, sd = [], np.zeros((len(which), h, w), bool), np.empty((len(which), h, w), np.float32)
        for k, i in enumerate(which):
            v, ok[k] = read_window(handle(i), x0, y1, h, w)
            vals.append(v)
            sr, sc = self.origins[i]
            px = np.ascontiguousarray(np.broadcast_to(mx - sc, (h, w)))
            py = np.ascontiguousarray(np.broadcast_to((my - sr)[:, None], (h, w)))
            sd[k] = cv2.remap(self.signed[i], px, py, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        out = np.zeros((self.gains.shape[1], h, w), np.float32)
        if which:
            wts = feather_weights(sd, ok, self.feather)
            for k, i in enumerate(which):
                out += wts[k] * (self.gains[i][:, None, None] * vals[k] + self.offsets[i][:, None, None])
        if np.dtype(self.dtype).kind in "iu":
            info = np.iinfo(self.dtype)
            out = np.clip(np.rint(out), info.min, info.max)
        valid = ok.any(axis=0)
        out = out.astype(self.dtype)
        moved = 0
        if self.nodata is not None:
            moved = off_nodata(out, valid, self.nodata)
            out[:, ~valid] = self.nodata
        else:
            out[:, ~valid] = 0
        return out, valid, moved


def off_nodata(out, valid, nodata) -> int:
    """Move the band values of the valid cells of ``out`` ``(bands, h, w)`` that equal ``nodata`` (GDAL's nodata is
    per band) one step away from it, within the type's range, so that they do not read as nodata; returns their
    count. Only a blend or a balancing produces them: an orthophoto's band value at its nodata is nodata there."""
    nd = out.dtype.type(nodata)
    hit = valid[None] & (out == nd)
    n = int(np.count_nonzero(hit))
    if n:
        if out.dtype.kind in "iu":
            moved = nd - 1 if nd == np.iinfo(out.dtype).max else nd + 1
        else:
            moved = np.nextafter(nd, out.dtype.type(0))
        out[hit] = moved
    return n


def read_window(ds, x0: float, y1: float, h: int, w: int):
    """``(values (bands, h, w) float32, valid (h, w))`` of the ``h x w`` window of ``ds`` whose top-left corner
    is the map point ``(x0, y1)`` (on ``ds``'s pixel lattice); only the part inside ``ds`` is read (a boundless
    read would go through a VRT)."""
    from rasterio.windows import Window
    t = ds.transform
    c_off, r_off = int(round((x0 - t.c) / t.a)), int(round((y1 - t.f) / t.e))
    vals, ok = np.zeros((ds.count, h, w), np.float32), np.zeros((h, w), bool)
    a0, a1, b0, b1 = max(0, r_off), min(ds.height, r_off + h), max(0, c_off), min(ds.width, c_off + w)
    if a0 < a1 and b0 < b1:
        a = ds.read(window=Window(b0, a0, b1 - b0, a1 - a0), masked=True)
        rows, cols = slice(a0 - r_off, a1 - r_off), slice(b0 - c_off, b1 - c_off)
        vals[:, rows, cols] = a.filled(0)
        ok[rows, cols] = ~np.ma.getmaskarray(a).all(axis=0)
    return vals, ok


def tile_profile(profile: dict, h: int, w: int, transform) -> dict:
    """A tile's GeoTIFF: the mosaic's profile at the tile's size and place, ZSTD level 1 (written once, read once
    by the COG copy: speed over size)."""
    p = {k: v for k, v in profile.items() if k not in ("predictor", "zlevel", "compress")}
    return {**p, "width": w, "height": h, "transform": transform, "compress": "zstd", "zstd_level": 1}


def blend_tile(paths, blend: Blend, tile_path, window, profile: dict, pin: bool = False) -> dict:
    """Write the ``window = (r0, c0, h, w)`` of the mosaic into the GeoTIFF ``tile_path`` (the Dask or thread
    task); ``pin``: one thread for GDAL, OpenCV and BLAS (on a Dask worker)."""
    import rasterio
    from rasterio.windows import Window
    if pin:
        from ..common.dask_cluster import pin_threads
        pin_threads()
    r0, c0, h, w = window
    opened, moved = {}, 0

    def handle(i):
        if i not in opened:
            opened[i] = rasterio.open(paths[i])
        return opened[i]

    t = blend.transform * blend.transform.translation(c0, r0)
    try:
        with write_env(1), rasterio.Env(GDAL_TIFF_INTERNAL_MASK=True), \
                rasterio.open(tile_path, "w", **tile_profile(profile, h, w, t)) as dst:
            for br, bc, bh, bw in windows_of(r0 + h, c0 + w, BLOCK, r0, c0, h, w):
                values, valid, n = blend.window(handle, br, bc, bh, bw)
                moved += n
                win = Window(bc - c0, br - r0, bw, bh)
                dst.write(values, window=win)
                if blend.nodata is None:
                    dst.write_mask(np.where(valid, 255, 0).astype(np.uint8), window=win)
    finally:
        for ds in opened.values():
            ds.close()
    return {"path": str(tile_path), "window": list(window), "orthophotos": len(opened), "moved_off_nodata": moved}


def _completed(futures, client):
    if client is None:
        return cf.as_completed(futures)
    from ..common.dask_cluster import distributed_module
    return distributed_module("mosaic on Dask").as_completed(futures)


def write_tiled(paths, blend: Blend, dst_path, profile: dict, *, client=None, release=None, progress=None,
                span=(0.0, 1.0)) -> dict:
    """The mosaic ``dst_path`` (a COG) from tiles blended on ``client`` (a ``dask.distributed.Client``; None:
    threads of this process), assembled by a VRT; the tiles' folder (beside ``dst_path``) removed at the end.
    ``release()`` is called once the tiles are written, before the COG copy (e.g. to end a local Dask cluster,
    whose idle workers would otherwise hold their memory while this process copies)."""
    dst_path = Path(dst_path)
    folder = Path(tempfile.mkdtemp(prefix=f".{dst_path.stem}.tiles.", dir=dst_path.parent))
    tiles = tile_windows(profile["height"], profile["width"], TILE)
    pool = cf.ThreadPoolExecutor(default_threads(), thread_name_prefix="fotogeo-mosaic") if client is None else None
    futures = []
    lo, hi = span
    try:
        shared = client.scatter(blend, broadcast=True) if client is not None else blend
        submit = client.submit if client is not None else pool.submit
        extra = {"pure": False} if client is not None else {}
        futures = [submit(blend_tile, list(paths), shared, str(folder / f"tile_{r0:06d}_{c0:06d}.tif"),
                          (r0, c0, h, w), profile, client is not None, **extra) for r0, c0, h, w in tiles]
        done = []
        for k, fut in enumerate(_completed(futures, client)):
            done.append(fut.result())
            if progress is not None:
                progress(lo + (hi - lo) * 0.8 * (k + 1) / len(futures), f"blended tile {k + 1}/{len(futures)}")
        done.sort(key=lambda d: d["window"])
        futures = []
        if release is not None:
            release()
        vrt = write_vrt(folder / "tiles.vrt", [(d["path"], tuple(d["window"])) for d in done], crs=profile["crs"],
                        transform=profile["transform"], width=profile["width"], height=profile["height"],
                        count=profile["count"], dtype=profile["dtype"], nodata=profile["nodata"],
                        mask=profile["nodata"] is None)
        if progress is not None:
            progress(lo + (hi - lo) * 0.8, "assembling the tiles into a cloud-optimised GeoTIFF")
        to_cog(vrt, dst_path, resampling="average", threads=default_threads(), compress=profile["compress"])
    except (Cancelled, KeyboardInterrupt):
        for fut in futures:
            fut.cancel()
        raise
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
        shutil.rmtree(folder, ignore_errors=True)
    return {"tiles": len(tiles), "max_orthophotos_per_tile": max((d["orthophotos"] for d in done), default=0),
            "moved_off_nodata": sum(d["moved_off_nodata"] for d in done)}

