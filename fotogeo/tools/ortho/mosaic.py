"""``fotogeo mosaic``: one orthophoto mosaic from many, with seamlines, feathering and balancing (issue 21).

``mosaic(orthos, output, seamlines=None)`` — the orthophotos must share a CRS. The mosaic's pixel lattice is the
finest pixel size among them with the origin of the first that has it; one on another lattice (pixel size, or an
origin a fraction of a pixel off) is read through a VRT that resamples it onto the lattice
(:func:`fotogeo.io.vrt.lattice_vrt`, bilinear). Then:

1. **seam grid** — the mosaic's extent on a grid of at most :data:`SEAM_PIXELS` cells (every ``f``-th pixel):
   each orthophoto's band values there (GDAL average; NaN off it), held over its own window of the grid only
   (:class:`fotogeo.mosaic.patches.Patch`), so the seam grid's memory follows the area covered, not the number of
   orthophotos;
2. **seamlines** (:mod:`fotogeo.mosaic.seams`) — Voronoi cells of the distance to each orthophoto's nadir point
   (``FOTOGEO_NADIR`` written by ``fotogeo ortho``; else the centre of its valid area), each shared boundary
   replaced by the least-cost path through the grey difference of the two orthophotos (with ``dsm``, cells on
   above-ground objects cost 1000 more: :func:`above_ground`); each pair is worked on over the intersection of
   the two windows only;
3. **balancing** (:func:`fotogeo.mosaic.blend.balance`, unless ``balance=False``) — a gain and an offset per
   orthophoto and band from the overlaps' means and spreads (a sparse least-squares problem, one row per overlap);
4. **blending** (:mod:`fotogeo.tools.ortho.mosaic_tiles`) — tiles of 4096² pixels, each a task (threads of this
   process, or Dask with ``scheduler``/``workers``: the mechanism of ``register-batch``,
   :mod:`fotogeo.tools.common.dask_cluster`) that writes its own GeoTIFF window by window (512²): each orthophoto
   reaching the window read, its balanced values weighted by the feather ramp of width ``feather`` (map units;
   default 16 pixels or two seam cells) across its seamline; the tiles placed in a VRT and copied to one
   Cloud-Optimised GeoTIFF with overviews. Memory: the seam grid (bounded) plus one window per orthophoto
   reaching it per task.

Outputs (all or nothing): ``output`` (COG, DEFLATE or ``compress``'s, overviews) and the GeoPackage ``seamlines``
(default ``output`` with ``.gpkg``): layer ``seamlines`` (lines between two images: ``image_a``, ``image_b``) and
``regions`` (each image's part of the mosaic, with its gains and offsets).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...io.output_checks import GEOTIFF_SUFFIXES, check_outputs
from ...io.raster import AtomicOutputs, geotiff_profile, ropen
from ...mosaic.blend import balance as balance_band
from ...mosaic.blend import overlap_statistics, signed_distance
from ...mosaic.patches import Patch, overlapping_pairs
from ...mosaic.seams import seam_labels
from ...progress import as_progress
from ...options.products import MOSAIC
from ..common.boundary import tool
from ..common.checks import check_output_grid
from ..common.dask_cluster import connect
from .mosaic_collar import collar_masks
from .mosaic_nodata import output_nodata
from .mosaic_tiles import Blend, write_tiled

#: cells of the seam grid (seamlines, balancing statistics, feather distances)
SEAM_PIXELS = 4_000_000


def _lattice(infos, paths):
    """The mosaic's CRS and pixel lattice: the finest pixel size among the orthophotos, with the origin of the
    first one that has it. Another CRS, a rotated grid or another band set is refused."""
    first = infos[0]
    for info, p in zip(infos, paths):
        if not info.georeferenced:
            raise InputError(f"orthophoto {str(p)!r} has no georeference (no CRS or geotransform); mosaic "
                             "orthophotos (fotogeo ortho or register writes them), or georeference it first")
        if info.crs != first.crs:
            raise InputError(f"orthophoto {str(p)!r} is in another CRS than {str(paths[0])!r}; make every "
                             f"orthophoto in one CRS (--crs of fotogeo ortho or register, or gdalwarp -t_srs)")
        if info.transform.b or info.transform.d:
            raise InputError(f"orthophoto {str(p)!r} has a rotated grid; make it north-up first "
                             f"(gdalwarp -t_srs with its own CRS)")
        if info.transform.e > 0 or info.transform.a < 0:
            raise InputError(f"orthophoto {str(p)!r} is stored south-up or east-left (a flipped grid); make it "
                             f"north-up first (gdalwarp -t_srs with its own CRS)")
        if (info.count, info.dtype) != (first.count, first.dtype):
            raise InputError(f"orthophoto {str(p)!r} has {info.count} bands of {info.dtype}, {str(paths[0])!r} "
                             f"{first.count} of {first.dtype}; mosaic orthophotos of one band set and data type "
                             "(gdal_translate -b to keep the same bands, -ot to convert)")
    finest = min(infos, key=lambda i: abs(i.transform.a * i.transform.e))
    return first.crs, finest.transform


def _union_grid(infos, lattice):
    """The grid ``(transform, width, height)`` of ``lattice`` covering every orthophoto (all on the lattice)."""
    from affine import Affine
    bounds = np.array([(i.transform.c, i.transform.f + i.transform.e * i.height,
                        i.transform.c + i.transform.a * i.width, i.transform.f) for i in infos])
    x0, y1 = bounds[:, 0].min(), bounds[:, 3].max()
    width = int(round((bounds[:, 2].max() - x0) / lattice.a))
    height = int(round((y1 - bounds[:, 1].min()) / -lattice.e))
    return Affine(lattice.a, 0, x0, 0, lattice.e, y1), width, height


def _onto_lattice(paths, infos, lattice, folder, masks=None):
    """Each orthophoto off ``lattice`` or with a collar mask (``masks``: index -> (mask raster, its cell in
    pixels), :func:`~.mosaic_collar.collar_masks`) replaced, for reading, by a VRT resampling it onto the lattice
    in ``folder`` (:func:`fotogeo.io.vrt.lattice_vrt`, the mask its dataset mask); returns the paths to read, their
    descriptions and the names resampled."""
    from ...io.raster import open_raster
    from ...io.vrt import lattice_vrt, on_lattice
    read, described, resampled, masks = list(paths), list(infos), [], masks or {}
    for i, (p, info) in enumerate(zip(paths, infos)):
        moved = not on_lattice(info.transform, lattice)
        if moved or i in masks:
            mask, scale = masks.get(i, (None, (1.0, 1.0)))
            read[i] = str(lattice_vrt(p, info, lattice, Path(folder) / f"{i}.vrt", mask=mask, mask_scale=scale))
            described[i] = open_raster(read[i], "orthophoto")
        if moved:
            resampled.append(Path(p).name)
    return read, described, resampled


def _seam_patches(paths, infos, transform, width, height, crs):
    """Each orthophoto on the seam grid over its own window (:class:`Patch`), the grid's transform, factor and
    shape."""
    import rasterio
    from rasterio.warp import Resampling, reproject
    f = max(1, math.ceil(math.sqrt(width * height / SEAM_PIXELS)))
    shape = (math.ceil(height / f), math.ceil(width / f))
    t = transform * transform.scale(f)
    patches = []
    for p, info in zip(paths, infos):
        c, r = (int(round(v)) for v in ~transform * (info.transform.c, info.transform.f))  # its offset (pixels)
        c0, r0 = c // f, r // f
        c1, r1 = min(shape[1], -(-(c + info.width) // f)), min(shape[0], -(-(r + info.height) // f))
        v = np.full((info.count, r1 - r0, c1 - c0), np.nan, np.float32)
        with ropen(p) as ds:  # GDAL's warper reads the file in chunks: memory is the patch's
            reproject(rasterio.band(ds, list(range(1, ds.count + 1))), v, dst_transform=t * t.translation(c0, r0),
                      dst_crs=crs, resampling=Resampling.average, dst_nodata=np.nan)
        v[:, ~np.isfinite(v).all(axis=0)] = np.nan
        patches.append(Patch(r0, c0, v))
    return patches, t, f, shape


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
    if not np.isfinite(z).any():
        raise InputError(f"DSM {str(dsm)!r} covers none of the mosaic (another area, or another CRS without its "
                         "own); give the DSM of the orthophotos' area, or no dsm", option="dsm")
    size = max(3, int(round(OBJECT_SIZE_M / abs(t.a))) | 1)
    filled = np.where(np.isfinite(z), z, np.nanmin(z) if np.isfinite(z).any() else 0.0)
    ground = grey_opening(filled, size=(size, size))
    return np.isfinite(z) & (filled - ground > ABOVE_GROUND_M)


def _nadirs(paths, patches, t):
    out = []
    for path, patch in zip(paths, patches):
        with ropen(path) as ds:
            tag = ds.tags().get("FOTOGEO_NADIR")
        if tag:
            out.append([float(v) for v in tag.split()])
        else:  # the centre of the valid area
            r, c = np.nonzero(patch.valid)
            out.append(list(t * (c.mean() + 0.5 + patch.c0, r.mean() + 0.5 + patch.r0)) if len(r) else [np.nan] * 2)
    return np.array(out)


def _seam_layers(labels, t, names, gains, offsets, pairs):
    """The ``regions`` and ``seamlines`` layers of the label image (a seamline per overlapping pair)."""
    import shapely
    from rasterio.features import shapes
    polys = {i: [] for i in range(len(names))}
    for geom, v in shapes(labels.astype(np.int32), mask=labels >= 0, transform=t):
        polys[int(v)].append(shapely.geometry.shape(geom))
    region = {i: shapely.union_all(p) if p else shapely.Polygon() for i, p in polys.items()}
    lines, a, b = [], [], []
    for i, j in pairs:
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
def mosaic(orthos, output, *, seamlines=None, feather=None, balance: bool = True, dsm=None, compress: str = "deflate",
           scheduler=None, workers=None, overwrite: bool = False, progress=None) -> dict:
    """Mosaic ``orthos`` into ``output`` with seamlines written to ``seamlines`` (module docstring); GDAL's block
    cache bounded as in every fotogeo write (:func:`fotogeo.io.warp.write_env`). The tiles run on Dask when
    ``scheduler`` (a running cluster) or ``workers`` (a local cluster of that many processes) is given, else in
    threads of this process. ``compress``: the mosaic's compression (:mod:`fotogeo.io.compression`)."""
    from ...io.compression import check_compression
    from ...io.warp import default_threads, write_env
    compress = check_compression(compress)
    client, end = (connect(None, scheduler, workers, "mosaic --scheduler/--workers") if scheduler or workers
                   else (None, lambda: None))
    ended = []

    def close():  # once: after the tiles (before the COG copy) or at the end, whichever comes first
        if not ended:
            ended.append(True)
            end()

    try:
        with write_env(default_threads(), 1):
            return _mosaic(orthos, output, seamlines, (feather, balance, dsm, compress), overwrite, progress, client,
                           close)
    finally:
        close()


