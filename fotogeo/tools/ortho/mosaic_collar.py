"""The collars of a mosaic's orthophotos stored without nodata (:mod:`fotogeo.mosaic.collar`), read with bounded
memory: the four one-pixel border strips first (a file whose border holds no cell equal to 0 — or the type's
maximum — in every band has no collar and is not read further), then, where a collar is possible, the file
decimated to at most :data:`MAX_COLLAR_PIXELS` cells (:func:`fotogeo.io.raster.read_decimated`; average, so a
decimated cell is collar only when every pixel under it is). The collar mask is written on that decimated grid
and read through the orthophoto's VRT with nearest resampling (:func:`fotogeo.io.vrt.lattice_vrt`). A decimated
mask is grown by one cell: the cells under the collar's edge (part collar, part data) become nodata, so that no
collar pixel is blended into the mosaic as black; up to one decimated cell of data along the edge is given up
(covered by a neighbour where the orthophotos overlap)."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

#: the most cells of one orthophoto labelled for its collar (larger files are read decimated)
MAX_COLLAR_PIXELS = 4_000_000


def collar_masks(paths, infos, folder) -> tuple[dict, dict]:
    """``({index: (mask raster, (fx, fy))}, {name: {value, share}})`` of the orthophotos without nodata, mask or
    alpha whose border carries a constant collar (:func:`fotogeo.mosaic.collar.border_collar`): the collar
    becomes nodata through a mask raster in ``folder`` (0 collar, 255 data; ``fx, fy`` its cells in the
    orthophoto's pixels), with a note naming the file and the fix."""
    from rasterio.enums import MaskFlags
    from rasterio.windows import Window

    from ...errors import InputNote
    from ...io.raster import geotiff_profile, read_decimated, ropen
    from ...mosaic.collar import border_collar, border_values, collar_values
    masks, found = {}, {}
    for i, (p, info) in enumerate(zip(paths, infos)):
        if info.nodata is not None:
            continue
        with ropen(p) as ds:
            if any(flags != [MaskFlags.all_valid] for flags in ds.mask_flag_enums):
                continue  # its own mask or alpha band says what is data
            w, h = ds.width, ds.height
            edges = [ds.read(window=win) for win in (Window(0, 0, w, 1), Window(0, h - 1, w, 1),
                                                      Window(0, 0, 1, h), Window(w - 1, 0, 1, h))]
            crs, transform = ds.crs, ds.transform
        values = border_values(edges, collar_values(info.dtype))
        if not values:
            continue
        bands, _, (fx, fy) = read_decimated(info, MAX_COLLAR_PIXELS, "orthophoto")
        mask, value = border_collar(bands, values)
        del bands
        if mask is None:
            continue
        if fx > 1 or fy > 1:  # the cells under the collar's edge, part collar: nodata, never blended as black
            from scipy import ndimage
            mask = ndimage.binary_dilation(mask, np.ones((3, 3), bool))
        masks[i] = (Path(folder) / f"{i}_collar.tif", (fx, fy))
        with ropen(masks[i][0], "w", **geotiff_profile(width=mask.shape[1], height=mask.shape[0], count=1,
                                                       dtype="uint8", crs=crs,
                                                       transform=transform * transform.scale(fx, fy))) as out:
            out.write(np.where(mask, 0, 255).astype(np.uint8)[None])
        found[Path(p).name] = {"value": int(value), "share": round(float(mask.mean()), 4)}
        warnings.warn(f"orthophoto {str(p)!r} has no nodata value and a border of {value} in every band "
                      f"({mask.mean():.1%} of its pixels): taken as nodata; tag it (gdal_edit -a_nodata {value} "
                      f"{Path(p).name}) to have it read so without this check", InputNote, stacklevel=3)
    return masks, found
