"""``fotogeo ortho``: orthorectify images whose orientation is known onto a DEM (issue 21).

``ortho(images, output, dem=..., camera=..., eo=... | rpc=True)`` — each image's ground → image model and
the heights come from :mod:`fotogeo.tools.ortho.inputs`; then, per image:

1. **grid** (:func:`plan_grid`): the image outline (33 points per edge) intersected with the DEM gives the
   footprint; where the DEM does not reach, the outline on the planes of the DEM's lowest and highest
   heights clipped to the DEM's extent. The grid is north-up in the map CRS, its edges multiples of the
   resolution (``gdalwarp -tap``; orthority's ``--aligned-pixels``), the resolution the image's ground
   sample distance at its centre unless given; its size is checked before anything is written. The share
   of a 41 x 41 grid of image pixels whose rays reach the DEM is the image's **DEM coverage**: 0 is refused,
   below 100 % the orthophoto is clipped to the DEM and the coverage is named in a warning;
2. **resampling** (:func:`fotogeo.io.warp.warp_to_grid`, window by window in threads, memory bounded by the
   block size): each output cell centre ``(X, Y)`` → ``Z = DEM(X, Y)`` (bilinear) → pixel = model(X, Y, Z)
   (:class:`OrthoMapping`; ``error_threshold`` > 0: a frame's positions interpolated on a checked lattice, like
   ``gdalwarp -et``) → nearest / bilinear / cubic; cells without a height or outside the image are nodata.
   With ``occlusion`` the cell's line of sight is traced through the same surface
   (:mod:`fotogeo.geometry.occlusion`): a hidden ground cell is nodata instead of a copy of whatever hides it
   (the "double image" of a building on a DSM).

Frames can also come from a fitted ``orient`` model (``model``: orient's JSON report, one image). With
``uncertainty`` and ``view_bands`` each orthophoto gets rasters beside it on its grid: the predicted planimetric σ
of every cell and its view geometry (:mod:`fotogeo.tools.ortho.products`).

Outputs: one GeoTIFF per image (tiled, DEFLATE or ``compress``'s, internal overviews; ``cog``: GDAL's COG
layout), ``output`` itself for one image, ``<output>/<name>_ortho.tif`` for several; written through
:class:`~fotogeo.io.raster.AtomicOutputs` (all or nothing). :func:`plan_grid` and :func:`write_orthophoto` are
also ``triangulate --orthorectify``'s (:mod:`fotogeo.tools.triangulate.ortho`): one orthorectification.
"""
from __future__ import annotations

import functools
import warnings
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...crs import crs_name
from ...errors import FotogeoWarning, InputError, ModelError
from ...geometry.dem import heights_at, underlying_dem
from ...geometry.georeference import Georeference
from ...geometry.vertical import as_pyproj
from ...geometry.lattice import ground_to_image_on_lattice, piecewise_on_lattice
from ...geometry.occlusion import visible_pixels
from ...io.compression import check_compression
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, open_raster
from ...io.warp import grid_covering, warp_to_grid
from ...io.warp_gdal import centres_to_map
from ...pixels import HALF, outline
from ...progress import as_progress
from ...options.products import ORTHO
from ..common.boundary import tool
from ..common.checks import check_output_grid
from .crs_rule import map_crs
from .inputs import SAME_CRS, holes, image_models, require_heights, terrain
from .products import dem_sigma_for, frame_covariances, product_paths, write_products


#: DEFLATE level of the orthophotos: with the horizontal predictor, level 1 writes ~4x faster than 6 for ~10 %
#: more bytes (NGI frames at 1 m: 0.6 s / 31 MB vs 2.8 s / 28 MB per frame)
ZLEVEL = 1