def _balance(patches, pairs, bands: int, enabled: bool):
    n = len(patches)
    gains, offsets = np.ones((n, bands)), np.zeros((n, bands))
    if enabled:
        for b in range(bands):
            gains[:, b], offsets[:, b] = balance_band(overlap_statistics(patches, pairs, b), n)
    return gains, offsets


def _mosaic(orthos, output, seamlines, choices, overwrite, progress, client, release) -> dict:
    """The run of :func:`mosaic`; ``choices``: its ``(feather, balance, dsm, compress)``."""
    import tempfile

    from ...io.raster import open_raster
    prog = as_progress(progress)
    paths = [str(p) for p in orthos]
    if len(paths) < 2:
        raise InputError("give at least two orthophotos to mosaic")
    output = Path(output)
    seamlines = Path(seamlines) if seamlines else output.with_suffix(".gpkg")
    check_outputs(((output, "mosaic", GEOTIFF_SUFFIXES), (seamlines, "seamlines", (".gpkg",))), paths, overwrite)
    infos = [open_raster(p, "orthophoto") for p in paths]
    crs, lattice = _lattice(infos, paths)
    with tempfile.TemporaryDirectory(prefix="fotogeo-mosaic-") as folder:
        masks, collars = collar_masks(paths, infos, folder)
        read, infos, resampled = _onto_lattice(paths, infos, lattice, folder, masks)
        if resampled:
            prog(0.01, f"resampled onto the mosaic's pixel lattice ({abs(lattice.a):g} × {abs(lattice.e):g}): "
                       + ", ".join(resampled))
        result = _mosaic_on_lattice(paths, read, infos, crs, lattice, output, seamlines, choices, overwrite, prog,
                                    client, release)
    return {**result, "resampled_onto_lattice": resampled, "collars_taken_as_nodata": collars}


