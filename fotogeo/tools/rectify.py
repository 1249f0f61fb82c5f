"""Rectification of one image through a ground → image model onto a north-up map grid.

:func:`rectify_grid` chooses and checks the output grid before any pixel is resampled (so a bad
model or an oversized output stops a run before it writes anything); :func:`rectify_image` then
resamples the image onto it, window by window: each output cell's centre (X, Y), its height (a DEM,
a constant, or the control's mean height — 2-D models ignore it), the model's image position, the
pixel resampled there (:func:`fotogeo.io.warp.warp_to_grid`). Shared by ``orient`` (one image
through its GCP model) and ``triangulate`` (every frame of an adjusted block,
:mod:`fotogeo.tools.triangulate_ortho`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..errors import InputError, ModelError
from ..geometry.georeference import Georeference
from ..io.raster import read_dem
from ..io.warp import grid_covering, warp_to_grid
from .checks import check_output_grid


class RectifyGrid(NamedTuple):
    """The output grid of a rectification: the image's georeference, the grid's affine transform,
    its size in pixels and its resolution in map units."""
    geo: Georeference
    transform: object
    width: int
    height: int
    resolution: float


def rectify_grid(path, info, model, crs, ground, dem=None, height=None, resolution=None) -> RectifyGrid:
    """The georeference and the north-up grid in ``crs`` that rectifying the image ``info`` (an opened
    raster) through ``model`` (ground → image) writes to ``path``, checked before any pixel is resampled.

    Heights (3-D models; 2-D ones ignore them) come from ``dem``, else ``height``, else the mean
    height of ``ground`` (the control's X, Y, Z rows); the default resolution is the ground sample
    distance at the image centre at that mean height. A model that spreads the image over a ground
    area far larger than its pixels cover (64x, whatever the resolution) is refused as unstable; the
    grid's size is checked by :func:`~fotogeo.tools.checks.check_output_grid`.
    """
    zmean = mean_height(ground)
    heights = dem_heights(dem, crs) if dem is not None else (zmean if height is None else height)
    geo = Georeference(model, heights=heights, crs=crs)
    w, h = info.width, info.height
    XY = geo.footprint(w, h)
    if not np.isfinite(XY).all():
        raise ModelError("the model does not map the whole image footprint to the ground; rectify with another model")
    gsd = geo.with_heights(zmean).ground_sample_distance(w, h)
    span = XY.max(axis=0) - XY.min(axis=0)
    if not np.isfinite(gsd) or gsd <= 0 or span[0] * span[1] / gsd ** 2 > 64 * w * h:
        raise ModelError("the model spreads the image over a ground area far larger than its pixels cover: "
                         "it is unstable outside the GCPs; rectify with a simpler model or more spread GCPs")
    res = float(resolution or gsd)
    transform, width, height_px = grid_covering(XY, res)
    check_output_grid(path, width, height_px, bands=info.count, dtype=info.dtype, source_pixels=w * h,
                      resolution=res, what=f"the rectified raster {str(path)!r}")
    return RectifyGrid(geo, transform, width, height_px, res)


def rectify_image(path, info, crs, grid: RectifyGrid, resampling, progress) -> dict:
    """Resample the image ``info`` onto ``grid`` (from :func:`rectify_grid`) through its georeference into
    ``path`` (a GeoTIFF in ``crs``); the grid's size, resolution and transform and what was written."""
    geo, transform, width, height_px, res = grid
    written = warp_to_grid(info.path, path, geo.map_to_pixel, crs=crs, transform=transform, width=width,
                           height=height_px, resampling=resampling, progress=progress)
    return {"width": width, "height": height_px, "resolution": res, "transform": list(transform)[:6], **written}


def mean_height(ground):
    """Mean height (third column) of the ground points ``ground``, None when none has one.

    >>> mean_height(np.array([[0.0, 0.0, 10.0], [1.0, 1.0, np.nan], [2.0, 2.0, 20.0]]))
    15.0
    >>> mean_height(np.array([[0.0, 0.0, np.nan]])) is None
    True
    """
    z = np.asarray(ground, float)[:, 2]
    return float(np.nanmean(z)) if np.isfinite(z).any() else None


def dem_heights(dem, crs):
    """The DEM (path or :class:`~fotogeo.geometry.dem.Dem`) as a height source at points in ``crs``."""
    from pyproj import CRS

    from ..geometry.dem import Dem, DemSampler
    d = dem if isinstance(dem, Dem) else read_dem(dem)
    if d.crs is None:
        raise InputError(f"DEM {d.path!r} has no CRS; it cannot be matched to the GCPs (assign one with "
                         "gdal_edit.py -a_srs)")
    return d if CRS.from_user_input(d.crs) == crs else DemSampler(d, crs)
