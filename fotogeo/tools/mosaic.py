"""``fotogeo mosaic``: one orthophoto mosaic from many, with seamlines, feathering and balancing (issue 21).

``mosaic(orthos, output, seamlines=None)`` — the orthophotos must share a CRS and a pixel lattice (same pixel size,
origins a whole number of pixels apart: what ``fotogeo ortho`` writes at one ``--resolution``). Then:

1. **seam grid** — the mosaic's extent on a grid of at most :data:`SEAM_PIXELS` cells (every ``f``-th pixel):
   each orthophoto's valid mask, grey level (mean of its bands) and band values there (GDAL average);
2. **seamlines** (:mod:`fotogeo.mosaic.seams`) — Voronoi cells of the distance to each orthophoto's nadir point
   (``FOTOGEO_NADIR`` written by ``fotogeo ortho``; else the centre of its valid area), each shared boundary
   replaced by the least-cost path through the grey difference of the two orthophotos (with ``dsm``, cells on
   above-ground objects cost 1000 more: :func:`above_ground`);
3. **balancing** (:func:`fotogeo.mosaic.blend.balance`, unless ``balance=False``) — a gain and an offset per
   orthophoto and band from the overlaps' means and spreads;
4. **blending** (:func:`fotogeo.mosaic.blend.feather_weights`) — per output window of 512², each orthophoto's
   window read, its balanced values weighted by the feather ramp of width ``feather`` (map units; default 16
   pixels or two seam cells) across its seamline; memory is bounded by the seam grid and one window per image.

Outputs (all or nothing): ``output`` (tiled DEFLATE GeoTIFF with overviews) and the GeoPackage ``seamlines``
(default ``output`` with ``.gpkg``): layer ``seamlines`` (lines between two images: ``image_a``, ``image_b``) and
``regions`` (each image's part of the mosaic, with its gains and offsets).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.raster import AtomicOutputs, check_output, geotiff_profile, ropen
from ..io.warp import in_order
from ..mosaic.blend import balance as balance_band
from ..mosaic.blend import feather_weights, signed_distances
from ..mosaic.seams import seam_labels
from ..progress import as_progress
from ..options_products import MOSAIC
from .boundary import tool
from .checks import check_output_grid

#: cells of the seam grid (seamlines, balancing statistics, feather distances)
SEAM_PIXELS = 4_000_000
BLOCK = 512


def _lattice(infos, paths):
    """The common CRS, pixel size and the union grid ``(transform, width, height)``; mismatches refused."""
    from affine import Affine
    first = infos[0]
    res = (first.transform.a, first.transform.e)
    bounds = []
    for info, p in zip(infos, paths):
        t = info.transform
        if info.crs != first.crs:
            raise InputError(f"orthophoto {str(p)!r} is in another CRS than {str(paths[0])!r}; make every "
                             f"orthophoto in one CRS (fotogeo ortho --crs)")
        off = ((t.c - first.transform.c) / res[0], (t.f - first.transform.f) / res[1])
        if (t.a, t.e) != res or t.b or t.d or any(abs(o - round(o)) > 1e-6 for o in off):
            raise InputError(f"orthophoto {str(p)!r} is not on the pixel lattice of {str(paths[0])!r} (pixel size "
                             f"or origin); make them with one --resolution (fotogeo ortho aligns every grid)")
        if (info.count, info.dtype) != (first.count, first.dtype):
            raise InputError(f"orthophoto {str(p)!r} has {info.count} bands of {info.dtype}, {str(paths[0])!r} "
                             f"{first.count} of {first.dtype}; mosaic orthophotos of one kind")
        bounds.append((t.c, t.f + t.e * info.height, t.c + t.a * info.width, t.f))
    b = np.array(bounds)
    x0, y1 = b[:, 0].min(), b[:, 3].max()
    width = int(round((b[:, 2].max() - x0) / res[0]))
    height = int(round((y1 - b[:, 1].min()) / -res[1]))
    return first.crs, Affine(res[0], 0, x0, 0, res[1], y1), width, height


def _seam_grid(paths, transform, width, height, crs):
    """Per orthophoto on the seam grid: valid mask, band values (NaN off it), and the grid's transform."""
    from rasterio.warp import Resampling, reproject
    f = max(1, math.ceil(math.sqrt(width * height / SEAM_PIXELS)))
    w, h = math.ceil(width / f), math.ceil(height / f)
    t = transform * transform.scale(f)
    import rasterio
    values, valid = [], []
    for p in paths:
        with ropen(p) as ds:  # GDAL's warper reads the file in chunks: memory is the seam grid's
            v = np.full((ds.count, h, w), np.nan, np.float32)
            reproject(rasterio.band(ds, list(range(1, ds.count + 1))), v, dst_transform=t, dst_crs=crs,
                      resampling=Resampling.average, dst_nodata=np.nan)
        ok = np.isfinite(v).all(axis=0)
        values.append(np.where(ok, v, np.nan))
        valid.append(ok)
    return np.array(values), np.array(valid), t, f


