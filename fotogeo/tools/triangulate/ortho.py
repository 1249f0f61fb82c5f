"""Frames on the ground after a bundle adjustment: footprints and orthorectified frames.

Each adjusted frame becomes a ground → image model (:class:`AdjustedFrame`: the bundle
adjustment's collinearity with Brown's distortion, :mod:`fotogeo.orientation.bundle_jacobian`)
placed on the terrain by :class:`fotogeo.geometry.georeference.Georeference`:

* **footprints** — the image outline (33 points per edge) intersected with the DEM, or with the
  plane at the mean height of the adjusted points when there is no DEM;
* **orthorectified frames** — the terrain rectification of ``fotogeo orient --rectify`` (the
  north-up grid at the frame's ground sample distance, checked for its size, then every output
  cell's centre → its DEM height → the image pixel, resampled by :func:`fotogeo.io.warp.warp_to_grid`);
* **uncertainty rasters** (``uncertainty``) — beside each orthophoto ``<frame>_ortho_sigma.tif``, the predicted
  planimetric σ of every cell from this adjustment's covariance (the report's ``frames[].covariance``) and the
  DEM's σ: the raster ``fotogeo ortho --uncertainty`` writes from the same report
  (:mod:`fotogeo.tools.ortho_products`, :mod:`fotogeo.orientation.ground_sigma`).

The inverse (pixel → ground) removes the distortion by the fixed-point iteration of
:func:`~fotogeo.orientation.bundle_jacobian.undistort_rays`, then intersects the pinhole ray.
"""
from __future__ import annotations

import warnings

import numpy as np

from ...errors import FotogeoWarning, InputError, ModelError
from ...geometry.camera import OrientedFrame
from ...geometry.dem import is_height_source
from ...geometry.georeference import Georeference
from ...orientation import bundle_jacobian as bj
from ...pixels import as_points


class AdjustedFrame:
    """Ground ``(X, Y, Z)`` → pixel of one adjusted frame, distortion included (module docstring)."""

    src_dims = 3

    def __init__(self, camera, eo, distortion: dict, name: str = ""):
        self.frame = OrientedFrame(camera, eo, name)
        self.interior = np.array([camera.focal_length, *camera.principal_point,
                                  *(float(distortion.get(k, 0.0)) for k in bj.INTERIOR_NAMES[3:])])
        self.scale = bj.pixel_scale(camera)

    @property
    def projection_centre(self) -> np.ndarray:
        """The adjusted projection centre ``(X, Y, Z)``: every line of sight ends there
        (:mod:`fotogeo.geometry.occlusion`)."""
        return self.frame.eo.centre

    def forward(self, XYZ) -> np.ndarray:
        c = self.frame.world_to_camera(as_points(XYZ, 3, "ground points"))
        px = bj.project_camera(c, self.interior, self.scale)
        px[c[:, 2] <= 0] = np.nan
        return px

    def forward_grid(self, X, Y, Z) -> np.ndarray:
        """:meth:`forward` of the grid points ``(X[col], Y[row], Z[row, col])`` (``Z`` ``(len(Y), len(X))``),
        row by row ``(N, 2)``: the camera coordinates ``c_k = Σ M_ik (P_i − C_i)`` (``M`` = ``R·D``) are built
        from one term per column, one per row and one per point; a camera without distortion skips Brown's
        terms."""
        M, C = self.frame.eo.rotation_cv, self.frame.eo.centre
        dx, dy = np.asarray(X, float) - C[0], np.asarray(Y, float) - C[1]
        Z = np.asarray(Z, float)
        c = []
        for k in range(3):  # in place: c_k = M_2k·Z + (M_0k·dx − M_2k·Z0) per column + M_1k·dy per row
            v = np.multiply(Z, M[2, k])
            v += (dx * M[0, k] - C[2] * M[2, k])[None, :]
            v += (dy * M[1, k])[:, None]
            c.append(v)
        behind = (c[2] <= 0).ravel()
        with np.errstate(invalid="ignore", divide="ignore"):
            if np.any(self.interior[3:]):
                px = bj.project_camera(np.column_stack([v.ravel() for v in c]), self.interior, self.scale)
            else:  # pinhole: col = f·sx·x/z + ppx, row = f·sy·y/z + ppy
                f, ppx, ppy = self.interior[:3]
                px = np.empty((c[0].size, 2))
                for k, (s, pp) in enumerate(((f * self.scale[0], ppx), (f * self.scale[1], ppy))):
                    np.divide(c[k], c[2], out=c[k])
                    c[k] *= s
                    c[k] += pp
                    px[:, k] = c[k].ravel()
        if behind.any():
            px[behind] = np.nan
        return px

    def inverse(self, pixel, heights=None, **_) -> np.ndarray:
        rays = bj.undistort_rays(as_points(pixel, 2, "pixels"), self.interior, self.scale)
        pinhole = rays @ self.frame.camera.K[:2].T
        if is_height_source(heights):
            return self.frame.pixel_to_world(pinhole, heights)
        return self.frame.pixel_to_world_at(pinhole, heights)