class OrthoMapping:
    """Map ``(X, Y)`` → image pixel through the terrain (module docstring, step 2); thread-safe (no state).

    ``surface``: the height source the occlusion test traces through (None: no test), ``step`` its
    horizontal step (map units), ``pyramid`` its :class:`~fotogeo.geometry.occlusion.MaxPyramid` (or None),
    ``tol`` its height margin; ``size`` the image's ``(width, height)``; ``error_threshold``: the largest
    distance (image pixels) of a frame's interpolated positions from the exact ones in :meth:`grid` (0: exact)."""

    def __init__(self, model, heights, size, surface=None, step: float = 1.0, tol: float = 0.05, pyramid=None,
                 error_threshold: float = 0.0):
        self.model, self.heights, self.size, self.error_threshold = model, heights, size, float(error_threshold)
        self.surface, self.step, self.tol, self.pyramid = surface, step, tol, pyramid

    def __call__(self, XY) -> np.ndarray:
        XY = np.asarray(XY, np.float64)
        P = np.column_stack([XY, heights_at(self.heights, XY)])
        px = self.model.forward(P)
        if self.surface is None:
            return px
        w, h = self.size
        with np.errstate(invalid="ignore"):
            outside = ~((px[:, 0] >= 0) & (px[:, 0] <= w) & (px[:, 1] >= 0) & (px[:, 1] <= h))
        px[outside] = np.nan
        return visible_pixels(self.model, self.surface, P, px, step=self.step, tol=self.tol, pyramid=self.pyramid)


    def grid(self, transform, r0: int, c0: int, h: int, w: int) -> np.ndarray:
        """The same positions for the ``h x w`` cell centres of a window of a north-up ``transform``
        (:func:`fotogeo.io.warp.warp_to_grid`): the DEM sampled once per row and column
        (:meth:`~fotogeo.geometry.dem.Dem.heights_grid`); the frame's camera coordinates likewise
        (``forward_grid``: two planes ``(2, h, w)``, column and row) — with ``error_threshold`` > 0 exactly only on
        a lattice that follows the DEM's cells, interpolated between and checked
        (:func:`~fotogeo.geometry.lattice.piecewise_on_lattice`: within ``error_threshold`` image pixels at the
        middles of the lattice's edges and rectangles, else exact there) —, any other model (rows ``(h·w, 2)``) on
        a checked lattice (:func:`~fotogeo.geometry.lattice.ground_to_image_on_lattice`: within 0.001 px of the
        exact positions)."""
        t = transform
        X = t.c + (c0 + HALF + np.arange(w)) * t.a
        Y = t.f + (r0 + HALF + np.arange(h)) * t.e
        if t.b or t.d or self.surface is not None:
            return self(centres_to_map(t, r0, c0, h, w))
        framed = hasattr(self.model, "forward_grid")
        breaks = self._breaks(X, Y) if framed and self.error_threshold > 0 else None
        if breaks is not None:
            def exact(r, c):  # at fractional rows and columns of the window
                Xc, Yr = t.c + (c0 + HALF + c) * t.a, t.f + (r0 + HALF + r) * t.e
                return self.model.forward_grid(Xc, Yr, self._heights_grid(Xc, Yr))
            return piecewise_on_lattice(exact, breaks[1], breaks[0], h, w, tol=self.error_threshold)
        Z = self._heights_grid(X, Y)
        if Z is None:
            return self(centres_to_map(t, r0, c0, h, w))
        if framed:
            return self.model.forward_grid(X, Y, Z)
        return ground_to_image_on_lattice(self.model.forward, X, Y, Z)

    def _breaks(self, X, Y):
        """``(columns, rows)``: the fractional indices where the height source's heights may have a kink (the DEM's
        cell boundaries and edges; none for a constant height), None when it cannot say."""
        if np.isscalar(self.heights):
            return np.empty(0), np.empty(0)
        breaks = getattr(self.heights, "breaks_grid", None)
        return breaks(X, Y) if breaks is not None else None

    def _heights_grid(self, X, Y):
        """Heights ``(len(Y), len(X))`` of a north-up window, None when the height source cannot give them so."""
        if np.isscalar(self.heights):
            return np.full((len(Y), len(X)), float(self.heights))
        grid_heights = getattr(self.heights, "heights_grid", None)
        return grid_heights(X, Y) if grid_heights is not None else None


class OrthoGrid(NamedTuple):
    transform: object
    width: int
    height: int
    resolution: float
    coverage: float


def output_paths(images, output) -> dict:
    """name → path: ``output`` for one image (unless it is a folder), ``output/<name>_ortho.tif`` for several."""
    from ...io.block import frame_key
    out = Path(output)
    if len(images) == 1 and not out.is_dir():
        return {frame_key(images[0]): out}
    if out.exists() and not out.is_dir():
        raise InputError(f"output {str(out)!r} is a file but {len(images)} images give one orthophoto each: give a "
                         f"folder")
    out.mkdir(parents=True, exist_ok=True)
    return {frame_key(p): out / f"{frame_key(p)}_ortho.tif" for p in images}


def _z_range(heights) -> tuple:
    if np.isscalar(heights):
        return float(heights), float(heights)
    return tuple(float(v) for v in heights.z_range)


