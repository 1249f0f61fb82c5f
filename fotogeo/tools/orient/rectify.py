"""Rectification of one image through a ground → image model onto a north-up map grid.

:func:`rectify_grid` chooses and checks the output grid before any pixel is resampled (so a bad
model or an oversized output stops a run before it writes anything); :func:`rectify_image` then
resamples the image onto it, window by window: each output cell's centre (X, Y), its height (a DEM,
a constant, or the control's mean height — 2-D models ignore it), the model's image position, the
pixel resampled there (:func:`fotogeo.io.warp.warp_to_grid`). Used by ``orient`` (one image
through its GCP model, also the GCP picker's *Rectify*); ``triangulate`` orthorectifies its frames as
``fotogeo ortho`` does (:mod:`fotogeo.tools.triangulate.ortho`).

:func:`check_terrain_heights` is the one check of the heights an image is put on the ground with
(orient, triangulate and ``register --dem``): a 3-D model only knows the heights of its control, so
heights far outside their range, or above the camera's projection centre, give an orthophoto that
looks normal and is wrong (issue 24: a DEM 5000 m too high, correlation −0.20 with the right one).
"""
from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np

from ...errors import FotogeoWarning, InputError, ModelError
from ...geometry.dem import heights_at
from ...geometry.georeference import Georeference
from ...io.raster import read_dem
from ...io.warp import grid_covering, warp_to_grid
from ..common.checks import check_output_grid


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
    grid's size is checked by :func:`~fotogeo.tools.common.checks.check_output_grid`.
    """
    zmean = mean_height(ground)
    heights = dem_heights(dem, crs) if dem is not None else (zmean if height is None else height)
    geo = Georeference(model, heights=heights, crs=crs)
    w, h = info.width, info.height
    where = f"the DEM {str(getattr(dem, 'path', dem))!r}" if dem is not None else f"the height {height}"
    check_terrain_heights(geo, w, h, np.asarray(ground, float)[:, 2], where, "the GCPs")
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

    from ...geometry.dem import Dem, DemSampler
    d = dem if isinstance(dem, Dem) else read_dem(dem)
    if d.crs is None:
        raise InputError(f"DEM {d.path!r} has no CRS; it cannot be matched to the GCPs (assign one with "
                         "gdal_edit.py -a_srs)")
    return d if CRS.from_user_input(d.crs) == crs else DemSampler(d, crs)


#: heights this far outside the control's height range count as unseen: the range itself, at least this
#: share of the image's ground extent (a 3-D model extrapolates a little in height, never by kilometres)
UNSEEN_MARGIN = 0.05
#: image pixels sampled per axis to find the heights under the image
HEIGHT_SAMPLES = 17


def check_terrain_heights(geo: Georeference, width: int, height: int, seen_z, what: str, control: str) -> None:
    """Refuse terrain heights a 3-D model cannot map (see the module docstring); warn when part of them is.

    ``geo`` carries the model and the heights (a DEM or a number); ``seen_z`` the heights of the points the
    model was fitted to (``control`` names them, ``what`` names the heights in messages). The heights under
    a grid of the image placed at the control's median height are compared with the projection centre of
    models that have one (DLT, collinearity, adjusted frames) — any height at or above it is refused — and
    with the control's range widened by :data:`UNSEEN_MARGIN`: refused when most are outside, a
    :class:`FotogeoWarning` when some are. 2-D models (heights ignored) pass.
    """
    seen = np.asarray(seen_z, float)
    seen = seen[np.isfinite(seen)]
    if getattr(geo.model, "src_dims", 2) != 3 or geo.heights is None or not len(seen):
        return
    z_mid = float(np.median(seen))
    cols, rows = np.meshgrid(np.linspace(0.5, width - 0.5, HEIGHT_SAMPLES),
                             np.linspace(0.5, height - 0.5, HEIGHT_SAMPLES))
    XY = geo.with_heights(z_mid).pixel_to_map(np.column_stack([cols.ravel(), rows.ravel()]))
    XY = XY[np.isfinite(XY).all(axis=1)]
    z = heights_at(geo.heights, XY) if len(XY) else np.empty(0)
    z = np.broadcast_to(z, (len(XY),))[np.isfinite(np.broadcast_to(z, (len(XY),)))]
    if not len(z):
        return  # the DEM does not cover the image: the footprint check says so
    _refuse_above_centre(geo.model, z, float(seen.max()), what)
    extent = float(np.hypot(*(XY.max(axis=0) - XY.min(axis=0))))
    margin = max(float(np.ptp(seen)), UNSEEN_MARGIN * extent)
    low, high = float(seen.min()) - margin, float(seen.max()) + margin
    outside = (z < low) | (z > high)
    if not outside.any():
        return
    text = (f"{what} gives heights {z.min():.1f}..{z.max():.1f} under the image; the model has only seen "
            f"{seen.min():.1f}..{seen.max():.1f} ({control})")
    fix = ("check the DEM's height unit and reference (ellipsoid or geoid), that it is this area's DEM, "
           "or give control points that span the terrain")
    if np.median(z) < low or np.median(z) > high:
        raise InputError(f"{text}: the model cannot place the image on heights it never saw; {fix}")
    warnings.warn(f"{text}: on {outside.mean():.0%} of the image the rectified pixels are extrapolated "
                  f"beyond {low:.0f}..{high:.0f}; {fix}", FotogeoWarning, stacklevel=2)


def _refuse_above_centre(model, z, seen_top: float, what: str) -> None:
    centre = getattr(model, "projection_centre", None)
    if centre is None or not np.isfinite(centre[2]) or centre[2] <= seen_top:
        return  # no centre, or one the control itself is not below: nothing the model has seen to compare
    if z.max() >= centre[2]:
        raise InputError(f"{what} reaches {z.max():.1f} under the image, at or above the camera's projection "
                         f"centre (height {centre[2]:.1f}): no camera sees ground above itself; check the DEM's "
                         f"height unit and reference, or that it is this area's DEM")