#: above-ground objects: cells higher than the DSM's opening (the local ground) by more than this (m) ...
ABOVE_GROUND_M = 2.5
#: ... where the opening removes every object narrower than this (m)
OBJECT_SIZE_M = 40.0


def above_ground(dsm, t, shape, crs) -> np.ndarray:
    """Cells of the seam grid (``t``, ``shape``) on above-ground objects of the DSM: its highest value in the cell
    (GDAL max) above the grey opening of the DSM over :data:`OBJECT_SIZE_M` by more than :data:`ABOVE_GROUND_M`."""
    import rasterio
    from rasterio.warp import Resampling, reproject
    from scipy.ndimage import grey_opening
    z = np.full(shape, np.nan, np.float32)
    with ropen(dsm) as ds:
        if ds.crs is None:
            raise InputError(f"DSM {str(dsm)!r} has no CRS; assign one (gdal_edit.py -a_srs)")
        reproject(rasterio.band(ds, 1), z, dst_transform=t, dst_crs=crs, resampling=Resampling.max, dst_nodata=np.nan)
    size = max(3, int(round(OBJECT_SIZE_M / abs(t.a))) | 1)
    filled = np.where(np.isfinite(z), z, np.nanmin(z) if np.isfinite(z).any() else 0.0)
    ground = grey_opening(filled, size=(size, size))
    return np.isfinite(z) & (filled - ground > ABOVE_GROUND_M)


def _nadirs(paths, valid, t):
    out = []
    for p, ok in zip(paths, valid):
        with ropen(p) as ds:
            tag = ds.tags().get("FOTOGEO_NADIR")
        if tag:
            out.append([float(v) for v in tag.split()])
        else:  # the centre of the valid area
            r, c = np.nonzero(ok)
            out.append(list(t * (c.mean() + 0.5, r.mean() + 0.5)) if len(r) else [np.nan, np.nan])
    return np.array(out)