def _surface_bounds(heights, crs):
    """The DEM's extent in the map CRS ``(x0, y0, x1, y1)``, None for a constant height."""
    if np.isscalar(heights):
        return None
    dem, sampled = underlying_dem(heights)
    r, c = dem.shape
    corners = np.array([dem.transform * p for p in ((0, 0), (c, 0), (c, r), (0, r))])
    if sampled:
        from ...crs import transform_points
        from ...geometry.vertical import horizontal_crs
        corners = transform_points(horizontal_crs(dem.crs), crs, corners)
    return (*corners.min(axis=0), *corners.max(axis=0))


def plan_grid(im, heights, crs, resolution, path, dem_name, compress: str = "deflate") -> OrthoGrid:
    """The checked output grid of one image (module docstring, step 1), to be written with ``compress``."""
    zlo, zhi = _z_range(heights)
    t = np.linspace(0, 1, 41)
    sample = np.column_stack([g.ravel() for g in np.meshgrid(t * im.width, t * im.height)])
    ground = im.model.inverse(sample, heights)
    hit = np.isfinite(ground[:, :2]).all(axis=1)
    coverage = float(hit.mean())
    if coverage == 0:
        raise InputError(f"DEM {dem_name!r} does not cover image {im.name!r}: none of its rays reaches the DEM; "
                         f"{SAME_CRS} ({as_pyproj(crs).to_string()})")
    if coverage < 0.999:
        pct = f"{100 * coverage:.0f}" if coverage < 0.995 else f"{min(100 * coverage, 99.9):.1f}"
        warnings.warn(f"DEM {dem_name!r} covers {pct} % of image {im.name!r}: the orthophoto is "
                      f"clipped to the DEM", FotogeoWarning, stacklevel=3)
    zmean = float(np.nanmean(ground[hit, 2])) if ground.shape[1] > 2 and np.isfinite(ground[hit, 2]).any() \
        else 0.5 * (zlo + zhi)
    XY = Georeference(im.model, heights=heights, crs=crs).footprint(im.width, im.height)
    if not np.isfinite(XY).all():  # partly off the DEM: the planes' outlines, clipped to the DEM
        rim = outline(im.width, im.height, 33)
        XY = np.vstack([im.model.inverse(rim, zlo)[:, :2], im.model.inverse(rim, zhi)[:, :2]])
        XY = XY[np.isfinite(XY).all(axis=1)]
        b = _surface_bounds(heights, crs)
        if b is not None:
            XY = np.clip(XY, b[:2], b[2:])
    gsd = Georeference(im.model, heights=zmean, crs=crs).ground_sample_distance(im.width, im.height)
    if not np.isfinite(gsd) or gsd <= 0:
        raise ModelError(f"image {im.name!r}: no ground sample distance at its centre; check its orientation")
    res = float(resolution or gsd)
    transform, width, height = grid_covering(XY, res)
    count, dtype = im.count, im.dtype  # as the image's reader found them (inputs.image_models)
    if count is None:  # built elsewhere without opening the file (triangulate --ortho, dsm)
        info = open_raster(im.path, "image")
        count, dtype = info.count, info.dtype
    check_output_grid(path, width, height, bands=count, dtype=dtype, source_pixels=im.width * im.height,
                      resolution=res, what=f"the orthophoto {str(path)!r}", compress=compress)
    return OrthoGrid(transform, width, height, res, coverage)


def nadir_point(im, heights, crs):
    """``(X, Y)`` of the image's nadir: under a frame's projection centre, else the ground of its centre pixel."""
    centre = getattr(im.model, "projection_centre", None)
    if centre is not None:
        return tuple(float(v) for v in centre[:2])
    return tuple(float(v) for v in Georeference(im.model, heights=heights, crs=crs).pixel_to_map(
        [[im.width / 2, im.height / 2]])[0])


def occlusion_surface(heights, dem):
    """The surface of the occlusion test, its march step (half a DEM cell) and its block maxima (a DEM in the map
    CRS without geoid shift; else None: every step sampled); a DSM with holes is refused."""
    if dem is None or np.isscalar(heights):
        raise InputError("occlusion masking needs a surface model: give the DSM (--dem)")
    d = underlying_dem(heights)[0]
    share = holes(d)
    if share > 0:
        from ...options.dsm import DSM
        reach = DSM["fill_max_distance"].default
        raise InputError(f"DSM {str(dem)!r} has nodata holes ({100 * share:.2g} % of its area): a hole would let "
                         f"hidden ground show through; fill them first (fotogeo dsm --fill, which fills {reach:g} "
                         f"cells from the data unless --fill-max-distance reaches farther; or gdal_fillnodata.py) or "
                         f"orthorectify without occlusion masking")
    from ...geometry.occlusion import MaxPyramid
    return heights, 0.5 * min(abs(d.transform.a), abs(d.transform.e)), MaxPyramid(d) if heights is d else None