def frame_models(result, block) -> list:
    """One :class:`AdjustedFrame` per frame of the adjusted block."""
    return [AdjustedFrame(result.camera, e, result.distortion, n) for n, e in zip(block.frames, result.eo)]


def terrain(dem, crs, result):
    """The height source: the DEM in the map CRS, else the mean height of the adjusted points."""
    if dem is not None:
        from ..rectify import dem_heights
        return dem_heights(dem, crs)
    z = result.point_xyz[:, 2]
    return float(np.nanmean(z)) if np.isfinite(z).any() else 0.0


def footprints(result, block, heights, crs) -> dict:
    """The ``footprints`` layer: one polygon per frame on ``heights``; frames that leave the DEM
    get the outline of the points that reach it (empty when none does)."""
    import shapely
    w, h = block.camera.image_size
    polys, complete = [], []
    for model in frame_models(result, block):
        XY = Georeference(model, heights=heights, crs=crs).footprint(w, h)
        ok = np.isfinite(XY).all(axis=1)
        polys.append(shapely.polygons(XY[ok]) if ok.sum() >= 4 else shapely.Polygon())
        complete.append(bool(ok.all()))
    return {"geometry": np.array(polys, dtype=object), "name": np.array(block.frames, dtype=str),
            "on_terrain": np.array(complete), "area_m2": np.array([p.area for p in polys])}


def common_resolution(grids: dict) -> float | None:
    """One pixel size for every orthophoto of a mosaic (``fotogeo mosaic`` needs one lattice): the median of the
    frames' ground sample distances (their grids' resolutions), rounded to 3 significant digits; None when no
    frame has a grid."""
    res = [g.resolution for g in grids.values() if not isinstance(g, str)]
    return float(f"{np.median(res):.3g}") if res else None


def ortho_grids(paths: dict, result, block, frames, dem, crs, resolution, quiet: bool = False) -> dict:
    """Per frame, the checked output grid of its orthorectification (:func:`fotogeo.tools.rectify.rectify_grid`,
    the mean height of the adjusted points); nothing is resampled yet. A frame whose grid cannot be made (e.g.
    off the DEM) gets the reason instead (a string): it is reported and skipped, never losing the adjustment's
    outputs (``quiet``: without the warning)."""
    from ...io.raster import open_raster
    from ..rectify import rectify_grid
    points = result.point_xyz[np.isfinite(result.point_xyz).all(axis=1)]
    ground = points if len(points) else np.zeros((1, 3))
    grids = {}
    for model, path, name in zip(frame_models(result, block), frames, block.frames):
        try:
            grids[name] = rectify_grid(paths[name], open_raster(path, "frame"), model, crs, ground, dem, None,
                                       resolution)
        except (ModelError, InputError) as exc:
            grids[name] = f"not orthorectified: {str(exc)[:300]}; check that the DEM covers the frame's footprint"
            if not quiet:
                warnings.warn(f"frame {name!r} {grids[name]}", FotogeoWarning, stacklevel=2)
    return grids