@dataclass(frozen=True)
class Blend:
    """What every output window needs (module docstring, step 4): the mosaic's grid, the gains and offsets, the
    signed distances on the seam grid (``factor`` output pixels per seam cell), the feather width, the output
    type and nodata, and each orthophoto's bounds."""
    transform: object
    gains: np.ndarray
    offsets: np.ndarray
    signed: np.ndarray
    factor: int
    feather: float
    dtype: str
    nodata: float
    bounds: tuple

    def window(self, handles, r0: int, c0: int, h: int, w: int) -> np.ndarray:
        """The blended ``(bands, h, w)`` window at ``(r0, c0)`` read through ``handles`` (one per orthophoto)."""
        import cv2
        from rasterio.windows import from_bounds
        f = self.factor
        mx = np.broadcast_to(((np.arange(c0, c0 + w) + 0.5) / f - 0.5).astype(np.float32), (h, w))
        my = np.broadcast_to(((np.arange(r0, r0 + h) + 0.5) / f - 0.5).astype(np.float32)[:, None], (h, w))
        mx, my = np.ascontiguousarray(mx), np.ascontiguousarray(my)  # seam-grid coordinates (centre convention)
        n = len(handles)
        vals, ok, sd = [None] * n, np.zeros((n, h, w), bool), np.full((n, h, w), -np.inf, np.float32)
        x0, y1 = self.transform * (c0, r0)
        x1, y0 = self.transform * (c0 + w, r0 + h)
        for i, ds in enumerate(handles):
            b = self.bounds[i]
            if b.left >= x1 or b.right <= x0 or b.bottom >= y1 or b.top <= y0:
                continue  # this orthophoto does not reach the window
            win = from_bounds(x0, y0, x1, y1, ds.transform).round_offsets().round_lengths()
            a = ds.read(window=win, boundless=True, masked=True)
            vals[i] = a.filled(0).astype(np.float32)
            ok[i] = ~np.ma.getmaskarray(a).all(axis=0)
            sd[i] = cv2.remap(self.signed[i], mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        wts = feather_weights(sd, ok, self.feather)
        out = np.zeros((len(self.gains[0]), h, w), np.float32)
        for i in range(n):
            if vals[i] is not None:
                out += wts[i] * (self.gains[i][:, None, None] * vals[i] + self.offsets[i][:, None, None])
        info = np.iinfo(self.dtype) if np.dtype(self.dtype).kind in "iu" else None
        if info is not None:
            out = np.clip(np.rint(out), info.min + (1 if self.nodata == info.min else 0), info.max)
        out[:, ~ok.any(axis=0)] = self.nodata
        return out.astype(self.dtype)


def blended_windows(paths, blend: Blend, blocks, threads: int):
    """Yield ``(block, window array)`` in order, computed by ``threads`` threads (each with its own handles on the
    orthophotos; reads, OpenCV and numpy release the GIL), at most two windows per thread in flight."""
    import threading

    import rasterio
    local, opened, lock = threading.local(), [], threading.Lock()

    def job(block):
        handles = getattr(local, "handles", None)
        if handles is None:
            handles = local.handles = [rasterio.open(p) for p in paths]
            with lock:
                opened.extend(handles)
        return blend.window(handles, *block)

    try:
        yield from in_order(job, blocks, threads, "fotogeo-mosaic")
    finally:
        for ds in opened:
            ds.close()


def _seam_layers(labels, t, names, gains, offsets):
    """The ``regions`` and ``seamlines`` layers of the label image."""
    import shapely
    from rasterio.features import shapes
    polys = {i: [] for i in range(len(names))}
    for geom, v in shapes(labels.astype(np.int32), mask=labels >= 0, transform=t):
        polys[int(v)].append(shapely.geometry.shape(geom))
    region = {i: shapely.union_all(p) if p else shapely.Polygon() for i, p in polys.items()}
    lines, a, b = [], [], []
    for i in region:
        for j in region:
            if i < j:
                line = shapely.line_merge(shapely.intersection(region[i].boundary, region[j].boundary))
                if not line.is_empty and line.length > 0:
                    lines.append(line)
                    a.append(names[i])
                    b.append(names[j])
    regions = {"geometry": np.array([region[i] for i in region], dtype=object), "image": np.array(names),
               "gains": np.array([json.dumps([round(float(g), 4) for g in gains[i]]) for i in region]),
               "offsets": np.array([json.dumps([round(float(o), 3) for o in offsets[i]]) for i in region])}
    seams = {"geometry": np.array(lines, dtype=object), "image_a": np.array(a, dtype=str),
             "image_b": np.array(b, dtype=str)}
    return {"seamlines": seams, "regions": regions}


@tool(MOSAIC)
def mosaic(orthos, output, *, seamlines=None, feather=None, balance: bool = True, dsm=None, overwrite: bool = False,
           progress=None) -> dict:
    """Mosaic ``orthos`` into ``output`` with seamlines written to ``seamlines`` (module docstring); GDAL's block
    cache bounded as in every fotogeo write (:func:`fotogeo.io.warp.write_env`)."""
    from ..io.warp import default_threads, write_env
    with write_env(default_threads(), 1):
        return _mosaic(orthos, output, seamlines, feather, balance, dsm, overwrite, progress)


def _mosaic(orthos, output, seamlines, feather, balance, dsm, overwrite, progress) -> dict:
    from ..io.raster import open_raster
    from ..io.vector import write_layers
    prog = as_progress(progress)
    paths = [str(p) for p in orthos]
    if len(paths) < 2:
        raise InputError("give at least two orthophotos to mosaic")
    output = Path(output)
    seamlines = Path(seamlines) if seamlines else output.with_suffix(".gpkg")
    for p, role in ((output, "mosaic"), (seamlines, "seamlines")):
        check_output(p, paths, overwrite, role)
    infos = [open_raster(p, "orthophoto") for p in paths]
    crs, transform, width, height = _lattice(infos, paths)
    first = infos[0]
    check_output_grid(output, width, height, bands=first.count, dtype=first.dtype,
                      source_pixels=sum(i.width * i.height for i in infos), what=f"the mosaic {str(output)!r}")
    values, valid, t, f = _seam_grid(paths, transform, width, height, crs)
    prog(0.2, "seam grid read")
    above = above_ground(dsm, t, valid.shape[1:], crs) if dsm is not None else None
    labels = seam_labels(valid, _nadirs(paths, valid, t), t, values.mean(axis=1), above=above)  # NaN off an image
    prog(0.4, "seamlines")
    n, bands = len(paths), first.count
    gains, offsets = np.ones((n, bands)), np.zeros((n, bands))
    if balance:
        for b in range(bands):
            gains[:, b], offsets[:, b] = balance_band(values[:, b], valid)
    signed = signed_distances(labels, n, abs(t.a))
    width_m = feather if feather is not None else max(16 * abs(transform.a), 2 * abs(t.a))
    nodata = first.nodata if first.nodata is not None else 0
    profile = geotiff_profile(width=width, height=height, count=bands, dtype=first.dtype, crs=crs,
                              transform=transform, nodata=nodata, predictor=True, zlevel=1)
    from rasterio.windows import Window

    from ..io.warp import default_threads
    from rasterio.coords import BoundingBox
    from rasterio.transform import array_bounds
    blend = Blend(transform, gains, offsets, signed, f, width_m, first.dtype, nodata,
                  tuple(BoundingBox(*array_bounds(i.height, i.width, i.transform)) for i in infos))
    blocks = [(r, c, min(BLOCK, height - r), min(BLOCK, width - c)) for r in range(0, height, BLOCK)
              for c in range(0, width, BLOCK)]
    with AtomicOutputs(overwrite) as out:
        tmp = out.temp(output)
        with ropen(tmp, "w", **profile) as dst:
            for k, ((r, c, h, w), arr) in enumerate(blended_windows(paths, blend, blocks, default_threads())):
                dst.write(arr, window=Window(c, r, w, h))
                prog(0.4 + 0.55 * (k + 1) / len(blocks), f"blending window {k + 1}/{len(blocks)}")
        from ..io.warp import add_overviews
        with ropen(tmp, "r+") as dst:
            add_overviews(dst, width, height, "bilinear")
        names = [Path(p).stem for p in paths]
        write_layers(out.temp(seamlines), _seam_layers(labels, t, names, gains, offsets), crs,
                     {"seamlines": "fotogeo mosaic seamlines (least-cost paths between Voronoi cells of nadir "
                                   "distance)", "regions": "fotogeo mosaic: each orthophoto's part, gains, offsets"})
        out.commit()
    prog(1.0, "done")
    return {"fotogeo": "mosaic", "output": str(output), "seamlines": str(seamlines), "width": width,
            "height": height, "seam_grid_factor": f, "feather_m": width_m, "images": names,
            "gains": gains.tolist(), "offsets": offsets.tolist(), "labels_transform": list(t)[:6],
            "cells_per_image": [int((labels == i).sum()) for i in range(n)]}