def warn_dem_holes(dem, heights) -> None:
    """A warning naming the share of nodata holes of the DEM under the images (their orthophotos are nodata there);
    nothing for a constant height."""
    share = holes(underlying_dem(heights)[0]) if dem is not None and not np.isscalar(heights) else 0.0
    if share > 0:
        warnings.warn(f"DEM {str(dem)!r} has nodata holes ({100 * share:.2g} % of its area under "
                      f"the images): the orthophotos are nodata there; fill them (gdal_fillnodata.py) to keep those "
                      f"cells", FotogeoWarning, stacklevel=3)


def write_orthophoto(path, im, heights, crs, grid: OrthoGrid, resampling: str, progress, *,
                     occlusion=(None, 1.0, None), cog: bool = False,
                     error_threshold: float = ORTHO["error_threshold"].default, compress: str = "deflate") -> dict:
    """Resample the image ``im`` (:class:`~fotogeo.tools.ortho.inputs.OrthoImage`) onto ``grid``
    (:func:`plan_grid`) into ``path`` (module docstring, step 2), tagged ``FOTOGEO_NADIR`` (:func:`nadir_point`:
    ``fotogeo mosaic`` starts its seamlines where relief displacement vanishes); ``occlusion``: the
    ``(surface, step, pyramid)`` of :func:`occlusion_surface`, ``cog``: GDAL's COG layout instead of internal
    overviews; ``error_threshold``: :class:`OrthoMapping`'s; ``compress``: the file's compression
    (:mod:`fotogeo.io.compression`; DEFLATE at level :data:`ZLEVEL`). The report entry: the grid's size, resolution,
    transform, DEM coverage and what was written.
    The one orthorectification of frames and RPC images (``fotogeo ortho`` and ``triangulate --orthorectify``)."""
    surface, step, pyramid = occlusion
    mapping = OrthoMapping(im.model, heights, (im.width, im.height), surface, step, pyramid=pyramid,
                           error_threshold=error_threshold)
    nadir = " ".join(f"{v:.3f}" for v in nadir_point(im, heights, crs))
    written = warp_to_grid(im.path, path, mapping, crs=crs, transform=grid.transform, width=grid.width,
                           height=grid.height, resampling=resampling, progress=progress, overviews=not cog,
                           zlevel=ZLEVEL, tags={"FOTOGEO_NADIR": nadir}, reduce=True, compress=compress)
    if cog:
        from ...io.cog import convert_to_cog
        convert_to_cog(path, resampling, compress)
    return {"width": grid.width, "height": grid.height, "resolution": grid.resolution,
            "transform": list(grid.transform)[:6], "dem_coverage": grid.coverage, **written}


@tool(ORTHO, rasters={"dem": None, "geoid": None})
def ortho(images, output, *, dem=None, camera=None, eo=None, rpc: bool = False, model=None, height=None,
          dem_heights: str = "auto", geoid=None, occlusion: bool = False, resolution=None, dst_crs="auto",
          resampling: str = "nearest", error_threshold: float = 0.125, cog: bool = False, uncertainty: bool = False,
          dem_sigma=None, view_bands: bool = False, sfm_frame: str = "auto", compress: str = "deflate",
          overwrite: bool = False, progress=None) -> dict:
    """Orthorectify ``images`` onto the DEM into ``output`` (module docstring); returns the report dict. A folder
    made for several orthophotos is removed again when the run fails before writing into it."""
    images = [str(p) for p in ([images] if isinstance(images, (str, Path)) else images)]
    folder = Path(output) if len(images) > 1 or Path(output).is_dir() else None
    made = folder is not None and not folder.exists()
    try:
        return _ortho(images, output, dem=dem, camera=camera, eo=eo, rpc=rpc, model=model, height=height,
                      dem_heights=dem_heights, geoid=geoid, occlusion=occlusion, resolution=resolution,
                      dst_crs=dst_crs, resampling=resampling, error_threshold=error_threshold,
                      cog=cog, uncertainty=uncertainty, dem_sigma=dem_sigma, view_bands=view_bands, sfm_frame=sfm_frame,
                      compress=compress, overwrite=overwrite, progress=progress)
    except BaseException:
        if made and folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()
        raise