def orthorectify(temp_paths: dict, grids: dict, frames, block, crs, resampling, progress) -> dict:
    """Resample every frame onto its grid (:func:`ortho_grids`) into ``temp_paths``; a summary per frame."""
    from ...io.raster import open_raster
    from ..rectify import rectify_image
    out = {}
    for k, (path, name) in enumerate(zip(frames, block.frames)):
        stage = progress.stage(k / len(frames), (k + 1) / len(frames), f"orthorectifying {name}")
        if isinstance(grids.get(name), str) or name not in temp_paths:  # no grid: the frame is reported, the other outputs are still written
            out[name] = {"error": grids.get(name, "no grid")}
            continue
        out[name] = rectify_image(temp_paths[name], open_raster(path, "frame"), crs, grids[name], resampling, stage)
        _tag_nadir(temp_paths[name], grids[name].geo.model)
    return out


def sigma_paths(ortho_paths: dict, uncertainty: bool) -> dict:
    """``sigma:<frame>`` → ``<frame>_ortho_sigma.tif`` beside each orthophoto path of ``ortho_paths``
    (``ortho:<frame>`` keys) with ``uncertainty``; refused without orthophotos to put them beside."""
    if not uncertainty:
        return {}
    if not ortho_paths:
        raise InputError("--uncertainty writes a σ raster beside each orthophoto: give --orthorectify (or --mosaic)",
                         option="uncertainty")
    from ..ortho_products import product_paths
    names = {k.split(":", 1)[1]: p for k, p in ortho_paths.items()}
    return {f"sigma:{n}": d["sigma"] for n, d in product_paths(names, True, False).items()}


def sigma_of_dem(paths: dict, heights, dem_sigma, crs):
    """``(σ_h m, rule)`` of the height source ``heights`` (:func:`terrain`) when ``paths`` has σ rasters
    (:func:`sigma_paths`), else None; checked before anything is written (a constant height needs ``dem_sigma``:
    :func:`fotogeo.tools.ortho_products.dem_sigma_for`)."""
    if not any(k.startswith("sigma:") for k in paths):
        return None
    from ..ortho_products import dem_sigma_for
    return dem_sigma_for(dem_sigma, heights, crs)


def write_sigma_rasters(out, paths: dict, grids: dict, done: dict, rep: dict, heights, crs, size, sigma_h) -> None:
    """Each orthorectified frame's σ raster (:func:`sigma_paths`) written through ``out``
    (:class:`~fotogeo.io.raster.AtomicOutputs`) on its orthophoto's grid, from the covariances of the report
    ``rep`` (as ``fotogeo ortho --uncertainty`` reads them from report.json), ``heights`` and the image ``size``
    ``(width, height)``; its entry goes into ``done[frame]`` (the report's ``orthorectified``), the DEM's σ
    into ``rep``."""
    from types import SimpleNamespace

    from ...orientation.ground_sigma import covariances_from_report
    from ..ortho_products import write_products
    covs = covariances_from_report(rep)
    rep["dem_sigma_m"], rep["dem_sigma_rule"] = sigma_h
    for name, entry in done.items():
        if "error" in entry or f"sigma:{name}" not in paths:
            continue
        g = grids[name]
        im = SimpleNamespace(model=g.geo.model, width=size[0], height=size[1])
        entry.update(write_products(out, {"sigma": paths[f"sigma:{name}"]}, im, heights, g, crs, covs[name],
                                    sigma_h))


def _tag_nadir(path, frame) -> None:
    """``FOTOGEO_NADIR`` (X Y of the projection centre, the ground point without relief displacement), as
    ``fotogeo ortho`` writes it: ``fotogeo mosaic`` starts its seamlines there."""
    from ...io.raster import ropen
    with ropen(path, "r+") as ds:
        ds.update_tags(FOTOGEO_NADIR=" ".join(f"{v:.3f}" for v in frame.projection_centre[:2]))