def _mosaic_on_lattice(paths, read, infos, crs, lattice, output, seamlines, choices, overwrite, prog, client,
                       release) -> dict:
    """The mosaic of orthophotos ``paths`` all on one pixel ``lattice``, their pixels read from ``read``."""
    feather, balance, dsm, compress = choices
    from rasterio.coords import BoundingBox
    from rasterio.transform import array_bounds

    from ...io.vector import write_layers
    transform, width, height = _union_grid(infos, lattice)
    first = infos[0]
    check_output_grid(output, width, height, bands=first.count, dtype=first.dtype,
                      source_pixels=sum(i.width * i.height for i in infos), what=f"the mosaic {str(output)!r}",
                      compress=compress)
    patches, t, f, shape = _seam_patches(read, infos, transform, width, height, crs)
    prog(0.2, "seam grid read")
    above = above_ground(dsm, t, shape, crs) if dsm is not None else None
    labels = seam_labels(patches, _nadirs(paths, patches, t), t, shape, above=above)
    prog(0.35, "seamlines")
    pairs = overlapping_pairs(patches)
    n, bands = len(paths), first.count
    gains, offsets = _balance(patches, pairs, bands, balance)
    signed = tuple(signed_distance(labels, i, p.window, abs(t.a)) for i, p in enumerate(patches))
    origins = tuple((p.r0, p.c0) for p in patches)
    del patches  # the blending needs the signed distances only
    width_m = feather if feather is not None else max(16 * abs(transform.a), 2 * abs(t.a))
    nodata, why = output_nodata(read, infos, prog.stage(0.35, 0.4, "choosing the nodata value"))
    profile = geotiff_profile(width=width, height=height, count=bands, dtype=first.dtype, crs=crs,
                              transform=transform, nodata=nodata, compress=compress)
    blend = Blend(transform, gains, offsets, signed, origins, f, width_m, first.dtype, nodata,
                  tuple(BoundingBox(*array_bounds(i.height, i.width, i.transform)) for i in infos))
    prog(0.4, "blending")
    with AtomicOutputs(overwrite) as out:
        tiled = write_tiled(read, blend, out.temp(output), profile, client=client, release=release, progress=prog,
                            span=(0.4, 0.97))
        names = [Path(p).stem for p in paths]
        write_layers(out.temp(seamlines), _seam_layers(labels, t, names, gains, offsets, pairs), crs,
                     {"seamlines": "fotogeo mosaic seamlines (least-cost paths between Voronoi cells of nadir "
                                   "distance)", "regions": "fotogeo mosaic: each orthophoto's part, gains, offsets"})
        out.commit()
    prog(1.0, "done")
    return {"fotogeo": "mosaic", "output": str(output), "seamlines": str(seamlines), "width": width,
            "height": height, "seam_grid_factor": f, "feather_m": width_m, "images": names,
            "gains": gains.tolist(), "offsets": offsets.tolist(), "labels_transform": list(t)[:6],
            "cells_per_image": np.bincount(labels[labels >= 0], minlength=n).tolist(), "overlapping_pairs": len(pairs),
            "nodata": None if nodata is None or nodata != nodata else nodata, "valid_area": why,
            "moved_off_nodata": tiled["moved_off_nodata"],
            "tiles": tiled["tiles"], "max_orthophotos_per_tile": tiled["max_orthophotos_per_tile"],
            "executor": "dask" if client is not None else "threads"}