@contextmanager
def _crs_as_cause(dst_crs, eo):
    """A DEM that misses the images of an orientation file read in the CRS the caller gave (``dst_crs``; not an
    OpenSfM reconstruction, whose positions come in latitude/longitude) names that CRS as a likely cause: COLMAP's
    and fotogeo's lines carry no CRS, so coordinates of another zone land hundreds of kilometres away."""
    try:
        yield
    except InputError as exc:
        if dst_crs in (None, "auto") or eo is None or Path(eo).suffix.lower() == ".json" or SAME_CRS not in str(exc):
            raise
        raise InputError(f"{exc}; the orientation file {str(eo)!r} was read in the CRS given (dst_crs {dst_crs}): "
                         f"if its coordinates are in another CRS, give that one", option="dst_crs") from None


def _ortho(images, output, *, dem=None, camera=None, eo=None, rpc: bool = False, model=None, height=None,
           dem_heights: str = "auto", geoid=None, occlusion: bool = False, resolution=None, dst_crs="auto",
           resampling: str = "nearest", error_threshold: float = 0.125, cog: bool = False, uncertainty: bool = False,
           dem_sigma=None, view_bands: bool = False, sfm_frame: str = "auto", compress: str = "deflate",
           overwrite: bool = False, progress=None) -> dict:
    """The run of :func:`ortho`."""
    prog = as_progress(progress)
    if not images:
        raise InputError("give at least one image to orthorectify")
    compress = check_compression(compress)
    inputs = [*images, dem, camera, eo, geoid, model]
    paths = output_paths(images, output)
    extras = product_paths(paths, uncertainty, view_bands)
    for p in paths.values():
        check_output(p, inputs, overwrite, "orthophoto")
    for p in (q for e in extras.values() for q in e.values()):
        check_output(p, inputs, overwrite, "orthophoto product")
    require_heights([Path(p).stem for p in images], dem, height, rpc)
    rpc_of = _rpc_reader() if rpc else None  # each image's RPC read once in the run
    crs, rule = map_crs(dst_crs, dem, eo, images, rpc, camera, model, sfm_frame, rpc_of)
    said = []
    ims = image_models(images, crs, camera=camera, eo=eo, rpc=rpc, model=model, sfm_frame=sfm_frame, said=said,
                       rpc_of=rpc_of)
    with _crs_as_cause(dst_crs, eo):
        heights, ref, notes = terrain(dem, height, crs, ims, dem_heights=dem_heights, geoid=geoid)
    surface, step, pyramid = occlusion_surface(heights, dem) if occlusion else (None, 1.0, None)
    if not occlusion:
        warn_dem_holes(dem, heights)
    sigma_h = dem_sigma_for(dem_sigma, heights, crs) if uncertainty else None
    covs = frame_covariances(eo, ims) if uncertainty else {}
    with _crs_as_cause(dst_crs, eo):
        grids = {im.name: plan_grid(im, heights, crs, resolution, paths[im.name], str(dem), compress) for im in ims}
    prog(0.05, "grids planned")
    rep = {"fotogeo": "ortho", "crs": crs_name(crs), "crs_rule": rule, "height_reference": ref, "notes": notes,
           "occlusion": bool(occlusion), "resampling": resampling, "images": {}}
    if said:
        rep["orientation"] = said
    if sigma_h is not None:
        rep["dem_sigma_m"], rep["dem_sigma_rule"] = sigma_h
    with AtomicOutputs(overwrite) as out:
        for k, im in enumerate(ims):
            g = grids[im.name]
            stage = prog.stage(0.05 + 0.95 * k / len(ims), 0.05 + 0.95 * (k + 1) / len(ims),
                               f"orthorectifying {im.name}")
            entry = write_orthophoto(out.temp(paths[im.name]), im, heights, crs, g, resampling, stage,
                                     occlusion=(surface, step, pyramid), cog=cog, error_threshold=error_threshold,
                                     compress=compress)
            rep["images"][im.name] = {"path": str(paths[im.name]), "kind": im.kind, **entry,
                                      **write_products(out, extras[im.name], im, heights, g, crs, covs.get(im.name),
                                                       sigma_h, compress)}
        out.commit()
    prog(1.0, "done")
    return rep


def _rpc_reader():
    """:func:`fotogeo.io.rpc_image.image_rpc`, remembered per path for one run (imported here: the RPC reader
    imports the models, and scipy with them, which a run of frames does not need)."""
    from ...io.rpc_image import image_rpc
    return functools.lru_cache(maxsize=None)(image_rpc)
